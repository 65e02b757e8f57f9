// The real-time engine (engine.h) on lavapipe: the picture against the offline refinement, the
// screen-space bound, the ring-buffer cache under stress, determinism, and bad input.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "gpu_test.h"
#include "pnsplat/engine/engine.h"
#include "pnsplat/refine/input.h"
#include "pnsplat/refine/ply.h"
#include "pnsplat/refine/refiner.h"
#include "pnsplat/refine/shapes.h"
#include "test_data.h"

namespace pnsplat {
namespace {

using engine::Camera;
using engine::Engine;
using engine::EngineSettings;
using engine::FrameOptions;
using engine::FrameReport;
using engine::RgbaImage;

// The sanitizer builds run the long tests shorter (the same checks on fewer frames).
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif

PointSet load(const std::string& file) {
    auto data = readPly(test::dataDir() / file);
    EXPECT_TRUE(data.ok()) << data.error().message;
    PointSet points = std::move(data).value().points;
    EXPECT_TRUE(completeInput(points, 2).ok());
    return points;
}

EngineSettings adaptive(std::uint32_t width, std::uint32_t height) {
    EngineSettings settings;
    settings.render.width = width;
    settings.render.height = height;
    settings.render.background = {1.0f, 1.0f, 1.0f};
    settings.workers = 2;
    return settings;
}

// The largest projected diameter, in pixels, that 99 % of the front-facing splats in view stay
// within (the screen-space measure of the engine's FrameReport, here for any point set).
float splatSizeP99(const PointSet& points, const Camera& camera, std::uint32_t width, std::uint32_t height) {
    const glm::mat4 view = camera.view();
    const float tanY = std::tan(camera.fovY * 0.5f), tanX = tanY * float(width) / float(height);
    const float focal = float(height) / (2.0f * tanY);
    std::vector<float> sizes;
    for (std::size_t i = 0; i < points.size(); ++i) {
        const glm::vec3 p = glm::vec3(view * glm::vec4(points.position[i], 1.0f));
        const float depth = -p.z;
        if (!(depth > 1e-6f) || std::abs(p.x) > tanX * depth || std::abs(p.y) > tanY * depth) continue;
        if (glm::dot(points.normal[i], points.position[i] - camera.eye) >= 0.0f) continue;
        sizes.push_back(2.0f * points.radius[i] * focal / depth);
    }
    if (sizes.empty()) return 0.0f;
    const auto at = sizes.begin() + static_cast<std::ptrdiff_t>(sizes.size() * 99 / 100);
    std::nth_element(sizes.begin(), at, sizes.end());
    return *at;
}

class EngineTest : public test::GpuTest {};

struct View {
    std::string name, file;
    // The camera from the model's bounding sphere: eye at centre + distance · radius · direction.
    glm::vec3 direction;
    float distance;
    glm::vec3 lookOffset{0.0f}; // target = centre + lookOffset · radius
};

// Acceptance 1 and 2 of the real-time issue: at a far, a close-up and a grazing camera of sparse
// real models, `render --adaptive` (the engine in lockstep, settled at 2 px) against a render of
// the offline refinement to the level at which the splats in view are at most 2 px (99th
// percentile): PSNR and SSIM, the share of splats over the threshold, and the points used.
TEST_F(EngineTest, SettledPictureMatchesTheOfflineRefinement) {
    const std::vector<View> views = {
        {"far (igea)", "igea-600-uniform.ply", {0.0f, 0.0f, 1.0f}, 2.9f},
        {"close-up (igea)", "igea-600-uniform.ply", {0.25f, 0.1f, 1.0f}, 1.35f, {0.05f, 0.1f, 0.4f}},
        {"grazing (bunny)", "bunny-3500-random.ply", {0.15f, 1.0f, 0.35f}, 2.4f, {0.0f, -0.15f, 0.0f}},
    };
    constexpr std::uint32_t kWidth = 320, kHeight = 240;
    for (const View& v : views) {
        SCOPED_TRACE(v.name);
        PNSPLAT_REQUIRE_DATA(v.file);
        const PointSet input = load(v.file);
        auto created = Engine::create(context(), input, adaptive(kWidth, kHeight));
        ASSERT_TRUE(created.ok()) << created.error().message;
        Engine& engine = **created;
        const engine::Sphere bounds = engine.bounds();
        Camera camera;
        camera.target = bounds.centre + v.lookOffset * bounds.radius;
        camera.eye = bounds.centre + glm::normalize(v.direction) * v.distance * bounds.radius;
        camera.fovY = 40.0f * std::numbers::pi_v<float> / 180.0f;
        FrameOptions options;
        options.lockstep = options.readBack = options.measureSplats = true;
        auto drawn = engine.frame(camera, options);
        ASSERT_TRUE(drawn.ok()) << drawn.error().message;
        ASSERT_TRUE(drawn->settled);
        const RgbaImage adaptiveImage = engine.image(drawn->frame).value();
        std::uint32_t deepest = 0;
        for (const NodeId id : engine.drawn()) deepest = std::max(deepest, engine.tree().node(id).level);

        // The offline refinement, level after level, until the splats in view are at most 2 px.
        Refiner offline(input, RefineOptions{});
        while (splatSizeP99(offline.points(), camera, kWidth, kHeight) > 2.0f) offline.refineLevel();
        const RgbaImage offlineImage = render(offline.points(), adaptive(kWidth, kHeight).render, camera);
        const auto difference = engine::compareImages(adaptiveImage, offlineImage);
        ASSERT_TRUE(difference.ok());
        const double ratio = double(engine.tree().pointCount()) / double(offline.points().size());
        std::printf("[%s] PSNR %.2f dB, SSIM %.4f; adaptive: %zu splats drawn, largest %.2f px, %.3f %% above "
                    "2 px, levels to %u, %zu points in the tree; offline: %u levels, %zu points (ratio %.3f)\n",
                    v.name.c_str(), difference->psnr, difference->ssim, drawn->splatsDrawn,
                    double(drawn->maxSplatPx), 100.0 * drawn->overThreshold, deepest, engine.tree().pointCount(),
                    offline.levels(), offline.points().size(), ratio);
        EXPECT_GE(difference->psnr, 38.0);
        EXPECT_GE(difference->ssim, 0.98);
        EXPECT_LE(drawn->overThreshold, 0.01); // acceptance 2: 99 % at or below the threshold
        if (v.name.rfind("close-up", 0) == 0) {
            EXPECT_LE(ratio, 1.0 / 3.0);
        }
    }
}

} // namespace
} // namespace pnsplat
