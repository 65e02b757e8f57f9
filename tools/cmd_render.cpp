// `pnsplat render`: splat a point set offscreen (optionally refined first) into a PNG.
#include <chrono>
#include <cmath>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/core.h>

#include "commands.h"
#include "pnsplat/engine/context.h"
#include "pnsplat/engine/engine.h"
#include "engine_setup.h"
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
    std::vector<float> camera;
    double orbitDegrees = 0.0;
    double fovDegrees = 40.0;
    unsigned refineLevels = 0;
    std::vector<std::string> holes; // "X,Y,Z,R", one per --fill-hole
    std::vector<float> background{1.0f, 1.0f, 1.0f};
    float radiusScale = 1.0f;
    bool flipNormals = false;
    bool adaptive = false;
    EngineArgs engine;
};

constexpr double kDegree = std::numbers::pi / 180.0;

void runRender(const RenderArgs& args) {
    using namespace engine;
    std::string name;
    PointSet points = loadForRendering(args.input, name);
    const std::size_t inputCount = points.size();
    if (args.refineLevels > 0 || !args.holes.empty()) {
        RefineJob job;
        job.levels = args.refineLevels;
        job.holes = parseHoles(args.holes);
        RefineRun run = refineWithProgress(std::move(points), job, name);
        points = std::move(run.points);
        fmt::print("refined {}: {} -> {} points in {} level(s), {:.2f} s\n", name, inputCount, points.size(),
                   run.levels, run.seconds);
    }
    if (args.flipNormals)
        for (auto& n : points.normal) n = -n;

    EngineArgs engineArgs = args.engine;
    auto context = createContext(engineArgs);
    EngineSettings settings = engineSettings(engineArgs, *context, args.adaptive);
    settings.render.background = {args.background[0], args.background[1], args.background[2]};
    settings.render.radiusScale = args.radiusScale;
    const std::size_t pointsIn = points.size();
    auto created = Engine::create(*context, std::move(points), settings);
    if (!created) throw CommandError(name + ": " + created.error().message);
    Engine& engine = **created;

    const float fov = static_cast<float>(args.fovDegrees * kDegree);
    Camera camera;
    if (!args.camera.empty()) {
        camera.eye = {args.camera[0], args.camera[1], args.camera[2]};
        camera.target = {args.camera[3], args.camera[4], args.camera[5]};
        camera.up = {args.camera[6], args.camera[7], args.camera[8]};
        camera.fovY = fov;
    } else {
        camera = frameSphere(engine.bounds(), float(args.engine.width) / float(args.engine.height), fov,
                             static_cast<float>(args.orbitDegrees * kDegree));
    }
    // One frame; with --adaptive in lockstep: refined for this camera until settled.
    FrameOptions frameOptions;
    frameOptions.lockstep = true;
    frameOptions.readBack = true;
    frameOptions.measureSplats = args.adaptive;
    const FrameReport drawn = unwrap(engine.frame(camera, frameOptions));
    const RgbaImage image = unwrap(engine.image(drawn.frame));
    engine.finish();
    const std::vector<FrameReport> reports = engine.reports();
    const PassTimes gpu = reports.empty() ? PassTimes{} : reports.back().gpu;
    unwrap(writePng(args.output, image));
    fmt::print(
        "{}: {} splats ({} in view) at {}x{} on {} ({} path): visibility {:.1f} ms, accumulation {:.1f} ms, "
        "normalization {:.1f} ms -> {}\n",
        name, engine.tree().pointCount(), drawn.splatsDrawn, args.engine.width, args.engine.height, context->deviceName(),
        settings.render.path == RenderPath::Compute ? "compute" : "graphics", gpu.visibilityMs,
        gpu.accumulationMs, gpu.normalizationMs, args.output);
    if (args.adaptive)
        fmt::print("{}: refined for this camera to splats of at most {:.2f} px ({:.2f} % above {} px): {} nodes, "
                   "{} points from {} in {:.0f} ms; {} drawn\n",
                   name, drawn.maxSplatPx, 100.0 * drawn.overThreshold, args.engine.threshold, engine.tree().nodeCount(),
                   engine.tree().pointCount(), pointsIn, drawn.refineWaitMs, drawn.splatsDrawn);
    checkValidation(*context);
}

} // namespace

void addRenderCommand(CLI::App& app) {
    auto args = std::make_shared<RenderArgs>();
    CLI::App* cmd =
        app.add_subcommand("render", "Render a point set offscreen as surface splats into a PNG (Vulkan)");
    cmd->add_option("input", args->input, "input PLY; omitted: the embedded default model");
    cmd->add_option("-o,--output", args->output, "output PNG")->capture_default_str();
    cmd->add_option("--width", args->engine.width, "image width in pixels")->capture_default_str();
    cmd->add_option("--height", args->engine.height, "image height in pixels")->capture_default_str();
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
    cmd->add_option("--background", args->background, "background colour r,g,b in [0, 1]")
        ->delimiter(',')
        ->expected(3)
        ->check(CLI::Range(0.0, 1.0));
    cmd->add_option("--radius-scale", args->radiusScale, "splat radius as a multiple of the point radius")
        ->check(CLI::Range(0.01, 100.0))
        ->capture_default_str();
    cmd->add_flag("--flip-normals", args->flipNormals, "negate every normal (shows why orientation matters)");
    cmd->add_flag("--adaptive", args->adaptive,
                  "refine, for this camera, exactly what it needs (the real-time engine, until settled)");
    addEngineOptions(*cmd, args->engine, true, true);
    cmd->callback([args] { runRender(*args); });
}

} // namespace pnsplat::tools
