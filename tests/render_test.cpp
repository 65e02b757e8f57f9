// Rendering on lavapipe: analytic single-disk and occlusion oracles, the two paths against each
// other, golden images that a broken pass fails, culling, and bad input.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <numbers>
#include <string>
#include <utility>

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include "gpu_test.h"
#include "pnsplat/engine/camera.h"
#include "pnsplat/refine/angles.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/radius_estimation.h"
#include "pnsplat/refine/refiner.h"
#include "pnsplat/refine/shapes/shapes.h"
#include "test_data.h"
#include "test_random.h"

namespace pnsplat {
namespace {

using engine::Camera;
using engine::RenderPath;
using engine::RenderSettings;
using engine::RgbaImage;
using test::GpuTest;

PointSet disk(glm::vec3 centre, glm::vec3 normal, float radius, glm::u8vec3 colour) {
    PointSet p;
    p.position = {centre};
    p.normal = {normal};
    p.radius = {radius};
    p.colour = {colour};
    return p;
}

Camera lookingDownZ(float distance, float fovDegrees = 40.0f) {
    Camera camera;
    camera.eye = {0.0f, 0.0f, distance};
    camera.target = {0.0f, 0.0f, 0.0f};
    camera.fovY = radians(fovDegrees);
    return camera;
}

RenderSettings small(RenderPath path, std::uint32_t w = 256, std::uint32_t h = 256) {
    RenderSettings s;
    s.width = w;
    s.height = h;
    s.path = path;
    s.background = {0.0f, 0.0f, 0.0f};
    return s;
}

// Whether pixel (x, y) lies in the picture and is black (the tests' background); x and y may have
// wrapped below 0.
bool backgroundAt(const RgbaImage& image, std::uint32_t x, std::uint32_t y) {
    return x < image.width && y < image.height && glm::u8vec3(image.at(x, y)) == glm::u8vec3(0);
}

// Whether one of the pixel's four neighbours is background (the pixels the smooth silhouette blends).
bool besideBackground(const RgbaImage& image, std::uint32_t x, std::uint32_t y) {
    return backgroundAt(image, x + 1, y) || backgroundAt(image, x - 1, y) || backgroundAt(image, x, y + 1) ||
           backgroundAt(image, x, y - 1);
}

// The white disk of radius 1 seen from 5 away (lookingDownZ(5), 40 degrees, 256 px high): the
// radius of its image in pixels, (1/5) / tan(20°) · 128.
const double kWhiteDiskRadiusPx = 0.2 / std::tan(radians(20.0)) * 128.0;

PointSet withRadii(PointSet points) {
    estimateRadii(points, 1);
    return points;
}

// A red disk of radius 1 at the origin, 3 in front of a blue one of radius 2.5, both facing +z.
PointSet redDiskBeforeBlueOne() {
    PointSet points = disk({0, 0, 0}, {0, 0, 1}, 1.0f, {255, 0, 0});
    points.appendFrom(disk({0, 0, -3}, {0, 0, 1}, 2.5f, {0, 0, 255}), 0);
    return points;
}

class PathTest : public GpuTest, public ::testing::WithParamInterface<RenderPath> {};

// A white disk of radius 1 facing a camera 5 away: its image is the circle of radius
// (1/5) / tan(20°) · 128 = 70.3 px about the image centre, white inside, background outside.
TEST_P(PathTest, SingleDiskCoversExactlyItsProjection) {
    const RgbaImage image =
        render(disk({0, 0, 0}, {0, 0, 1}, 1.0f, {255, 255, 255}), small(GetParam()), lookingDownZ(5.0f));
    ASSERT_EQ(image.width, 256u);
    int inside = 0, outside = 0;
    for (std::uint32_t y = 0; y < 256; ++y)
        for (std::uint32_t x = 0; x < 256; ++x) {
            const double d = std::hypot(x + 0.5 - 128.0, y + 0.5 - 128.0);
            const glm::u8vec4 c = image.at(x, y);
            if (d < kWhiteDiskRadiusPx - 1.0) {
                ++inside;
                EXPECT_GT(c.x, 200) << x << "," << y;
            } else if (d > kWhiteDiskRadiusPx + 1.0) {
                ++outside;
                EXPECT_EQ(c.x, 0) << x << "," << y;
            }
        }
    EXPECT_GT(inside, 14000);
    EXPECT_GT(outside, 40000);
    EXPECT_EQ(image.at(128, 128).x, 255); // albedo 1 lit head-on saturates
}

// A red disk 3 in front of a larger blue one: red where both overlap (beyond ε·r), blue around
// it; with a depth offset larger than their distance the two blend.
TEST_P(PathTest, NearerDiskHidesFartherOne) {
    const PointSet points = redDiskBeforeBlueOne();
    RenderSettings settings = small(GetParam());
    const Camera camera = lookingDownZ(8.0f);
    const RgbaImage image = render(points, settings, camera);
    ASSERT_EQ(image.width, 256u);
    // Red (plus the white specular highlight of the headlight) in the middle; blue at 50 px, beyond
    // the red disk (≈ 37 px) and inside the blue one.
    EXPECT_GT(image.at(128, 128).x, image.at(128, 128).z + 80);
    EXPECT_GT(image.at(128, 128 + 50).z, image.at(128, 128 + 50).x + 80);

    settings.depthOffset = 4.0f; // ε·r = 4 for the red disk: the blue one now blends in
    const RgbaImage blended = render(points, settings, camera);
    ASSERT_EQ(blended.width, 256u);
    EXPECT_GT(blended.at(128, 128).x, 100);
    EXPECT_GT(blended.at(128, 128).z, image.at(128, 128).z + 30);
}

// The outer silhouette is smoothed (RenderSettings::smoothEdges): the far blue disk's contour
// against the background blends toward it, darker than the hard picture but not background; the
// near red disk's contour over the blue one, a low weight too, stays as it was (the passes keep no
// farther surface to blend with). Only pixels beside the background change.
TEST_P(PathTest, TheOuterSilhouetteBlendsTowardTheBackground) {
    const PointSet points = redDiskBeforeBlueOne();
    RenderSettings settings = small(GetParam());
    const Camera camera = lookingDownZ(8.0f);
    const RgbaImage smooth = render(points, settings, camera);
    settings.smoothEdges = false;
    const RgbaImage hard = render(points, settings, camera);
    ASSERT_EQ(smooth.width, 256u);
    ASSERT_EQ(hard.width, 256u);
    std::size_t changed = 0;
    for (std::uint32_t y = 0; y < 256; ++y)
        for (std::uint32_t x = 0; x < 256; ++x) {
            const glm::u8vec4 a = smooth.at(x, y), b = hard.at(x, y);
            if (a == b) continue;
            ++changed;
            EXPECT_TRUE(besideBackground(hard, x, y)) << x << "," << y;
            EXPECT_LE(a.z, b.z) << x << "," << y;
            EXPECT_GT(a.z, 0) << x << "," << y;
        }
    // The blue disk's contour, about 2 pi 80 pixels long; each of its pixels has a weight below 1.
    EXPECT_GT(changed, 300u);
}

// How much the outer silhouette blends, against the Gaussian: the white disk of
// SingleDiskCoversExactlyItsProjection, whose weight at a pixel is exp(-k ρ²) (ρ its distance from
// the centre over the disk's radius on screen, k the sharpness), over a black background. A pixel of
// its rim beside the background is drawn as mix(background, colour, w / kEdgeWeight): its hard value
// times exp(-k ρ²). Fails with the weight's square root or square, or another kEdgeWeight.
TEST_P(PathTest, TheSilhouetteBlendsByTheGaussianWeight) {
    constexpr double kEdgeWeight = 1.0; // shaders/gpu_types.h, not visible to the tests
    const PointSet white = disk({0, 0, 0}, {0, 0, 1}, 1.0f, {255, 255, 255});
    RenderSettings settings = small(GetParam());
    const RgbaImage smooth = render(white, settings, lookingDownZ(5.0f));
    settings.smoothEdges = false;
    const RgbaImage hard = render(white, settings, lookingDownZ(5.0f));
    ASSERT_EQ(smooth.width, 256u);
    ASSERT_EQ(hard.width, 256u);
    std::size_t rim = 0;
    for (std::uint32_t y = 0; y < 256; ++y)
        for (std::uint32_t x = 0; x < 256; ++x) {
            if (backgroundAt(hard, x, y) || !besideBackground(hard, x, y)) continue;
            const double rho = std::hypot(x + 0.5 - 128.0, y + 0.5 - 128.0) / kWhiteDiskRadiusPx;
            const double weight = std::exp(-double(settings.sharpness) * rho * rho) / kEdgeWeight;
            EXPECT_NEAR(double(smooth.at(x, y).x), double(hard.at(x, y).x) * weight, 2.0)
                << x << "," << y << " rho " << rho;
            ++rim;
        }
    EXPECT_GT(rim, 300u); // about 2 pi 70 pixels
}

// A pinhole (RenderSettings::fillPinholes): four small disks, of four colours, around the centre of
// the picture, each covering one of the centre pixel's four neighbours and not the centre (0.9 px
// in radius, 1.4 px from it). The centre is drawn as the other pixel of its pair, (2x, y) and
// (2x + 1, y): its left neighbour in a picture 255 pixels wide (centre 127), its right one at 257
// (centre 128). Background with the fill off, and when any one of the four disks is missing (a gap
// open on that side). Without colours (the compute path's one-word sums) it is filled too.
TEST_P(PathTest, APinholeIsDrawnAsTheOtherPixelOfItsPair) {
    const Camera camera = lookingDownZ(5.0f);
    const float pxPerUnit = float(kWhiteDiskRadiusPx) * 127.5f / 128.0f; // 255 pixels high, not 256
    const float step = 1.4f / pxPerUnit, radius = 0.9f / pxPerUnit;
    const std::array<PointSet, 4> disks = {disk({-step, 0, 0}, {0, 0, 1}, radius, {255, 0, 0}),
                                           disk({step, 0, 0}, {0, 0, 1}, radius, {0, 255, 0}),
                                           disk({0, -step, 0}, {0, 0, 1}, radius, {0, 0, 255}),
                                           disk({0, step, 0}, {0, 0, 1}, radius, {255, 255, 255})};
    const auto allBut = [&](std::size_t missing) {
        PointSet points;
        for (std::size_t k = 0; k < disks.size(); ++k)
            if (k != missing) points.appendFrom(disks[k], 0);
        return points;
    };
    const PointSet four = allBut(disks.size());
    PointSet plain = four;
    plain.colour.clear();
    for (const std::uint32_t width : {255u, 257u}) {
        SCOPED_TRACE(width);
        RenderSettings settings = small(GetParam(), width, 255);
        const std::uint32_t x = (width - 1) / 2, y = 127;
        const RgbaImage filled = render(four, settings, camera);
        ASSERT_EQ(filled.width, width);
        for (const auto& [nx, ny] : {std::pair{x - 1, y}, {x + 1, y}, {x, y - 1}, {x, y + 1}})
            EXPECT_FALSE(backgroundAt(filled, nx, ny)) << nx << "," << ny;
        const glm::u8vec3 left(filled.at(x - 1, y)), right(filled.at(x + 1, y));
        EXPECT_NE(left, right);
        EXPECT_EQ(glm::u8vec3(filled.at(x, y)), x % 2 == 1 ? left : right);
        EXPECT_FALSE(backgroundAt(render(plain, settings, camera), x, y));
        for (std::size_t missing = 0; missing < disks.size(); ++missing) {
            const RgbaImage open = render(allBut(missing), settings, camera);
            ASSERT_EQ(open.width, width);
            EXPECT_TRUE(backgroundAt(open, x, y)) << "without disk " << missing;
        }

        settings.fillPinholes = false;
        EXPECT_TRUE(backgroundAt(render(four, settings, camera), x, y));
        EXPECT_TRUE(backgroundAt(render(plain, settings, camera), x, y));
    }
}

// One splat far larger than the screen covers every pixel (no size limit), also on screens of
// more pixels than lavapipe lets one invocation's loops visit (65,535: the compute path lists such
// a splat and draws it with workgroups of its own, gpu::kBigSplatPixels): one without colour (one
// sum a pixel on the compute path), and a red and a blue one (four sums), which mix everywhere.
// At 300 × 1400 an invocation walks up to 11 runs (2,800 runs of at most 256 pixels over 256
// invocations), at 1100 × 60 a row is five runs. Without the big splats' own dispatch, the compute
// path left 400 × 300 background from row 163 on (tried).
TEST_P(PathTest, HugeSplatCoversTheScreen) {
    PointSet one = disk({0, 0, 0}, {0, 0, 1}, 50.0f, {255, 255, 255});
    one.colour.clear();
    PointSet two = disk({0, 0, 0}, {0, 0, 1}, 50.0f, {255, 0, 0});
    two.appendFrom(disk({0, 0, 0}, {0, 0, 1}, 50.0f, {0, 0, 255}), 0);
    for (const auto& [width, height] :
         {std::pair{64u, 48u}, std::pair{400u, 300u}, std::pair{300u, 1400u}, std::pair{1100u, 60u}}) {
        SCOPED_TRACE(fmt::format("{} x {}", width, height));
        const RgbaImage plain = render(one, small(GetParam(), width, height), lookingDownZ(2.0f));
        ASSERT_EQ(plain.width, width);
        const RgbaImage mixed = render(two, small(GetParam(), width, height), lookingDownZ(2.0f));
        ASSERT_EQ(mixed.width, width);
        for (std::uint32_t y = 0; y < height; ++y)
            for (std::uint32_t x = 0; x < width; ++x) {
                ASSERT_GT(plain.at(x, y).x, 100) << x << "," << y;
                ASSERT_GT(mixed.at(x, y).x, 50) << x << "," << y;
                ASSERT_GT(mixed.at(x, y).z, 50) << x << "," << y;
            }
    }
}

// Splats of one pixel, each alone in its tile of the compute path's normalization (gpu::kTileWidth
// × kTileHeight pixels): at a tile's last column and row, at its first, and in the partial tiles
// of an odd-sized picture. Each is drawn, and every other pixel is the background, on both paths
// (backgroundPixel's word: with halves rounded away from zero, every pixel counted covered).
// With the tile scan reading the first pixel of each pair only, or 31 of a tile's 32 rows, the
// compute path loses the splats at odd columns or last rows (tried).
TEST_P(PathTest, EverySplatIsDrawnWhereverItFallsInTheTiles) {
    RenderSettings settings = small(GetParam(), 333, 201);
    settings.background = {0.3f, 0.5f, 0.7f}; // two channels on a half: 76.5 and 178.5 (backgroundPixel)
    const Camera camera = lookingDownZ(5.0f);
    const float tanY = std::tan(camera.fovY / 2.0f), aspect = 333.0f / 201.0f;
    const float unitsPerPx = 2.0f * tanY * 5.0f / 201.0f;
    const std::array<std::array<std::uint32_t, 2>, 6> pixels = {
        {{63, 31}, {64, 32}, {129, 63}, {255, 159}, {331, 200}, {332, 0}}};
    PointSet points;
    for (const auto& [x, y] : pixels) {
        const float ndcX = 2.0f * (float(x) + 0.5f) / 333.0f - 1.0f,
                    ndcY = 2.0f * (float(y) + 0.5f) / 201.0f - 1.0f;
        points.appendFrom(disk({ndcX * tanY * aspect * 5.0f, -ndcY * tanY * 5.0f, 0.0f}, {0, 0, 1},
                               0.45f * unitsPerPx, {255, 255, 255}),
                          0);
    }
    const RgbaImage image = render(points, settings, camera);
    ASSERT_EQ(image.width, 333u);
    const glm::u8vec3 background = engine::backgroundPixel(settings.background);
    for (const auto& [x, y] : pixels) EXPECT_GT(image.at(x, y).x, 200) << x << "," << y;
    EXPECT_EQ(engine::coveredPixels(image.pixels, background), pixels.size());
}

// An engine drawing frame after frame (pipelined, kFramesInFlight) leaves nothing of one frame in
// the next. The compute path fills its buffers at each frame's start; with a sharp Gaussian
// the near disk's rim sets the depth of pixels whose rounded weight is zero, which would hide the
// far disk there if the depth of weightless pixels were not cleared too.
TEST_P(PathTest, ReusedRendererForgetsTheLastFrame) {
    RenderSettings settings = small(GetParam(), 96, 96);
    settings.sharpness = 30.0f;
    // Two scenes side by side, 20 apart: a near red disk in front of a far blue one at x = -20,
    // the far blue disk alone at x = +20.
    PointSet both = disk({-20, 0, 0}, {0, 0, 1}, 1.0f, {255, 0, 0});
    const PointSet farDisk = disk({0, 0, -3}, {0, 0, 1}, 2.5f, {0, 0, 255});
    both.appendFrom(disk({-20, 0, -3}, {0, 0, 1}, 2.5f, {0, 0, 255}), 0);
    both.appendFrom(disk({20, 0, -3}, {0, 0, 1}, 2.5f, {0, 0, 255}), 0);
    engine::EngineSettings engineSettings;
    engineSettings.render = settings;
    engineSettings.adaptive = false;
    auto engine = engine::Engine::create(context(), both, engineSettings);
    ASSERT_TRUE(engine.ok()) << engine.error().message;
    Camera left = lookingDownZ(8.0f), right = lookingDownZ(8.0f), away = lookingDownZ(8.0f);
    left.eye.x = left.target.x = -20.0f;
    right.eye.x = right.target.x = 20.0f;
    away.eye.y = away.target.y = 100.0f;
    // Frames drawn back to back, without waiting in between.
    engine::FrameOptions options;
    options.readBack = true;
    ASSERT_TRUE((*engine)->frame(left).ok());
    auto second = (*engine)->frame(right, options);
    ASSERT_TRUE(second.ok());
    const RgbaImage secondImage = frameOf(**engine, right); // a third frame, same camera
    auto secondAgain = (*engine)->image(second->frame);
    ASSERT_TRUE(secondAgain.ok());
    const RgbaImage fresh = render(farDisk, settings, lookingDownZ(8.0f));
    ASSERT_EQ(fresh.pixels.size(), secondAgain->pixels.size());
    EXPECT_TRUE(fresh.pixels == secondAgain->pixels);
    EXPECT_TRUE(fresh.pixels == secondImage.pixels);
    // And a frame of nothing after a frame of something is all background.
    const RgbaImage third = frameOf(**engine, away);
    ASSERT_EQ(third.width, 96u);
    for (std::uint32_t y = 0; y < 96; ++y)
        for (std::uint32_t x = 0; x < 96; ++x)
            ASSERT_EQ(third.at(x, y), glm::u8vec4(0, 0, 0, 255)) << x << "," << y;
}

TEST_P(PathTest, EmptySceneAndCameraLookingAwayGiveBackground) {
    RenderSettings settings = small(GetParam(), 65, 63); // odd: the last column is a pair of its own
    settings.background = {0.2f, 0.4f, 0.6f};
    const auto isBackground = [](const RgbaImage& image) {
        for (std::uint32_t y = 0; y < image.height; ++y)
            for (std::uint32_t x = 0; x < image.width; ++x) {
                const glm::u8vec4 c = image.at(x, y);
                if (c.x != 51 || c.y != 102 || c.z != 153) return false;
            }
        return image.width > 0;
    };
    EXPECT_TRUE(isBackground(render(PointSet{}, settings, lookingDownZ(5.0f))));
    Camera away = lookingDownZ(5.0f);
    away.target = {0.0f, 0.0f, 10.0f};
    EXPECT_TRUE(isBackground(render(withRadii(sampleSphereUniform(600, 1.0f)), settings, away)));
    // From inside a sphere every splat faces away: background, no crash.
    Camera inside = lookingDownZ(0.1f);
    EXPECT_TRUE(isBackground(render(withRadii(sampleSphereUniform(600, 1.0f)), settings, inside)));
}

TEST_P(PathTest, BadSettingsAndCamerasAreErrors) {
    RenderSettings settings = small(GetParam(), 0, 64);
    EXPECT_FALSE(engine::SplatRenderer::create(context(), settings).ok());
    settings.width = 1u << 20;
    settings.height = 64;
    EXPECT_FALSE(engine::SplatRenderer::create(context(), settings).ok());
    engine::EngineSettings engineSettings;
    engineSettings.render = small(GetParam(), 32, 32);
    engineSettings.adaptive = false;
    auto engine =
        engine::Engine::create(context(), disk({0, 0, 0}, {0, 0, 1}, 1.0f, {255, 255, 255}), engineSettings);
    ASSERT_TRUE(engine.ok());
    Camera camera = lookingDownZ(5.0f);
    camera.target = camera.eye;
    EXPECT_FALSE((*engine)->frame(camera).ok());
    camera = lookingDownZ(5.0f);
    camera.up = {0.0f, 0.0f, 1.0f};
    EXPECT_FALSE((*engine)->frame(camera).ok());
    EXPECT_TRUE((*engine)->frame(lookingDownZ(5.0f)).ok()); // and the engine goes on
}

INSTANTIATE_TEST_SUITE_P(Paths, PathTest, ::testing::Values(RenderPath::Compute, RenderPath::Graphics),
                         [](const ::testing::TestParamInfo<RenderPath>& p) {
                             return std::string(p.param == RenderPath::Compute ? "Compute" : "Graphics");
                         });

class RenderTest : public GpuTest {};

engine::ImageDifference difference(const RgbaImage& a, const RgbaImage& b) {
    auto d = engine::compareImages(a, b);
    EXPECT_TRUE(d.ok()) << d.error().message;
    return d ? *d : engine::ImageDifference{};
}

// The compute path runs where the device allows its workgroups (1,024 invocations; Vulkan
// guarantees 128) and has 64-bit atomics: lavapipe does; a device that does not is told to use the
// graphics path, and `auto` chooses it (tools/engine_setup.cpp).
TEST_F(RenderTest, TheComputePathNeedsWorkgroupsOf1024AndInt64Atomics) {
    EXPECT_EQ(engine::computePathProblem(context()), std::nullopt);
    const VkPhysicalDeviceLimits lavapipe = context().properties().limits;
    EXPECT_EQ(engine::computePathProblem(lavapipe, true, "a device"), std::nullopt);
    VkPhysicalDeviceLimits least = lavapipe; // Vulkan's guaranteed minimum
    least.maxComputeWorkGroupInvocations = 128;
    least.maxComputeWorkGroupSize[0] = least.maxComputeWorkGroupSize[1] = 128;
    EXPECT_EQ(engine::computePathProblem(least, true, "a small GPU"),
              "the compute path needs workgroups of 1024 invocations, 1024 in x, which a small GPU does not "
              "allow (at most 128); use the graphics path");
    VkPhysicalDeviceLimits narrow = lavapipe; // 1,024 invocations, but not in one row
    narrow.maxComputeWorkGroupSize[0] = 512;
    EXPECT_NE(engine::computePathProblem(narrow, true, "a device"), std::nullopt);
    EXPECT_EQ(engine::computePathProblem(lavapipe, false, "a device"),
              "the compute path needs 64-bit storage buffer atomics, which a device lacks; use the graphics "
              "path");
}

TEST_F(RenderTest, ComputeAndGraphicsPathsAgree) {
    const PointSet model = withRadii(makeBumpySphere());
    const engine::Sphere bounds{{0, 0, 0}, 1.3f};
    const Camera camera = engine::frameSphere(bounds, 320.0f / 240.0f, 0.7f, 0.5f);
    const RgbaImage a = render(model, small(RenderPath::Compute, 320, 240), camera);
    const RgbaImage b = render(model, small(RenderPath::Graphics, 320, 240), camera);
    const engine::ImageDifference d = difference(a, b);
    EXPECT_LT(d.rmse, 1.0);
    EXPECT_LT(d.differingShare, 0.002);
    EXPECT_GT(d.ssim, 0.999);
}

// The plain points (the benchmark's baseline, a render path of its own): each splat centre is the
// one pixel that holds its projection, in its colour as stored; every other pixel stays cleared.
TEST_F(RenderTest, PlainPointsDrawEachCentreAsOnePixel) {
    const Camera camera = lookingDownZ(5.0f);
    const float extent = 5.0f * std::tan(camera.fovY * 0.5f); // x and y at the view's edges, at z = 0
    PointSet points;
    std::vector<std::array<int, 2>> pixels;
    for (const auto [column, row] : {std::array{3, 5}, {30, 31}, {60, 2}, {17, 44}, {50, 58}}) {
        // The centre of pixel (column, row) of a 64 x 64 image: rows run downwards.
        const float x = ((float(column) + 0.5f) / 32.0f - 1.0f) * extent;
        const float y = -((float(row) + 0.5f) / 32.0f - 1.0f) * extent;
        points.position.emplace_back(x, y, 0.0f);
        points.normal.emplace_back(0.0f, 0.0f, 1.0f);
        points.radius.push_back(0.01f);
        points.colour.emplace_back(40 * points.size(), 255 - 30 * points.size(), 77);
        pixels.push_back({column, row});
    }
    const RgbaImage image = render(points, small(RenderPath::PlainPoints, 64, 64), camera);
    ASSERT_EQ(image.width, 64u);
    ASSERT_EQ(image.height, 64u);
    for (int row = 0; row < 64; ++row) {
        for (int column = 0; column < 64; ++column) {
            const auto found = std::ranges::find(pixels, std::array{column, row});
            const glm::u8vec3 want =
                found == pixels.end() ? glm::u8vec3(0) : points.colour[std::size_t(found - pixels.begin())];
            const std::uint8_t* at = &image.pixels[4 * (std::size_t(row) * 64 + std::size_t(column))];
            EXPECT_EQ(glm::u8vec3(at[0], at[1], at[2]), want) << "pixel " << column << ", " << row;
        }
    }
}

// Disks tilted up to 80 degrees, at several depths, over a wide view (70 degrees, so that
// perspective bends their outlines): the compute path visits only the pixels of each row that a
// quadratic says the disk covers (splat_compute.glsl, conicRow), the graphics path tests every
// pixel of a bounding square. Both must cover the same pixels: a row span cut short or shifted by a
// pixel leaves out a seventh of these disks' pixels.
TEST_F(RenderTest, ComputeRowSpansCoverWhatTheGraphicsPathCovers) {
    std::mt19937_64 rng(7);
    PointSet disks;
    const glm::vec3 eye{0.0f, 0.0f, 4.0f};
    for (int i = 0; i < 7; ++i)
        for (int j = 0; j < 7; ++j) {
            const glm::vec3 centre{-2.4f + 0.8f * float(i), -2.4f + 0.8f * float(j),
                                   test::uniform(rng, -1.0, 1.0)};
            // A normal within 80 degrees of the direction to the eye.
            const glm::vec3 toEye = glm::normalize(eye - centre);
            glm::vec3 n;
            do {
                n = test::randomUnit(rng);
            } while (glm::dot(n, toEye) < std::cos(radians(80.0f)));
            disks.position.push_back(centre);
            disks.normal.push_back(n);
            disks.radius.push_back(test::uniform(rng, 0.12, 0.3));
            disks.colour.push_back({255, 255, 255});
        }
    Camera camera = lookingDownZ(4.0f, 70.0f);
    const RgbaImage a = render(disks, small(RenderPath::Compute, 320, 240), camera);
    const RgbaImage b = render(disks, small(RenderPath::Graphics, 320, 240), camera);
    ASSERT_EQ(a.pixels.size(), b.pixels.size());
    std::size_t covered = 0, mismatched = 0;
    for (std::uint32_t y = 0; y < 240; ++y)
        for (std::uint32_t x = 0; x < 320; ++x) {
            const bool inA = a.at(x, y) != glm::u8vec4(0, 0, 0, 255);
            const bool inB = b.at(x, y) != glm::u8vec4(0, 0, 0, 255);
            covered += inB ? 1 : 0;
            mismatched += inA != inB ? 1 : 0;
        }
    std::cout << "[oblique disks: " << covered << " pixels covered, " << mismatched
              << " covered by one path only]\n";
    EXPECT_GT(covered, 8000u);
    EXPECT_LT(mismatched, covered / 200);
}

// Nearly edge-on disks close to the eye, checked pixel by pixel against the exact ray-disk test
// in double precision: every pixel whose centre lies clearly inside a disk (rho² < 0.999) is
// covered and every pixel clearly outside all of them (rho² > 1.001) is background, on both
// accumulation layouts (coloured: four sums; without colours: one word). The first disk, 0.025
// degrees from edge-on, was found by emulating the shader's float arithmetic: with rho² taken as the
// quadratic form a·u² + 2b·u·v + c·v², whose terms cancel, and the rows' roots from b² - a·c, it lost
// 3 pixels here (rho² 0.993 to 0.998), and in a view of it alone everything past 457 of the 571
// columns it reaches.
TEST_F(RenderTest, ComputeRowSpansKeepEveryPixelTheDiskCovers) {
    std::mt19937_64 rng(11);
    PointSet disks;
    const auto add = [&](glm::vec3 c, glm::vec3 n, float r) {
        disks.position.push_back(c);
        disks.normal.push_back(glm::normalize(n));
        disks.radius.push_back(r);
    };
    add({-0.466f, 0.646f, -0.990f}, {-0.247f, -0.861f, -0.445f}, 1.09f);
    for (int k = 0; k < 40; ++k) {
        const glm::vec3 c{test::uniform(rng, -2.0, 2.0), test::uniform(rng, -1.5, 1.5),
                          test::uniform(rng, -5.0, -2.5)};
        glm::vec3 n; // 70 to 89.9 degrees from the direction to the eye
        float cosine = 0.0f;
        do {
            n = test::randomUnit(rng);
            cosine = glm::dot(n, -glm::normalize(c));
        } while (!(cosine > 0.002f && cosine < 0.34f));
        add(c, n, test::uniform(rng, 0.2, 0.9));
    }
    Camera camera;
    camera.eye = {0.0f, 0.0f, 0.0f};
    camera.target = {0.0f, 0.0f, -1.0f};
    camera.fovY = radians(70.0f);
    const std::uint32_t w = 640, h = 480;
    const double ry = std::tan(radians(35.0)), rx = ry * double(w) / double(h);
    // rho² of the nearest hit in front of the eye among the disks, at pixel (x, y); > 1 for none.
    const auto rho2At = [&](std::uint32_t x, std::uint32_t y) {
        const glm::dvec3 ray{(2.0 * (x + 0.5) / w - 1.0) * rx, -(2.0 * (y + 0.5) / h - 1.0) * ry, -1.0};
        double best = 2.0;
        for (std::size_t i = 0; i < disks.size(); ++i) {
            const glm::dvec3 c(disks.position[i]), n(disks.normal[i]);
            const double dn = glm::dot(n, ray);
            if (dn >= 0.0) continue;
            const double t = glm::dot(n, c) / dn;
            const glm::dvec3 q = t * ray - c;
            if (t > 0.0)
                best = std::min(best, glm::dot(q, q) / (double(disks.radius[i]) * double(disks.radius[i])));
        }
        return best;
    };
    std::vector<double> rho2(std::size_t{w} * h);
    for (std::uint32_t y = 0; y < h; ++y)
        for (std::uint32_t x = 0; x < w; ++x) rho2[std::size_t{y} * w + x] = rho2At(x, y);
    for (const bool coloured : {true, false}) {
        disks.colour.assign(coloured ? disks.size() : 0, glm::u8vec3(255));
        RenderSettings settings = small(RenderPath::Compute, w, h);
        settings.fillPinholes = false; // the disks' own pixels: a pinhole between them is background
        const RgbaImage image = render(disks, settings, camera);
        ASSERT_EQ(image.width, w);
        std::size_t inside = 0, missed = 0, spilled = 0;
        std::string first; // the first pixel missed or spilled, with its rho²
        for (std::uint32_t y = 0; y < h; ++y)
            for (std::uint32_t x = 0; x < w; ++x) {
                const double r2 = rho2[std::size_t{y} * w + x];
                const bool covered = image.at(x, y) != glm::u8vec4(0, 0, 0, 255);
                if (r2 < 0.999) {
                    ++inside;
                    if (!covered) ++missed;
                } else if (r2 > 1.001 && covered) {
                    ++spilled;
                } else {
                    continue;
                }
                if (first.empty() && (covered != (r2 < 0.999)))
                    first = fmt::format(" (first: pixel {},{} at rho² {:.4f})", x, y, r2);
            }
        std::cout << "[edge-on disks, " << (coloured ? "four sums" : "one word") << ": " << inside
                  << " pixels inside, " << missed << " missed, " << spilled << " outside covered" << first
                  << "]\n";
        EXPECT_GT(inside, 5000u);
        EXPECT_EQ(missed, 0u);
        EXPECT_EQ(spilled, 0u);
    }
}

// A model without colours is drawn in one colour (engine.h, kDefaultColour), which the compute path
// accumulates as one word a pixel (the weight and the normal across the ray, gpu_types.h) instead
// of four: the picture of the same points given that colour each, but for rounding (the normal's
// two components are kept to 1/4096 of the weight, not 1/65536).
TEST_F(RenderTest, OneColourSumsGiveThePictureOfColouredSplats) {
    PointSet plain = withRadii(sampleSphereUniform(20000, 1.0f));
    PointSet coloured = plain;
    coloured.colour.assign(coloured.size(), glm::u8vec3(0xC8));
    const Camera camera = lookingDownZ(3.0f);
    const RgbaImage a = render(plain, small(RenderPath::Compute, 256, 192), camera);
    const RgbaImage b = render(coloured, small(RenderPath::Compute, 256, 192), camera);
    const engine::ImageDifference d = difference(a, b);
    std::cout << "[one colour against four sums: RMSE " << d.rmse << ", " << d.differingShare
              << " of pixels differ]\n";
    EXPECT_LT(d.rmse, 0.3);
    EXPECT_LT(d.differingShare, 0.001);
    EXPECT_GT(a.at(128, 96).x, 150); // lit grey, not background or black
}

TEST_F(RenderTest, CullingSkipsNodesAndChangesNothing) {
    const PointSet sphere = withRadii(sampleSphereUniform(50000, 1.0f));
    const Camera camera = lookingDownZ(3.0f, 5.0f); // a narrow cone through the middle of the sphere
    RenderSettings settings = small(RenderPath::Compute, 128, 128);
    engine::FrameReport culled, all;
    const RgbaImage a = render(sphere, settings, camera, &culled);
    settings.cullNodes = false;
    const RgbaImage b = render(sphere, settings, camera, &all);
    EXPECT_EQ(all.nodesVisible, all.treeNodes);
    EXPECT_EQ(all.splatsDrawn, sphere.size());
    EXPECT_LT(culled.nodesVisible, culled.treeNodes / 2);
    EXPECT_LT(culled.splatsDrawn, sphere.size() / 2);
    EXPECT_LT(difference(a, b).rmse, 0.05); // only float-atomic ordering may differ
}

// The splats splatsOutOfPicture finds (facing away, or out of the view) change nothing: the compute
// path's sums are integers, so the picture without them is bitwise the same. A close camera sees a
// part of a sphere, many splats straddling the image's edges.
TEST_F(RenderTest, SplatsOutOfThePictureChangeNothing) {
    const PointSet sphere = withRadii(sampleSphereUniform(50000, 1.0f));
    Camera camera;
    camera.eye = {0.4f, 0.3f, 1.5f};
    camera.target = {0.2f, 0.1f, 0.7f};
    camera.fovY = radians(40.0f);
    const RenderSettings settings = small(RenderPath::Compute, 128, 96);
    const std::vector<std::uint32_t> out = engine::splatsOutOfPicture(
        sphere.position, sphere.normal, sphere.radius, camera, settings.width, settings.height, 1.0f);
    ASSERT_TRUE(std::ranges::is_sorted(out));
    // Whether a splat's centre lies in the view.
    const glm::mat4 view = camera.view();
    const float tanY = std::tan(camera.fovY / 2.0f), tanX = tanY * 128.0f / 96.0f;
    const auto centreInView = [&](std::uint32_t i) {
        const glm::vec3 p = glm::vec3(view * glm::vec4(sphere.position[i], 1.0f));
        return -p.z > 0.0f && std::abs(p.y) < tanY * -p.z && std::abs(p.x) < tanX * -p.z;
    };
    std::size_t away = 0, outside = 0;
    for (const std::uint32_t i : out) ++(centreInView(i) ? away : outside);
    EXPECT_GT(away, 1000u) << "splats in view that face away";
    EXPECT_GT(outside, 10000u) << "splats out of the view";
    EXPECT_LT(sphere.size() - out.size(), sphere.size() / 4);
    PointSet kept = sphere;
    removePoints(kept, out);
    const RgbaImage all = render(sphere, settings, camera), some = render(kept, settings, camera);
    ASSERT_EQ(all.width, 128u);
    EXPECT_GT(engine::coveredPixels(all.pixels, glm::u8vec3(0)), 128u * 96u / 2u);
    EXPECT_TRUE(all.pixels == some.pixels);
    // A margin too thin shows: without the splats whose centre lies out of the view, the edges lose
    // what their disks brought in.
    PointSet centres = sphere;
    std::vector<std::uint32_t> centreOut;
    for (std::uint32_t i = 0; i < sphere.size(); ++i)
        if (!centreInView(i)) centreOut.push_back(i);
    removePoints(centres, centreOut);
    EXPECT_FALSE(render(centres, settings, camera).pixels == all.pixels);
}

// Golden images: each model at a fixed camera on the default path. PNSPLAT_UPDATE_GOLDEN=1 rewrites
// them (after a deliberate change; look at them before committing).
struct Golden {
    std::string name;
    PointSet points;
};

// 0..255 units. The two paths differ by 0.002 on lavapipe; another GPU's float rounding stays far
// below this, while every broken pass below exceeds 2.5 times it.
constexpr double kGoldenRmse = 1.0;

class GoldenTest : public GpuTest {
  protected:
    static RenderSettings settings() {
        RenderSettings s;
        s.width = 240;
        s.height = 180;
        s.background = {1.0f, 1.0f, 1.0f};
        return s;
    }
    static Camera camera(const PointSet& points) {
        glm::vec3 lo(1e30f), hi(-1e30f);
        for (const auto& p : points.position) {
            lo = glm::min(lo, p);
            hi = glm::max(hi, p);
        }
        const engine::Sphere bounds{(lo + hi) * 0.5f, glm::length(hi - lo) * 0.5f};
        return engine::frameSphere(bounds, 240.0f / 180.0f, 0.7f, 0.6f);
    }
    // Compares a render of `points` with tests/golden/<name>.png, or rewrites it on request.
    void checkGolden(const std::string& name, const PointSet& points) {
        const std::filesystem::path file = std::filesystem::path(PNSPLAT_GOLDEN_DIR) / (name + ".png");
        const RgbaImage image = render(points, settings(), camera(points));
        ASSERT_GT(image.width, 0u);
        if (const char* update = std::getenv("PNSPLAT_UPDATE_GOLDEN");
            update != nullptr && std::string(update) == "1") {
            ASSERT_TRUE(engine::writePng(file, image).ok());
            return;
        }
        auto golden = engine::readPng(file);
        ASSERT_TRUE(golden.ok()) << golden.error().message;
        const engine::ImageDifference d = difference(image, *golden);
        EXPECT_LT(d.rmse, kGoldenRmse) << name;

        // The comparison is tight enough that a broken pass fails it.
        RenderSettings broken = settings();
        broken.normalize = false;
        const double noNormalization = difference(render(points, broken, camera(points)), *golden).rmse;
        broken = settings();
        broken.depthOffset = 0.0f;
        const double noDepthOffset = difference(render(points, broken, camera(points)), *golden).rmse;
        broken = settings();
        broken.smoothEdges = false;
        const double hardEdges = difference(render(points, broken, camera(points)), *golden).rmse;
        PointSet flipped = points;
        for (auto& n : flipped.normal) n = -n;
        const double flippedNormals = difference(render(flipped, settings(), camera(points)), *golden).rmse;
        std::cout << "[golden " << name << "] RMSE " << d.rmse << " (tolerance " << kGoldenRmse
                  << "); broken passes: no normalization " << noNormalization << ", no depth offset "
                  << noDepthOffset << ", hard edges " << hardEdges << ", flipped normals " << flippedNormals
                  << "\n";
        EXPECT_GT(noNormalization, 2.5 * kGoldenRmse) << "no normalization";
        EXPECT_GT(noDepthOffset, 2.5 * kGoldenRmse) << "no depth offset";
        EXPECT_GT(flippedNormals, 2.5 * kGoldenRmse) << "flipped normals";
        EXPECT_GT(hardEdges, 2.5 * kGoldenRmse) << "hard edges";
    }
};

// The sphere is coloured by octant: with one colour its inside seen through flipped normals would
// shade much like its outside under a headlight.
TEST_F(GoldenTest, Sphere) {
    PointSet sphere = withRadii(sampleSphereUniform(2000, 1.0f));
    for (const glm::vec3& p : sphere.position)
        sphere.colour.push_back({static_cast<std::uint8_t>(p.x > 0 ? 230 : 40),
                                 static_cast<std::uint8_t>(p.y > 0 ? 200 : 60),
                                 static_cast<std::uint8_t>(p.z > 0 ? 220 : 50)});
    checkGolden("sphere", sphere);
}

TEST_F(GoldenTest, ColouredBumpySphere) {
    checkGolden("bumpy-sphere", withRadii(makeBumpySphere()));
}

TEST_F(GoldenTest, RealModel) {
    PNSPLAT_REQUIRE_DATA("banana-1500-random.ply");
    auto data = readPly(test::dataDir() / "banana-1500-random.ply");
    ASSERT_TRUE(data.ok());
    checkGolden("banana", withRadii(data->points));
}

// The paper's point (issue 3, acceptance 2): a sparse scan refined until its splats are about
// 2 px wide renders closer to the dense reference than the sparse scan splatted directly.
TEST_F(GoldenTest, RefinedSparseModelIsCloserToTheDenseRender) {
    PNSPLAT_REQUIRE_DATA("bunny-reference.ply");
    PNSPLAT_REQUIRE_DATA("bunny-3500-random.ply");
    auto dense = readPly(test::dataDir() / "bunny-reference.ply");
    auto sparse = readPly(test::dataDir() / "bunny-3500-random.ply");
    ASSERT_TRUE(dense.ok() && sparse.ok());
    const PointSet reference = withRadii(dense->points);
    const PointSet input = withRadii(sparse->points);
    RenderSettings s = settings();
    s.width = 320;
    s.height = 240;
    const Camera view = camera(reference);
    const float focal = float(s.height) * 0.5f / std::tan(view.fovY * 0.5f);
    const auto medianDiameter = [&](const PointSet& points) {
        std::vector<float> d(points.size());
        for (std::size_t i = 0; i < points.size(); ++i)
            d[i] = 2.0f * points.radius[i] * focal / glm::length(points.position[i] - view.eye);
        std::nth_element(d.begin(), d.begin() + long(d.size() / 2), d.end());
        return d[d.size() / 2];
    };
    Refiner refiner(input, RefineOptions{});
    while (medianDiameter(refiner.points()) > 2.0f && refiner.levels() < 6) refiner.refineLevel();
    const RgbaImage truth = render(reference, s, view);
    const engine::ImageDifference direct = difference(render(input, s, view), truth);
    const engine::ImageDifference refined = difference(render(refiner.points(), s, view), truth);
    std::cout << "[bunny 3500 -> " << refiner.points().size() << " points, " << refiner.levels()
              << " levels, median splat " << medianDiameter(refiner.points()) << " px] PSNR " << direct.psnr
              << " -> " << refined.psnr << " dB, SSIM " << direct.ssim << " -> " << refined.ssim << "\n";
    EXPECT_LE(medianDiameter(refiner.points()), 2.0f);
    EXPECT_GT(refined.psnr, direct.psnr + 2.0);
    EXPECT_GT(refined.ssim, direct.ssim + 0.02);
}

// ---- The camera `pnsplat render` chooses (engine::chooseViewpoint; issue 20, acceptance 5) ----

// A solid standing on a flat base, built along +z and turned so that +z goes to `up`: a cylinder
// of radius 1 over z in [0, 3], closed below by a flat disk and above by a hemisphere; points
// about 0.1 apart, outward normals.
PointSet standingSolid(glm::vec3 up) {
    PointSet p;
    const auto add = [&](glm::vec3 x, glm::vec3 n) {
        p.position.push_back(x);
        p.normal.push_back(n);
    };
    for (int k = 0; k < 63; ++k) {
        const float a = 2.0f * std::numbers::pi_v<float> * float(k) / 63.0f;
        const glm::vec3 n(std::cos(a), std::sin(a), 0.0f);
        for (int j = 0; j <= 30; ++j) add(n + glm::vec3(0.0f, 0.0f, 0.1f * float(j)), n);
        for (int j = 1; j < 16; ++j) { // the hemisphere, by latitude
            const float b = 0.5f * std::numbers::pi_v<float> * float(j) / 16.0f;
            const glm::vec3 m = std::cos(b) * n + glm::vec3(0.0f, 0.0f, std::sin(b));
            if (k % std::max(1, int(1.0f / std::cos(b))) == 0) add(m + glm::vec3(0.0f, 0.0f, 3.0f), m);
        }
    }
    add({0.0f, 0.0f, 4.0f}, {0.0f, 0.0f, 1.0f});
    for (float x = -0.95f; x < 1.0f; x += 0.1f)
        for (float y = -0.95f; y < 1.0f; y += 0.1f)
            if (x * x + y * y < 0.95f) add({x, y, 0.0f}, {0.0f, 0.0f, -1.0f});
    // The rotation taking +z to `up` (a half turn about x for -z).
    const glm::vec3 z(0.0f, 0.0f, 1.0f);
    const glm::vec3 axis =
        glm::length(glm::cross(z, up)) > 0.5f ? glm::cross(z, up) : glm::vec3(1.0f, 0.0f, 0.0f);
    const float angle = std::acos(glm::dot(z, up));
    const glm::mat3 turn(glm::rotate(glm::mat4(1.0f), angle, glm::normalize(axis)));
    for (auto& x : p.position) x = turn * x;
    for (auto& n : p.normal) n = turn * n;
    return p;
}

// A unit hemisphere below z = 0 closed by a flat disk at z = 0 facing +z, mirrored in z when
// `mirrored` (the disk then faces -z); points about 0.1 apart.
PointSet domeWithFlatFace(bool mirrored) {
    PointSet p;
    const float s = mirrored ? -1.0f : 1.0f;
    for (float x = -0.95f; x < 1.0f; x += 0.1f)
        for (float y = -0.95f; y < 1.0f; y += 0.1f)
            if (x * x + y * y < 1.0f) {
                p.position.push_back({x, y, 0.0f});
                p.normal.push_back({0.0f, 0.0f, s});
                const glm::vec3 d(
                    x, y, -s * std::sqrt(1.0f - x * x - y * y)); // the dome, its area twice the disk's
                for (const float t : {1.0f, 0.98f}) {
                    const glm::vec3 n = glm::normalize(glm::vec3(t * d.x, t * d.y, d.z));
                    p.position.push_back(n);
                    p.normal.push_back(n);
                }
            }
    return p;
}

TEST(CameraTest, ViewpointStandsASolidOnItsBase) {
    for (const glm::vec3 up : {glm::vec3(1, 0, 0), glm::vec3(-1, 0, 0), glm::vec3(0, 1, 0),
                               glm::vec3(0, -1, 0), glm::vec3(0, 0, 1), glm::vec3(0, 0, -1)}) {
        SCOPED_TRACE(::testing::Message() << "up " << up.x << "," << up.y << "," << up.z);
        const PointSet solid = standingSolid(up);
        const engine::Viewpoint view = engine::chooseViewpoint(solid.position, solid.normal);
        EXPECT_EQ(view.up, up);
        EXPECT_TRUE(view.upFromBase);
        EXPECT_EQ(glm::dot(view.front, up), 0.0f);
        // A given up axis is kept; the eye still looks across it.
        const engine::Viewpoint given = engine::chooseViewpoint(solid.position, solid.normal, glm::abs(up));
        EXPECT_EQ(given.up, glm::abs(up));
        EXPECT_FALSE(given.upFromBase);
        EXPECT_EQ(glm::dot(given.front, up), 0.0f);
    }
}

TEST(CameraTest, ViewpointAvoidsAFlatFaceAndDefaultsToYUpFromZ) {
    const PointSet flatOnTop = domeWithFlatFace(false), flatBelow = domeWithFlatFace(true);
    const engine::Viewpoint a = engine::chooseViewpoint(flatOnTop.position, flatOnTop.normal);
    EXPECT_EQ(a.up, glm::vec3(0, 1, 0));
    EXPECT_FALSE(a.upFromBase);
    EXPECT_EQ(a.front, glm::vec3(0, 0, -1)); // looks at the dome, not at the disk
    EXPECT_TRUE(a.frontFlipped);
    const engine::Viewpoint b = engine::chooseViewpoint(flatBelow.position, flatBelow.normal);
    EXPECT_EQ(b.front, glm::vec3(0, 0, 1));
    EXPECT_FALSE(b.frontFlipped);
    // A flat scan, every normal +z or every normal -z (a terrain tile, issue 27): the eye on the side
    // the normals face, whatever the flat-face rule says (before: on -z for +z normals, a blank
    // picture of back faces).
    for (const float side : {1.0f, -1.0f}) {
        PointSet grid;
        for (int y = 0; y < 25; ++y)
            for (int x = 0; x < 25; ++x) {
                grid.position.push_back({0.1f * float(x), 0.1f * float(y), 0.0f});
                grid.normal.push_back({0.0f, 0.0f, side});
            }
        const engine::Viewpoint flat = engine::chooseViewpoint(grid.position, grid.normal);
        EXPECT_EQ(flat.front, glm::vec3(0, 0, side)) << side;
        EXPECT_EQ(flat.frontFlipped, side < 0.0f) << side;
    }
    // Without normals the side is not chosen; without points, the default.
    EXPECT_EQ(engine::chooseViewpoint(flatOnTop.position, {}).front, glm::vec3(0, 0, 1));
    const engine::Viewpoint none = engine::chooseViewpoint({}, {});
    EXPECT_EQ(none.up, glm::vec3(0, 1, 0));
    EXPECT_EQ(none.front, glm::vec3(0, 0, 1));
    // A round model (the bumpy sphere) keeps the usual view: y up, eye on +z.
    const PointSet model = makeBumpySphere();
    const engine::Viewpoint round = engine::chooseViewpoint(model.position, model.normal);
    EXPECT_EQ(round.up, glm::vec3(0, 1, 0));
    EXPECT_EQ(round.front, glm::vec3(0, 0, 1));
}

// The viewpoints of ../shared/data's models, pinned after looking at each render: the nefertiti
// stands on its base along +z (seen in profile), the fandisk is seen from its shaped side (its
// flat back faces +z), the lion and the rocker arm from their broad side.
TEST(CameraTest, ViewpointsOfTheRealModels) {
    struct Case {
        std::string file;
        glm::vec3 up, front;
    };
    const std::vector<Case> cases = {
        {"nefertiti-3500-random.ply", {0, 0, 1}, {1, 0, 0}},
        {"nefertiti-reference.ply", {0, 0, 1}, {1, 0, 0}},
        {"fandisk-1500-uniform.ply", {-1, 0, 0}, {0, 0, -1}},
        {"fandisk-reference.ply", {-1, 0, 0}, {0, 0, -1}},
        {"bunny-3500-random.ply", {0, 1, 0}, {0, 0, 1}},
        {"lion-3500-random.ply", {0, 1, 0}, {1, 0, 0}},
        {"igea-600-uniform.ply", {0, 1, 0}, {0, 0, 1}},
        {"rockerarm-2000-uniform.ply", {0, 1, 0}, {1, 0, 0}},
        {"banana-1500-random.ply", {0, 1, 0}, {0, 0, 1}},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.file);
        PNSPLAT_REQUIRE_DATA(c.file);
        auto data = readPly(test::dataDir() / c.file);
        ASSERT_TRUE(data.ok()) << data.error().message;
        const engine::Viewpoint view = engine::chooseViewpoint(data->points.position, data->points.normal);
        EXPECT_EQ(view.up, c.up);
        EXPECT_EQ(view.front, c.front);
    }
}

// What a render shows, on a white background.
struct Silhouette {
    double width = 0.0, height = 0.0; // of the covered pixels' bounding box, in pixels
    double shadeSteps = 0.0; // share of the inner covered pixels whose grey level steps by more than 8
                             // to the next pixel right or below: creases and folds; a flat face has few
};

Silhouette silhouette(const RgbaImage& image) {
    const auto grey = [&](std::uint32_t x, std::uint32_t y) {
        const glm::u8vec4 p = image.at(x, y);
        return p.x == 255 && p.y == 255 && p.z == 255 ? -1 : (int(p.x) + int(p.y) + int(p.z)) / 3;
    };
    std::uint32_t x0 = image.width, x1 = 0, y0 = image.height, y1 = 0;
    std::size_t inner = 0, steps = 0;
    for (std::uint32_t y = 0; y < image.height; ++y)
        for (std::uint32_t x = 0; x < image.width; ++x) {
            const int g = grey(x, y);
            if (g < 0) continue;
            x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
            if (x == 0 || y == 0 || x + 1 == image.width || y + 1 == image.height) continue;
            const int right = grey(x + 1, y), below = grey(x, y + 1);
            if (right < 0 || below < 0 || grey(x - 1, y) < 0 || grey(x, y - 1) < 0) continue;
            ++inner;
            steps += std::max(std::abs(right - g), std::abs(below - g)) > 8;
        }
    if (x1 < x0) return {};
    return {double(x1 - x0 + 1), double(y1 - y0 + 1), inner > 0 ? double(steps) / double(inner) : 0.0};
}

class DefaultViewTest : public GpuTest {
  protected:
    // The model's render from the camera `pnsplat render` chooses, and from the old default (y up,
    // eye on +z), at 240x180 with a 40 degree field.
    std::pair<Silhouette, Silhouette> chosenAndOld(const std::string& file) {
        auto data = readPly(test::dataDir() / file);
        EXPECT_TRUE(data.ok());
        if (!data) return {};
        const PointSet points = withRadii(data->points);
        RenderSettings s;
        s.width = 240;
        s.height = 180;
        s.background = {1.0f, 1.0f, 1.0f};
        const engine::Sphere bounds = engine::boundingSphere(points.position);
        const float fov = 40.0f * std::numbers::pi_v<float> / 180.0f;
        const Camera chosen = engine::frameSphere(bounds, 240.0f / 180.0f, fov, 0.0f,
                                                  engine::chooseViewpoint(points.position, points.normal));
        const Camera old = engine::frameSphere(bounds, 240.0f / 180.0f, fov, 0.0f);
        const Silhouette a = silhouette(render(points, s, chosen)), b = silhouette(render(points, s, old));
        std::cout << "[" << file << "] chosen camera: box " << a.width << " x " << a.height
                  << ", shade steps " << a.shadeSteps << "; old default: box " << b.width << " x " << b.height
                  << ", shade steps " << b.shadeSteps << "\n";
        return {a, b};
    }
};

// The z-up nefertiti stands upright: its box spans 90 % of the image's height (its height along z
// is the largest extent: 495 mm, over 363 and 239) and is 1.3 times taller than wide (495 / 363
// in profile). From the old default, the top of its head, it is neither (measured: 121 x 175
// pixels against 112 x 132).
TEST_F(DefaultViewTest, NefertitiStandsUpright) {
    PNSPLAT_REQUIRE_DATA("nefertiti-3500-random.ply");
    const auto [chosen, old] = chosenAndOld("nefertiti-3500-random.ply");
    const auto upright = [](const Silhouette& s) {
        return s.height > 0.9 * 180.0 && s.height > 1.3 * s.width;
    };
    EXPECT_TRUE(upright(chosen));
    EXPECT_FALSE(upright(old));
}

// The fandisk shows its faces and creases, not its one flat back (the old default; measured: shade
// steps at 15 % of the inner pixels against 4 %).
TEST_F(DefaultViewTest, FandiskShowsItsShape) {
    PNSPLAT_REQUIRE_DATA("fandisk-1500-uniform.ply");
    const auto [chosen, old] = chosenAndOld("fandisk-1500-uniform.ply");
    EXPECT_GT(chosen.shadeSteps, 0.08);
    EXPECT_LT(old.shadeSteps, 0.08);
}

TEST(ImageTest, IdenticalImagesHaveInfinitePsnrAndUnitSsim) {
    RgbaImage a(16, 12);
    for (std::size_t i = 0; i < a.pixels.size(); ++i) a.pixels[i] = static_cast<std::uint8_t>(i * 7);
    auto d = engine::compareImages(a, a);
    ASSERT_TRUE(d.ok());
    EXPECT_TRUE(std::isinf(d->psnr));
    EXPECT_DOUBLE_EQ(d->ssim, 1.0);
    EXPECT_EQ(d->rmse, 0.0);
    EXPECT_EQ(d->differingShare, 0.0);
}

TEST(ImageTest, KnownDifferenceGivesExactFigures) {
    RgbaImage a(10, 10), b(10, 10);
    b.pixels[0] = 30;        // one channel of one pixel off by 30
    b.pixels[4 * 5 + 1] = 2; // another by 2: below the default threshold
    auto d = engine::compareImages(a, b);
    ASSERT_TRUE(d.ok());
    const double mse = (30.0 * 30.0 + 2.0 * 2.0) / 300.0;
    EXPECT_NEAR(d->rmse, std::sqrt(mse), 1e-12);
    EXPECT_NEAR(d->psnr, 10.0 * std::log10(255.0 * 255.0 / mse), 1e-9);
    EXPECT_DOUBLE_EQ(d->differingShare, 0.01);
    EXPECT_LT(d->ssim, 1.0);
    EXPECT_EQ(d->heatmap.at(0, 0).x, 90); // 30 · 3 on the red ramp
    EXPECT_EQ(d->heatmap.at(1, 1).x, 0);
}

TEST(ImageTest, SizeMismatchAndMissingFilesAreErrors) {
    EXPECT_FALSE(engine::compareImages(RgbaImage(4, 4), RgbaImage(4, 5)).ok());
    const auto missing = engine::readPng("/nonexistent/image.png");
    ASSERT_FALSE(missing.ok());
    EXPECT_EQ(missing.error().message, "/nonexistent/image.png: no such file"); // not stb's "can't fopen"
    EXPECT_FALSE(engine::writePng("/nonexistent/dir/image.png", RgbaImage(2, 2)).ok());
}

TEST(ImageTest, PngRoundTrip) {
    RgbaImage a(7, 5);
    for (std::size_t i = 0; i < a.pixels.size(); ++i) a.pixels[i] = static_cast<std::uint8_t>(i * 13 + 1);
    const auto file = std::filesystem::temp_directory_path() / "pnsplat-roundtrip.png";
    ASSERT_TRUE(engine::writePng(file, a).ok());
    auto b = engine::readPng(file);
    std::filesystem::remove(file);
    ASSERT_TRUE(b.ok());
    EXPECT_EQ(b->pixels, a.pixels);
}

// Draws `art` (one character a pixel: '.' background, '#' surface) into an image.
RgbaImage imageOf(const std::vector<std::string>& art, glm::u8vec3 background) {
    RgbaImage image(static_cast<std::uint32_t>(art[0].size()), static_cast<std::uint32_t>(art.size()));
    for (std::uint32_t y = 0; y < image.height; ++y)
        for (std::uint32_t x = 0; x < image.width; ++x) {
            const glm::u8vec4 colour =
                art[y][x] == '.' ? glm::u8vec4(background, 255) : glm::u8vec4(200, 200, 200, 255);
            std::copy(&colour[0], &colour[0] + 4, &image.pixels[(std::size_t{y} * image.width + x) * 4]);
        }
    return image;
}

TEST(ImageTest, EnclosedBackgroundIsWhatTheBorderDoesNotReach) {
    const glm::u8vec3 white = engine::backgroundPixel({1.0f, 1.0f, 1.0f});
    EXPECT_EQ(white, glm::u8vec3(255));
    EXPECT_EQ(engine::backgroundPixel({0.0f, 0.5f, 2.0f}), glm::u8vec3(0, 128, 255));
    EXPECT_EQ(engine::backgroundPixel({0.3f, 0.7f, -1.0f}), glm::u8vec3(76, 178, 0)); // 76.5 and 178.5
    // A ring with a hole of 4 pixels, a one-pixel hole beside it, a bay open to the border (not
    // enclosed) and background touching only diagonally (4-connected: enclosed).
    const std::vector<std::string> art = {
        "..........", //
        ".######...", //
        ".#..#.#...", //
        ".#..###.#.", //
        ".####..##.", //
        "...#.#.#..", //
        "...##.#...", //
        "..........", //
    };
    const RgbaImage image = imageOf(art, white);
    const std::vector<engine::ImageRegion> regions = engine::enclosedBackground(image, white);
    ASSERT_EQ(regions.size(), 4u);
    EXPECT_EQ(regions[0].pixels, 4u); // the square hole
    EXPECT_EQ(regions[0].x0, 2u);
    EXPECT_EQ(regions[0].y0, 2u);
    EXPECT_EQ(regions[0].x1, 3u);
    EXPECT_EQ(regions[0].y1, 3u);
    EXPECT_EQ(regions[1].pixels, 1u); // the one-pixel hole at (5, 2)
    EXPECT_EQ(regions[1].x0, 5u);
    EXPECT_EQ(regions[1].y1, 2u);
    EXPECT_EQ(regions[2].pixels, 3u); // (5, 4), (6, 4) and (6, 5)
    EXPECT_EQ(regions[2].x1, 6u);
    EXPECT_EQ(regions[2].y1, 5u);
    EXPECT_EQ(regions[3].pixels, 1u); // (4, 5), which touches the last only diagonally
    EXPECT_EQ(regions[3].x0, 4u);
    EXPECT_EQ(regions[3].y0, 5u);
    // Another background colour: the white pixels are surface then, and nothing is enclosed.
    EXPECT_TRUE(engine::enclosedBackground(image, glm::u8vec3(0)).empty());
    EXPECT_TRUE(engine::enclosedBackground(RgbaImage(), white).empty());
    EXPECT_TRUE(engine::enclosedBackground(RgbaImage(1, 1), white).empty());

    // Against a reference without enclosed background, all of them; against one that shows a
    // pixel of the square hole enclosed, the other three.
    RgbaImage reference = imageOf(std::vector<std::string>(8, ".........."), white);
    auto absent = engine::enclosedBackgroundAbsentIn(image, reference, white);
    ASSERT_TRUE(absent.ok());
    EXPECT_EQ(absent->size(), 4u);
    reference = imageOf(std::vector<std::string>(8, "##########"), white);
    std::copy(&image.pixels[(3 * 10 + 3) * 4], &image.pixels[(3 * 10 + 3) * 4] + 4,
              &reference.pixels[(3 * 10 + 3) * 4]);
    absent = engine::enclosedBackgroundAbsentIn(image, reference, white);
    ASSERT_TRUE(absent.ok());
    ASSERT_EQ(absent->size(), 3u);
    EXPECT_EQ((*absent)[0].x0, 5u);
    reference = image;
    absent = engine::enclosedBackgroundAbsentIn(image, reference, white);
    ASSERT_TRUE(absent.ok());
    EXPECT_TRUE(absent->empty());
    EXPECT_FALSE(engine::enclosedBackgroundAbsentIn(image, RgbaImage(10, 7), white).ok());
}

TEST(CameraTest, FrustumAgreesWithSamplingOnTheSphere) {
    // A sphere intersects the frustum iff some point of it lies inside: sample the sphere densely
    // and compare with the analytic test, allowing disagreement only within 1% of the radius.
    const engine::Frustum frustum{0.5f, 0.4f, {0.1f, 10.0f}};
    const auto inside = [&](glm::vec3 p) {
        const float d = -p.z;
        return d >= 0.1f && d <= 10.0f && std::abs(p.x) <= 0.5f * d && std::abs(p.y) <= 0.4f * d;
    };
    const PointSet dirs = sampleSphereUniform(4000, 1.0f);
    std::uint32_t seed = 7;
    const auto next = [&] {
        seed = seed * 1664525u + 1013904223u;
        return float(seed >> 8) / float(1 << 24);
    };
    for (int k = 0; k < 500; ++k) {
        const glm::vec3 c{(next() - 0.5f) * 12.0f, (next() - 0.5f) * 10.0f, -next() * 12.0f};
        const float r = 0.05f + next();
        bool sampled = inside(c);
        for (const auto& d : dirs.position) sampled = sampled || inside(c + d * r * 0.99f);
        const bool analytic = frustum.intersects(c, r);
        if (sampled) {
            EXPECT_TRUE(analytic) << "culled a visible sphere";
        }
    }
}

} // namespace
} // namespace pnsplat
