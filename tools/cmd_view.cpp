// `pnsplat view`: the real-time engine in a window (the viewer library, viewer.h), with the options
// `render` and `bench view` share; --stats writes bench view's JSON lines.
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <fmt/core.h>

#include "commands.h"
#include "engine_setup.h"
#include "frame_json.h"
#include "pnsplat/viewer/viewer.h"
#include "refine_run.h"

namespace pnsplat::tools {

namespace {

struct ViewArgs {
    std::string input;
    EngineArgs engine;
    CameraArgs camera;
    std::vector<float> background{1.0f, 1.0f, 1.0f};
    std::string vsync = "on";
    std::string script, screenshot, stats;
    std::size_t frames = 0;
    bool screenshotOverlay = false;
    bool keepNormals = false;
    std::vector<std::string> columns; // the input's (and dropped files'), when text
    bool keepOutliers = false;
    std::string fillHoles; // --fill-holes SIZE
};

// The model of `path` (empty: the embedded default model), its holes up to `holes` filled, framed
// as `render` frames it.
viewer::Model loadModel(const std::string& path, const CameraArgs& camera, float aspect,
                        const InputOptions& input, const std::vector<std::string>& columns,
                        const HoleSize& holes) {
    viewer::Model model;
    glm::dvec3 origin(0.0);
    PointSet points = loadForRendering(path, input, model.name, columns, nullptr, &origin);
    model.points = withHolesFilled(std::move(points), holes, model.name, origin);
    std::optional<engine::Viewpoint> view;
    model.camera = chooseCamera(camera, model.points, aspect, view, origin);
    model.origin = origin;
    model.bounds = engine::boundingSphere(model.points.position);
    return model;
}

void runView(const ViewArgs& args) {
    // The window system first: without a display, nothing else is worth doing.
    auto windows = viewer::WindowSystem::open();
    if (!windows) throw CommandError(windows.error().message);
    // Through OutputFile like every output: it appears whole when the session ends, and not at all
    // when it fails.
    std::optional<OutputFile> stats;
    if (!args.stats.empty()) stats.emplace(unwrap(OutputFile::open(args.stats, OutputContent::Text)));
    const InputOptions input{.keepNormals = args.keepNormals, .keepOutliers = args.keepOutliers};
    const HoleSize holes = parseHoleSize(args.fillHoles);
    viewer::Model model =
        loadModel(args.input, args.camera, float(args.engine.width) / float(args.engine.height), input,
                  args.columns, holes);

    engine::ContextOptions contextOptions;
    for (const std::string& name : (*windows)->instanceExtensions())
        contextOptions.instanceExtensions.push_back(name);
    contextOptions.deviceExtensions = viewer::WindowSystem::deviceExtensions();
    auto context = createContext(args.engine, contextOptions);

    viewer::ViewerOptions options;
    options.width = args.engine.width;
    options.height = args.engine.height;
    options.vsync = args.vsync == "on";
    options.engine = engineSettings(args.engine, *context, true);
    options.engine.render.background = {args.background[0], args.background[1], args.background[2]};
    options.script = args.script;
    options.frames = args.frames;
    options.screenshot = args.screenshot;
    options.screenshotOverlay = args.screenshotOverlay;

    // Dropped files are framed anew (--camera belongs to the first model); --fov stays.
    CameraArgs framing;
    framing.fovDegrees = args.camera.fovDegrees;
    // Dropped files are read as the input is: any point file, text columns named by --columns.
    const viewer::ModelLoader loader = [framing, input, columns = args.columns,
                                        holes](const std::string& path, float aspect) {
        return loadModel(path, framing, aspect, input, columns, holes);
    };
    FrameSeries series;
    viewer::FrameSink sink;
    if (stats)
        sink = [&](const engine::FrameReport& report, double frameMs, glm::dvec3 origin) {
            unwrap(stats->write(frameJson(report, frameMs, origin) + '\n'));
            series.add(report, frameMs);
        };
    const auto summary = viewer::run(**windows, *context, std::move(model), options, loader, sink);
    if (!summary) throw CommandError(summary.error().message);
    if (stats) {
        unwrap(stats->write(series.summaryJson(summary->seconds, summary->settings, context->deviceName(),
                                               context->driverName()) +
                            '\n'));
        unwrap(stats->commit());
    }
    checkValidation(*context);
}

} // namespace

void addViewCommand(CLI::App& app) {
    const auto [cmd, args] = addSubcommand(app, "view",
                                           "Show a point set in a window as the real-time engine refines it "
                                           "(camera controls, live statistics; H "
                                           "in the window lists the keys)",
                                           runView);
    // As bench view: at 2 px, lavapipe draws the bunny at 5 frames a second (docs/VIEWER.md).
    args->engine.targetFps = 24.0;
    cmd->add_option("input", args->input,
                    "input point file: PLY, PCD or text (.xyz .txt .pts .csv; README, Use); omitted: the "
                    "embedded default model (or drop a file on the window)");
    addColumnsOption(*cmd, args->columns);
    addSizeOptions(*cmd, args->engine, "window {} (screen units; the picture has the framebuffer's pixels)",
                   64);
    addCameraOptions(*cmd, args->camera);
    addBackgroundOption(*cmd, args->background);
    cmd->add_option("--vsync", args->vsync, "wait for the display between frames (off: as fast as they come)")
        ->check(CLI::IsMember({"on", "off"}))
        ->capture_default_str();
    addEngineOptions(*cmd, args->engine, true, false);
    cmd->add_option("--script", args->script,
                    "replay the timed input events of FILE (format: docs/VIEWER.md)");
    cmd->add_option("--frames", args->frames, "draw this many frames, then quit (0: until the window closes)")
        ->check(CLI::Range(std::size_t{0}, std::size_t{100000000}))
        ->capture_default_str();
    cmd->add_option(
        "--screenshot", args->screenshot,
        "after --frames frames (at least one), write the first frame drawn once the refinement has "
        "settled as a PNG, then quit");
    cmd->add_flag("--screenshot-overlay", args->screenshotOverlay,
                  "screenshots (this, P and a script's) include the statistics and other panels shown");
    cmd->add_option("--stats", args->stats,
                    "write one JSON line per frame to FILE, then a summary line (the fields of bench view)");
    addKeepNormalsOption(*cmd, args->keepNormals);
    addKeepOutliersOption(*cmd, args->keepOutliers);
    addFillHolesOption(*cmd, args->fillHoles);
}

} // namespace pnsplat::tools
