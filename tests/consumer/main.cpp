// A program outside the project, built against an installed pnsplat (tests/consumer/run.cmake):
// refines a small sphere with pnsplat::refine, then draws it with pnsplat::engine's real-time engine
// (whose shaders are compiled into the library), refined for its camera, and checks what each gave.
// Exit status 1 and one line on failure.
#include <cstddef>
#include <cstdio>
#include <string>
#include <utility>

#include "pnsplat/engine/camera.h"
#include "pnsplat/engine/context.h"
#include "pnsplat/engine/engine.h"
#include "pnsplat/refine/radius_estimation.h"
#include "pnsplat/refine/refiner.h"
#include "pnsplat/refine/shapes/shapes.h"

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
    engine::EngineSettings settings;
    settings.render.width = settings.render.height = 64;
    settings.render.path =
        !engine::computePathProblem(**context) ? engine::RenderPath::Compute : engine::RenderPath::Graphics;
    auto created = engine::Engine::create(**context, refiner.points(), settings);
    if (!created) return fail("engine", created.error().message);
    engine::Engine& view = **created;
    const engine::Camera camera = engine::frameSphere(view.bounds(), 1.0f, 0.7f, 0.0f);
    engine::FrameOptions options;
    options.lockstep = true; // refined for this camera until settled
    options.readBack = true;
    auto frame = view.frame(camera, options);
    if (!frame) return fail("frame", frame.error().message);
    auto image = view.image(frame->frame);
    if (!image) return fail("image", image.error().message);
    // The sphere fills the centre of the picture: grey splats, not the white background.
    const glm::u8vec4 centre = image->at(32, 32);
    if (centre.x == 255 && centre.y == 255 && centre.z == 255) {
        return fail("render", "the centre of the picture is background, where the sphere should be");
    }
    std::printf("pnsplat_consumer: %zu points refined to %zu, drawn as %zu splats on %s (centre pixel "
                "%d,%d,%d)\n",
                kInput, refiner.points().size(), frame->splatsDrawn, (*context)->deviceName().c_str(),
                centre.x, centre.y, centre.z);
    return 0;
}
