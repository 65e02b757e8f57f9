// `pnsplat render`: splat a point set offscreen (optionally refined first) into a PNG.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/core.h>

#include "commands.h"
#include "pnsplat/engine/context.h"
#include "pnsplat/engine/image.h"
#include "pnsplat/engine/splat_renderer.h"
#include "pnsplat/refine/ply.h"
#include "pnsplat/refine/shapes.h"
#include "refine_run.h"

namespace pnsplat::tools {

namespace {

struct RenderArgs {
    std::string input;
    std::string output = "render.png";
    std::uint32_t width = 1280, height = 720;
    std::vector<float> camera;
    double orbitDegrees = 0.0;
    double fovDegrees = 40.0;
    unsigned refineLevels = 0;
    std::vector<std::string> holes; // "X,Y,Z,R", one per --fill-hole
    std::size_t maxPoints = 0;
    std::string path = "auto";
    std::string device;
    std::vector<float> background{1.0f, 1.0f, 1.0f};
    float radiusScale = 1.0f;
    bool validation = false;
    bool flipNormals = false;
    bool force = false;
};

constexpr double kDegree = std::numbers::pi / 180.0;

// The points of `input` (a PLY file, or the embedded default model when empty) with normals and
// radii (estimated when the file has none); `name` receives a name for messages.
PointSet loadForRendering(const std::string& input, std::string& name) {
    PointSet points;
    if (input.empty()) {
        name = "the default model";
        points = makeDefaultModel();
    } else {
        name = inputName(input);
        points = readInput(input);
    }
    completeInput(points, 0, name);
    return points;
}

// "auto" is the compute path where the device has what it needs (on lavapipe it is several times
// faster than the raster pipeline), else the graphics path.
engine::RenderPath choosePath(const std::string& path, const engine::Context& context) {
    if (path == "graphics") return engine::RenderPath::Graphics;
    if (path == "compute" || context.hasInt64Atomics()) return engine::RenderPath::Compute;
    return engine::RenderPath::Graphics;
}

void runRender(const RenderArgs& args) {
    using namespace engine;
    refuseToOverwriteInput(args.output, {args.input}, args.force);
    // Standard output carries the image: the summaries go to standard error.
    std::FILE* summary = isStandardOutput(args.output) ? stderr : stdout;
    std::string name;
    PointSet points = loadForRendering(args.input, name);
    const std::size_t inputCount = points.size();
    if (args.refineLevels > 0 || !args.holes.empty()) {
        RefineJob job;
        job.levels = args.refineLevels;
        job.holes = parseHoles(args.holes);
        job.maxPoints = args.maxPoints;
        RefineRun run = refineWithProgress(std::move(points), job, name);
        points = std::move(run.points);
        fmt::print(summary, "refined {}: {} -> {} points in {} level(s), {:.2f} s\n", name, inputCount,
                   points.size(), run.levels, run.seconds);
    }
    if (args.flipNormals)
        for (auto& n : points.normal) n = -n;

    ContextOptions contextOptions;
    contextOptions.deviceName = args.device;
#ifndef NDEBUG
    contextOptions.validation = true;
#endif
    contextOptions.validation |= args.validation;
    auto context = unwrap(Context::create(contextOptions));
    auto created = SplatScene::create(*context, points);
    if (!created) throw CommandError(name + ": " + created.error().message);
    const SplatScene scene = std::move(created).value();

    RenderSettings settings;
    settings.width = args.width;
    settings.height = args.height;
    settings.path = choosePath(args.path, *context);
    settings.background = {args.background[0], args.background[1], args.background[2]};
    settings.radiusScale = args.radiusScale;
    auto renderer = unwrap(SplatRenderer::create(*context, settings));

    const float fov = static_cast<float>(args.fovDegrees * kDegree);
    Camera camera;
    if (!args.camera.empty()) {
        camera.eye = {args.camera[0], args.camera[1], args.camera[2]};
        camera.target = {args.camera[3], args.camera[4], args.camera[5]};
        camera.up = {args.camera[6], args.camera[7], args.camera[8]};
        camera.fovY = fov;
    } else {
        camera = frameSphere(scene.bounds(), float(args.width) / float(args.height), fov,
                             static_cast<float>(args.orbitDegrees * kDegree));
    }
    FrameStats stats;
    const RgbaImage image = unwrap(renderer->render(scene, camera, &stats));
    unwrap(writePng(args.output, image));
    fmt::print(
        summary,
        "{}: {} splats ({} in view) at {}x{} on {} ({} path): visibility {:.1f} ms, accumulation {:.1f} ms, "
        "normalization {:.1f} ms -> {}\n",
        name, stats.splats, stats.splatsDrawn, args.width, args.height, context->deviceName(),
        settings.path == RenderPath::Compute ? "compute" : "graphics", stats.visibilityMs,
        stats.accumulationMs, stats.normalizationMs, outputName(args.output));
    if (context->validationMessages() > 0)
        throw CommandError(fmt::format("{} validation message(s); the last: {}",
                                       context->validationMessages(), context->lastValidationMessage()));
}

} // namespace

void addRenderCommand(CLI::App& app) {
    auto args = std::make_shared<RenderArgs>();
    CLI::App* cmd =
        app.add_subcommand("render", "Render a point set offscreen as surface splats into a PNG (Vulkan)");
    cmd->add_option("input", args->input,
                    "input PLY, - for standard input; omitted: the embedded default model");
    cmd->add_option("-o,--output", args->output, "output PNG, - for standard output")->capture_default_str();
    addForceFlag(*cmd, args->force);
    cmd->add_option("--width", args->width, "image width in pixels")->capture_default_str();
    cmd->add_option("--height", args->height, "image height in pixels")->capture_default_str();
    auto* camera = cmd->add_option("--camera", args->camera, "eye, target and up: ex,ey,ez,tx,ty,tz,ux,uy,uz")
                       ->delimiter(',')
                       ->expected(9);
    cmd->add_option("--orbit", args->orbitDegrees, "turn the framing camera about the vertical axis, degrees")
        ->excludes(camera)
        ->capture_default_str();
    cmd->add_option("--fov", args->fovDegrees, "vertical field of view, degrees")
        ->check(CLI::Range(1.0, 179.0))
        ->capture_default_str();
    cmd->add_option("--refine-levels", args->refineLevels,
                    "refine this many levels first (the paper's method)")
        ->check(CLI::Range(0u, 16u));
    addFillHoleOption(*cmd, args->holes);
    addMaxPointsOption(*cmd, args->maxPoints);
    cmd->add_option("--path", args->path,
                    "compute (atomics), graphics (raster pipeline), or auto: compute where the device can")
        ->check(CLI::IsMember({"auto", "compute", "graphics"}))
        ->capture_default_str();
    cmd->add_option("--device", args->device,
                    "Vulkan device whose name contains this text (default: a GPU, else lavapipe)");
    cmd->add_option("--background", args->background, "background colour r,g,b in [0, 1]")
        ->delimiter(',')
        ->expected(3)
        ->check(CLI::Range(0.0, 1.0));
    cmd->add_option("--radius-scale", args->radiusScale, "splat radius as a multiple of the point radius")
        ->check(CLI::Range(0.01, 100.0))
        ->capture_default_str();
    cmd->add_flag("--validation", args->validation,
                  "load the Vulkan validation layer; any message fails the command");
    cmd->add_flag("--flip-normals", args->flipNormals, "negate every normal (shows why orientation matters)");
    cmd->callback([args] { runRender(*args); });
}

} // namespace pnsplat::tools
