// `pnsplat render`: splat a point set offscreen (optionally refined first) into a PNG.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/core.h>

#include "commands.h"
#include "engine_setup.h"
#include "pnsplat/engine/context.h"
#include "pnsplat/engine/engine.h"
#include "pnsplat/engine/image.h"
#include "pnsplat/refine/angles.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/shapes/shapes.h"
#include "pnsplat/refine/text.h"
#include "refine_run.h"
#include "render_compare.h"

namespace pnsplat::tools {

namespace {

struct RenderArgs {
    std::string input;
    std::string output = "render.png";
    CameraArgs view;
    std::string frame; // choose the camera for this file's points instead of the input's
    unsigned refineLevels = 0;
    std::vector<std::string> holes; // "X,Y,Z,R", one per --fill-hole
    std::string fillHoles;          // --fill-holes SIZE
    std::size_t maxPoints = 0;
    std::vector<float> background{1.0f, 1.0f, 1.0f};
    bool flipNormals = false;
    bool adaptive = false;
    bool compare = false;
    std::string reference;    // --compare: a dense PLY of the same surface
    std::string referencePng; // --compare: where to write the reference's render
    EngineArgs engine;
    bool json = false;
    bool keepNormals = false;
    bool keepOutliers = false;
    bool force = false;
    std::vector<std::string> columns; // the input's, when it is text

    InputOptions inputOptions() const { return {.keepNormals = keepNormals, .keepOutliers = keepOutliers}; }
};

// "+x", "-z", ...: the name of an axis direction.
std::string axisName(glm::vec3 direction) {
    for (int axis = 0; axis < 3; ++axis)
        if (direction[axis] != 0.0f)
            return (direction[axis] > 0.0f ? "+" : "-") + std::string(1, "xyz"[axis]);
    return "?";
}

// How the viewpoint was chosen, for the summary.
std::string viewpointReason(const engine::Viewpoint& view, const RenderArgs& args) {
    const char* up =
        args.view.up != "auto" ? "given" : (view.upFromBase ? "the model's base" : "no base stands out");
    return fmt::format("up {}: {}; eye on {}{}", axisName(view.up), up, axisName(view.front),
                       view.frontFlipped ? " (a flat face fills the other side, or no normal faces it)" : "");
}

// "23.41 dB" ("identical" for the same pictures).
std::string decibels(double psnr) {
    return std::isfinite(psnr) ? fmt::format("{:.2f} dB", psnr) : "identical";
}

// render --compare: three panels from the input's camera, and their PSNR against a dense render.
void runCompare(const RenderArgs& args) {
    using namespace engine;
    refuseToOverwriteInput(args.output, {args.input, args.frame, args.reference}, args.force);
    refuseToOverwriteInput(args.referencePng, {args.input, args.frame, args.reference}, args.force);
    std::FILE* summary = isStandardOutput(args.output) ? stderr : stdout;
    CompareJob job;
    std::string name;
    InputCompletion completion;
    glm::dvec3 origin(0.0); // the input's (PlyData::origin): the other files are drawn less it too
    job.input = loadForRendering(args.input, args.inputOptions(), name, args.columns, &completion, &origin);
    std::string frameName;
    const PointSet frame =
        args.frame.empty() ? PointSet() : loadBeside(args.frame, args.inputOptions(), frameName, origin);
    std::string referenceName;
    if (!args.reference.empty()) {
        // A reference is the true surface densely sampled (a mesh's vertices, say): kept whole.
        job.reference = loadBeside(args.reference, {.keepNormals = args.keepNormals, .keepOutliers = true},
                                   referenceName, origin);
    } else if (args.input.empty()) {
        // The default model is analytic: its dense version is the same surface sampled densely.
        referenceName = "the default model's dense version";
        PointSet dense = sampleDefaultModel(kDefaultReferencePoints);
        completeInput(dense, 0, referenceName, {.keepOutliers = true});
        job.reference = std::move(dense);
    }
    const std::size_t referencePoints = job.reference ? job.reference->size() : 0;
    std::optional<Viewpoint> view;
    // The camera is chosen once, for the input, and used for every panel and the reference.
    job.camera = chooseCamera(args.view, args.frame.empty() ? job.input : frame,
                              float(args.engine.width) / float(args.engine.height), view, origin);
    job.engine = args.engine;
    job.background = {args.background[0], args.background[1], args.background[2]};
    const std::size_t inputCount = job.input.size();
    const Camera camera = job.camera;

    auto context = createContext(args.engine);
    const Comparison c = renderComparison(*context, std::move(job));
    const std::string captions[3] = {
        fmt::format("input: {} points", inputCount),
        c.splats ? fmt::format("input as splats: PSNR {}", decibels(c.splats->psnr)) : "input as splats",
        c.refined ? fmt::format("refined for this camera: {} splats, PSNR {}", c.refinedFrame.splatsDrawn,
                                decibels(c.refined->psnr))
                  : fmt::format("refined for this camera: {} splats", c.refinedFrame.splatsDrawn)};
    unwrap(writePng(args.output, sideBySide(c.panels, captions)));
    if (!args.referencePng.empty() && !c.reference.pixels.empty())
        unwrap(writePng(args.referencePng, c.reference));
    checkValidation(*context);
    const char* path = c.path == RenderPath::Compute ? "compute" : "graphics";
    const auto psnr = [](const std::optional<ImageDifference>& d) {
        return d && std::isfinite(d->psnr) ? fmt::format("{:.3f}", d->psnr) : std::string("null");
    };
    const auto ssim = [](const std::optional<ImageDifference>& d) {
        return d ? fmt::format("{:.5f}", d->ssim) : std::string("null");
    };
    if (args.json) {
        fmt::print(
            summary,
            R"({{"input": {}, "output": {}, "input_points": {}, "compare": true, "panel_width": {}, )"
            R"("panel_height": {}, "device": {}, "path": "{}", "camera": "{}", "fov_degrees": {}, )"
            R"("refined_splats": {}, "tree_points": {}, "threshold_px": {}, "max_splat_px": {:.3f}, "over_threshold": {:.5f}, )"
            R"("reference": {}, "reference_points": {}, "psnr_splats": {}, "psnr_refined": {}, )"
            R"("ssim_splats": {}, "ssim_refined": {}, "outliers": {}}})"
            "\n",
            args.input.empty() ? "null" : jsonString(args.input), jsonString(outputName(args.output)),
            inputCount, args.engine.width, args.engine.height, jsonString(context->deviceName()), path,
            engine::cameraText(camera, origin), jsonNumber(args.view.fovDegrees), c.refinedFrame.splatsDrawn,
            c.treePoints, jsonNumber(args.engine.threshold), c.refinedFrame.maxSplatPx,
            c.refinedFrame.overThreshold,
            c.splats
                ? jsonString(args.reference.empty() ? std::string("default-model-dense") : args.reference)
                : "null",
            referencePoints, psnr(c.splats), psnr(c.refined), ssim(c.splats), ssim(c.refined),
            completion.outliers);
        return;
    }
    fmt::print(summary,
               "{}: {} points as dots, as splats, and refined for this camera ({} splats drawn, the largest "
               "{:.2f} px) "
               "in three {}x{} panels on {} ({} path) -> {}\n",
               name, inputCount, c.refinedFrame.splatsDrawn, c.refinedFrame.maxSplatPx, args.engine.width,
               args.engine.height, context->deviceName(), path, outputName(args.output));
    if (c.splats)
        fmt::print(
            summary,
            "against {} ({} points, the same camera): PSNR input as splats {}, refined {}{}; SSIM {:.4f}, "
            "{:.4f}\n",
            referenceName, referencePoints, decibels(c.splats->psnr), decibels(c.refined->psnr),
            // Only where both are finite: a picture identical to the reference has no decibels.
            std::isfinite(c.splats->psnr) && std::isfinite(c.refined->psnr)
                ? fmt::format(" ({:+.2f} dB)", c.refined->psnr - c.splats->psnr)
                : "",
            c.splats->ssim, c.refined->ssim);
    if (view)
        fmt::print(summary, "camera: --camera {} ({}{})\n", engine::cameraText(camera, origin),
                   viewpointReason(*view, args), args.frame.empty() ? "" : ", framing " + args.frame);
}

void runRender(const RenderArgs& args) {
    using namespace engine;
    if (args.compare) return runCompare(args);
    refuseToOverwriteInput(args.output, {args.input, args.frame}, args.force);
    // Standard output carries the image: the summaries go to standard error.
    std::FILE* summary = isStandardOutput(args.output) ? stderr : stdout;
    std::string name;
    InputCompletion completion;
    glm::dvec3 origin(0.0); // the input's (PlyData::origin): the framing file is drawn less it too
    PointSet points =
        loadForRendering(args.input, args.inputOptions(), name, args.columns, &completion, &origin);
    std::string frameName;
    const PointSet frame =
        args.frame.empty() ? PointSet() : loadBeside(args.frame, args.inputOptions(), frameName, origin);
    std::optional<Viewpoint> view;
    const Camera camera = chooseCamera(args.view, args.frame.empty() ? points : frame,
                                       float(args.engine.width) / float(args.engine.height), view, origin);

    const std::size_t inputCount = points.size();
    unsigned levels = 0;
    if (args.refineLevels > 0 || !args.holes.empty() || !args.fillHoles.empty()) {
        RefineJob job;
        job.levels = args.refineLevels;
        job.holes = parseHoles(args.holes, origin);
        job.origin = origin;
        job.fillHolesUpTo = parseHoleSize(args.fillHoles);
        job.keepNormals = args.keepNormals;
        job.keepOutliers = true; // loadForRendering has left them out (or was asked to keep them)
        job.maxPoints = args.maxPoints;
        RefineRun run = refineWithProgress(std::move(points), job, name);
        points = std::move(run.points);
        levels = run.levels;
        if (!args.json)
            fmt::print(summary, "refined {}: {} -> {} points in {} level(s), {:.2f} s\n", name, inputCount,
                       points.size(), run.levels, run.seconds);
    }
    if (args.flipNormals)
        for (auto& n : points.normal) n = -n;

    EngineArgs engineArgs = args.engine;
    auto context = createContext(engineArgs);
    EngineSettings settings = engineSettings(engineArgs, *context, args.adaptive);
    settings.render.background = {args.background[0], args.background[1], args.background[2]};
    const std::size_t pointsIn = points.size();
    // One picture needs only the splats that can change it: a deep refinement whose splats pass the
    // device's largest texel buffer draws when those in view fit (the same picture).
    if (!args.adaptive)
        removePoints(points,
                     splatsOutOfPicture(points.position, points.normal, points.radius, camera,
                                        args.engine.width, args.engine.height, settings.render.radiusScale));
    const std::size_t pointsDrawn = points.size();
    auto created = Engine::create(*context, std::move(points), settings);
    if (!created)
        throw CommandError(
            args.adaptive || pointsDrawn == pointsIn
                ? name + ": " + created.error().message
                : fmt::format("{}: {} ({} of its {} splats can be in this picture; fewer levels or a camera "
                              "that sees less would draw)",
                              name, created.error().message, pointsDrawn, pointsIn));
    Engine& engine = **created;

    FrameOptions
        frameOptions; // one frame; with --adaptive in lockstep: refined for this camera until settled
    frameOptions.lockstep = true;
    frameOptions.readBack = true;
    frameOptions.measureSplats = args.adaptive;
    const FrameReport drawn = unwrap(engine.frame(camera, frameOptions));
    const RgbaImage image = unwrap(engine.image(drawn.frame));
    engine.finish();
    const std::vector<FrameReport> reports = engine.reports();
    const PassTimes gpu = reports.empty() ? PassTimes{} : reports.back().gpu;
    unwrap(writePng(args.output, image));
    checkValidation(*context);
    const char* path = settings.render.path == RenderPath::Compute ? "compute" : "graphics";
    const std::size_t splats = args.adaptive ? engine.tree().pointCount() : pointsIn;
    const std::size_t covered =
        engine::coveredPixels(image.pixels, engine::backgroundPixel(settings.render.background));
    const double perCovered = covered > 0 ? double(drawn.splatsDrawn) / double(covered) : 0.0;
    // A tree only drawn refines nothing.
    const double refineMs = args.adaptive ? engine.refinementMs(drawn) : 0.0;
    if (args.json) {
        fmt::print(
            summary,
            R"({{"input": {}, "output": {}, "input_points": {}, "levels": {}, "splats": {}, "splats_in_view": {}, )"
            R"("width": {}, "height": {}, "device": {}, "path": "{}", "visibility_ms": {:.3f}, "accumulation_ms": {:.3f}, )"
            R"("normalization_ms": {:.3f}, "camera": "{}", "fov_degrees": {}, "frame": {}, "up": {}, "eye_side": {}, )"
            R"("adaptive": {}, "threshold_px": {}, "nodes": {}, "median_splat_px": {:.3f}, "p99_splat_px": {:.3f}, )"
            R"("max_splat_px": {:.3f}, )"
            R"("over_threshold": {:.5f}, "covered_px": {}, "splats_per_covered_px": {:.3f}, "refine_ms": {:.1f}, )"
            R"("settled": {}, "outliers": {}}})"
            "\n",
            args.input.empty() ? "null" : jsonString(args.input), jsonString(outputName(args.output)),
            inputCount, levels, splats, drawn.splatsDrawn, args.engine.width, args.engine.height,
            jsonString(context->deviceName()), path, gpu.visibilityMs, gpu.accumulationMs,
            gpu.normalizationMs, engine::cameraText(camera, origin), jsonNumber(args.view.fovDegrees),
            args.frame.empty() ? "null" : jsonString(args.frame),
            view ? jsonString(axisName(view->up)) : "null", view ? jsonString(axisName(view->front)) : "null",
            args.adaptive ? "true" : "false", jsonNumber(args.engine.threshold), engine.tree().nodeCount(),
            drawn.medianSplatPx, drawn.p99SplatPx, drawn.maxSplatPx, drawn.overThreshold, covered, perCovered,
            refineMs, args.adaptive ? (drawn.settled ? "true" : "false") : "null", completion.outliers);
        return;
    }
    fmt::print(
        summary,
        "{}: {} splats ({} in view) at {}x{} on {} ({} path): visibility {:.1f} ms, accumulation {:.1f} ms, "
        "normalization {:.1f} ms; {} pixels covered, {:.3g} splats each -> {}\n",
        name, splats, drawn.splatsDrawn, args.engine.width, args.engine.height, context->deviceName(), path,
        gpu.visibilityMs, gpu.accumulationMs, gpu.normalizationMs, covered, perCovered,
        outputName(args.output));
    if (args.adaptive) {
        // A frame in lockstep stops short of the threshold where nothing more can move, the cache
        // full (not settled); and nodes at the deepest level are refined no further (settled, their
        // splats maybe still wider). Say which rather than claim the threshold.
        const std::uint32_t maxLevel = engine.tree().settings().maxLevel;
        const std::string reached =
            !drawn.settled ? fmt::format("as far as the cache of {} MiB holds, short of a median splat of {} "
                                         "px (--cache-mb raises it)",
                                         args.engine.cacheMb, args.engine.threshold)
            : engine.deepestDrawnLevel() == maxLevel && drawn.medianSplatPx > args.engine.threshold
                ? fmt::format("to its deepest level ({}), short of a median splat of {} px", maxLevel,
                              args.engine.threshold)
                : fmt::format("until its median splat is at most {} px wide and its silhouettes are smooth",
                              args.engine.threshold);
        fmt::print(
            summary,
            "{}: refined for this camera {} (median {:.2f} px, {:.1f} % above, 99 % at most {:.2f} px, "
            "the largest {:.2f} px): {} nodes, {} points from {} in {:.0f} ms\n",
            name, reached, drawn.medianSplatPx, 100.0 * drawn.overThreshold, drawn.p99SplatPx,
            drawn.maxSplatPx, engine.tree().nodeCount(), splats, pointsIn, refineMs);
    }
    if (view)
        fmt::print(summary, "camera: --camera {} ({}{})\n", engine::cameraText(camera, origin),
                   viewpointReason(*view, args), args.frame.empty() ? "" : ", framing " + args.frame);
}

} // namespace

void addRenderCommand(CLI::App& app) {
    const auto [cmd, args] = addSubcommand(
        app, "render", "Render a point set offscreen as surface splats into a PNG (Vulkan)", runRender);
    cmd->add_option("input", args->input,
                    "input point file: PLY, PCD or text (.xyz .txt .pts .csv; README, Use), - for standard "
                    "input; omitted: the embedded default model");
    addColumnsOption(*cmd, args->columns);
    cmd->add_option("-o,--output", args->output, "output PNG, - for standard output")->capture_default_str();
    addForceFlag(*cmd, args->force);
    addSizeOptions(*cmd, args->engine, "image {} in pixels", 1);
    CLI::Option* camera = addCameraOptions(*cmd, args->view);
    cmd->add_option("--frame", args->frame,
                    "choose the camera for this PLY's points instead of the input's (a sparse input and its "
                    "refinement framed by the same file are seen from the same camera)")
        ->excludes(camera);
    cmd->add_option("--refine-levels", args->refineLevels,
                    "refine this many levels first (the paper's method)")
        ->check(CLI::Range(0u, 16u));
    addFillHoleOptions(*cmd, args->holes, args->fillHoles);
    addMaxPointsOption(*cmd, args->maxPoints);
    addBackgroundOption(*cmd, args->background);
    cmd->add_flag("--flip-normals", args->flipNormals, "negate every normal (shows why orientation matters)");
    CLI::Option* adaptive =
        cmd->add_flag("--adaptive", args->adaptive,
                      "refine, for this camera, exactly what it needs (the real-time engine, until settled)");
    CLI::Option* compare = cmd->add_flag(
        "--compare", args->compare,
        "three panels side by side from one camera (chosen for the input): the input as points, "
        "as splats, and refined for this camera as --adaptive does; --width and --height are "
        "each panel's; with a reference (the default model has its own), prints how close the "
        "splats and the refinement come to its render (PSNR, SSIM)");
    compare->excludes(adaptive)
        ->excludes("--refine-levels")
        ->excludes("--fill-hole")
        ->excludes("--fill-holes")
        ->excludes("--flip-normals");
    cmd->add_option("--reference", args->reference,
                    "with --compare: a dense PLY of the same surface, rendered from the same camera as the "
                    "ground truth (default for the default model: its dense version, "
                    "300,000 points of the same analytic surface)")
        ->needs(compare);
    cmd->add_option("--reference-png", args->referencePng,
                    "with --compare: write the reference's render (one panel's size) to this PNG")
        ->needs(compare);
    addEngineOptions(*cmd, args->engine, true, true);
    cmd->add_flag("--json", args->json,
                  "print the summary as one JSON line on standard output (fields: see README, Use)");
    addKeepNormalsOption(*cmd, args->keepNormals);
    addKeepOutliersOption(*cmd, args->keepOutliers);
}

} // namespace pnsplat::tools
