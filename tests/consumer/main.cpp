// A program outside the project, built against an installed pnsplat (tests/consumer/run.cmake):
// refines a small sphere with pnsplat::refine and splats it with pnsplat::engine (whose shaders are
// compiled into the library), and checks what each gave. Exit status 1 and one line on failure.
#include <cstddef>
#include <cstdio>
#include <string>
#include <utility>

#include "pnsplat/engine/camera.h"
#include "pnsplat/engine/context.h"
#include "pnsplat/engine/splat_renderer.h"
#include "pnsplat/engine/splat_scene.h"
#include "pnsplat/refine/radius_estimation.h"
#include "pnsplat/refine/refiner.h"
#include "pnsplat/refine/shapes.h"

namespace {

int fail(const char* what, const std::string& why) {
    std::fprintf(stderr, "pnsplat_consumer: %s: %s\n", what, why.c_str());
    return 1;
}

} // namespace

int main() {
    using namespace pnsplat;
    constexpr std::size_t kInput = 200;
    PointSet sphere = sampleSphereUniform(kInput, 1.0f);
    estimateRadii(sphere);
    Refiner refiner(std::move(sphere), RefineOptions{});
    const LevelStats level = refiner.refineLevel();
    if (level.inserted == 0 || refiner.points().size() != kInput + level.inserted) {
        return fail("refine", "one level of a 200-point sphere inserted " + std::to_string(level.inserted) +
                                  " points and holds " + std::to_string(refiner.points().size()));
    }

    auto context = engine::Context::create();
    if (!context) return fail("Vulkan", context.error().message);
    auto scene = engine::SplatScene::create(**context, refiner.points());
    if (!scene) return fail("scene", scene.error().message);
    engine::RenderSettings settings;
    settings.width = settings.height = 64;
    settings.path =
        (*context)->hasInt64Atomics() ? engine::RenderPath::Compute : engine::RenderPath::Graphics;
    auto renderer = engine::SplatRenderer::create(**context, settings);
    if (!renderer) return fail("renderer", renderer.error().message);
    const engine::Camera camera = engine::frameSphere(scene->bounds(), 1.0f, 0.7f, 0.0f);
    auto image = (*renderer)->render(*scene, camera);
    if (!image) return fail("render", image.error().message);
    // The sphere fills the centre of the picture: grey splats, not the white background.
    const glm::u8vec4 centre = image->at(32, 32);
    if (centre.x == 255 && centre.y == 255 && centre.z == 255) {
        return fail("render", "the centre of the picture is background, where the sphere should be");
    }
    std::printf("pnsplat_consumer: %zu points refined to %zu, rendered on %s (centre pixel %d,%d,%d)\n",
                kInput, refiner.points().size(), (*context)->deviceName().c_str(), centre.x, centre.y,
                centre.z);
    return 0;
}
