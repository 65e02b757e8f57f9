// `pnsplat bench view`: the real-time engine offscreen along a camera path, one JSON object per
// frame on standard output, then a summary line; with -o, the same lines in a file that appears
// whole at the end.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include <fmt/core.h>
#include <fmt/format.h>

#include "camera_path.h"
#include "commands.h"
#include "engine_setup.h"
#include "frame_json.h"
#include "pnsplat/engine/image.h"
#include "pnsplat/refine/io/output_file.h"
#include "refine_run.h"

namespace pnsplat::tools {

namespace {

struct BenchViewArgs {
    std::string input;
    std::string cameraPath = "orbit";
    std::size_t frames = 0; // 0: the path's own (orbit and zoom: 240)
    std::string capture;
    std::string output; // -o: every line again, the file whole at the end
    bool force = false;
    bool lockstep = false;
    bool measureSplats = false;
    std::size_t qualityEvery = 0; // 0: no quality frames
    EngineArgs engine;
    std::vector<std::string> columns; // the input's, when it is text
    bool keepOutliers = false;
    std::string fillHoles; // --fill-holes SIZE
};

constexpr std::size_t kDefaultFrames = 240;

void runBenchView(BenchViewArgs args) {
    using Clock = std::chrono::steady_clock;
    const bool pathFile = args.cameraPath != "orbit" && args.cameraPath != "zoom";
    refuseToOverwriteInput(args.output, {args.input, pathFile ? args.cameraPath : std::string()}, args.force);
    // Each line goes to standard output as it comes and, with -o (not standard output itself), to
    // the file, which appears whole once the run has ended well (opened first: a bad path fails at
    // once).
    std::optional<OutputFile> file;
    if (!args.output.empty() && !isStandardOutput(args.output))
        file.emplace(unwrap(OutputFile::open(args.output, OutputContent::Text)));
    const auto line = [&](const std::string& text) {
        fmt::print("{}\n", text);
        if (file) unwrap(file->write(text + '\n'));
    };
    std::string name;
    const HoleSize holes = parseHoleSize(args.fillHoles);
    glm::dvec3 origin(0.0);
    PointSet points = loadForRendering(args.input, {.keepOutliers = args.keepOutliers}, name, args.columns,
                                       nullptr, &origin);
    points = withHolesFilled(std::move(points), holes, name, origin);
    const std::size_t inputPoints = points.size();
    // A path file is read before the engine is made: a bad one fails at once, not after the whole
    // levels' refinement.
    std::optional<CameraPath> loaded;
    if (pathFile) loaded = CameraPath::load(args.cameraPath, origin);
    auto context = createContext(args.engine);
    const engine::EngineSettings settings = engineSettings(args.engine, *context, true);
    // The quality frames' reference engine draws the same points (standard input cannot be read twice).
    PointSet referencePoints;
    if (args.qualityEvery > 0) referencePoints = points;
    auto created = engine::Engine::create(*context, std::move(points), settings);
    if (!created) throw CommandError(name + ": " + created.error().message);
    engine::Engine& engine = **created;

    const float aspect = float(args.engine.width) / float(args.engine.height);
    const float fov = 40.0f * std::numbers::pi_v<float> / 180.0f;
    const std::size_t frames = args.frames > 0 ? args.frames : kDefaultFrames;
    const CameraPath path = loaded ? std::move(*loaded)
                            : args.cameraPath == "orbit"
                                ? CameraPath::orbit(engine.bounds(), aspect, fov, frames)
                                : CameraPath::zoom(engine.bounds(), aspect, fov, frames);
    const std::size_t count = args.frames > 0 ? args.frames : path.frames();
    if (!args.capture.empty()) {
        std::error_code error;
        std::filesystem::create_directories(args.capture, error);
        if (error)
            throw CommandError(args.capture + ": cannot create the capture folder: " + error.message());
    }
    fmt::print(
        stderr, "bench view: {} ({} points) along {} ({} frames) at {}x{} on {} ({}), {} worker(s){}\n", name,
        inputPoints, args.cameraPath, count, args.engine.width, args.engine.height, context->deviceName(),
        context->driverName(), settings.workers, args.lockstep ? ", lockstep" : "");

    engine::FrameOptions options;
    options.lockstep = args.lockstep;
    options.measureSplats = args.measureSplats;
    // Every frame is read back: its report counts the pixels it covers (a copy of the picture into
    // host memory in the frame's last command buffer, and a pass over it when the frame is done).
    options.readBack = true;
    // The pictures of the quality frames and their cameras, compared after the run (so that the
    // reference's refinement takes none of the run's time).
    struct QualityFrame {
        std::size_t index;
        engine::Camera camera;
        engine::RgbaImage picture;
    };
    std::vector<QualityFrame> quality;
    std::size_t taken = 0; // quality frames whose picture is read
    std::uint64_t firstFrame = 0;
    // The pictures of the quality frames before run frame `before` (all: count).
    const auto takeQuality = [&](std::size_t before) {
        for (; taken < quality.size() && quality[taken].index < before; ++taken)
            quality[taken].picture = unwrap(engine.image(firstFrame + quality[taken].index));
    };
    FrameSeries series;
    const Clock::time_point start = Clock::now();
    std::vector<Clock::time_point> starts; // by frame of the run (the engine's frames count on)
    Clock::time_point finished;            // the last frame's end: the engine finished
    // A frame lasts from its start to the next one's (the last: until the engine finished, before
    // the quality frames' pictures are read), so a frame done before the next one starts (a small
    // one, or one captured) waits here until then; `last`: every frame has ended.
    std::vector<engine::FrameReport> pending;
    const auto emit = [&](const std::vector<engine::FrameReport>& reports, bool last) {
        pending.insert(pending.end(), reports.begin(), reports.end());
        std::size_t done = 0;
        for (; done < pending.size(); ++done) {
            const std::size_t k = pending[done].frame - firstFrame;
            if (k + 1 >= starts.size() && !last) break;
            const Clock::time_point end = k + 1 < starts.size() ? starts[k + 1] : finished;
            const double frameMs = std::chrono::duration<double, std::milli>(end - starts[k]).count();
            line(frameJson(pending[done], frameMs, origin));
            series.add(pending[done], frameMs);
        }
        pending.erase(pending.begin(), pending.begin() + static_cast<std::ptrdiff_t>(done));
        std::fflush(stdout);
    };
    for (std::size_t k = 0; k < count; ++k) {
        starts.push_back(Clock::now());
        // A quality frame's picture, just before the frame that reuses its slot
        // (kFramesInFlight later): this frame's start waits for that frame to finish anyway, so the
        // wait falls where it would without quality frames. Taken one frame earlier, it made that
        // frame wait for its predecessor: every tenth frame took about two frames' time and the
        // next almost none (the bunny's zoom, 640x480: 71 ms and 12 ms against a median of 41).
        if (k >= engine::kFramesInFlight) takeQuality(k - engine::kFramesInFlight + 1);
        const engine::FrameReport report = unwrap(engine.frame(path.at(k), options));
        if (k == 0) firstFrame = report.frame;
        if (args.qualityEvery > 0 && k % args.qualityEvery == 0) quality.push_back({k, path.at(k), {}});
        if (!args.capture.empty()) {
            const engine::RgbaImage image = unwrap(engine.image(report.frame));
            unwrap(engine::writePng(fmt::format("{}/frame-{:05}.png", args.capture, k), image));
        }
        emit(engine.reports(), false);
    }
    engine.finish();
    finished = Clock::now();
    takeQuality(count);
    emit(engine.reports(), true);
    const double seconds = std::chrono::duration<double>(finished - start).count();
    if (!quality.empty()) {
        // The reference: the lockstep settled picture of each quality frame's camera, by an engine
        // of its own without hysteresis (each node decided for that camera alone) or target.
        engine::EngineSettings reference = settings;
        reference.targetFrameMs = 0.0f;
        reference.hysteresis = 1.0f;
        auto settled = engine::Engine::create(*context, std::move(referencePoints), reference);
        if (!settled) throw CommandError(name + ": " + settled.error().message);
        engine::FrameOptions lockstep;
        lockstep.lockstep = lockstep.readBack = true;
        fmt::print(stderr, "bench view: {} quality frames against the lockstep settled picture\n",
                   quality.size());
        for (const QualityFrame& q : quality) {
            const engine::FrameReport r = unwrap((*settled)->frame(q.camera, lockstep));
            const engine::RgbaImage picture = unwrap((*settled)->image(r.frame));
            const engine::ImageDifference d = unwrap(engine::compareImages(q.picture, picture));
            series.addQuality(d.psnr, d.ssim);
            line(fmt::format(
                R"({{"quality_frame": {}, "psnr": {:.3f}, "ssim": {:.5f}, "settled_splats_drawn": {}}})",
                q.index, std::min(d.psnr, kIdenticalPsnr), d.ssim, r.splatsDrawn));
        }
    }
    line(series.summaryJson(seconds, settings, context->deviceName(), context->driverName()));
    checkValidation(*context);
    if (file) unwrap(file->commit());
}

} // namespace

void addBenchViewCommand(CLI::App& bench) {
    auto args = std::make_shared<BenchViewArgs>();
    args->engine.width = 640;
    args->engine.height = 480;
    args->engine.targetFps = 24.0; // the paper's real-time rate
    CLI::App* view = bench.add_subcommand(
        "view",
        "The real-time engine offscreen along a camera path: one JSON line per frame, then a summary");
    view->add_option("input", args->input,
                     "input point file: PLY, PCD or text (.xyz .txt .pts .csv; README, Use); omitted: the "
                     "embedded default model");
    addColumnsOption(*view, args->columns);
    view->add_option("--camera-path", args->cameraPath,
                     "orbit (a turn about the model), zoom (towards it and back), or a keyframe file "
                     "(docs/REALTIME.md)")
        ->capture_default_str();
    view->add_option("--frames", args->frames, "frames to draw (default: 240, or the file's)")
        ->check(CLI::Range(std::size_t{1}, std::size_t{10000000}));
    view->add_option("--width", args->engine.width, "image width in pixels")
        ->check(CLI::Range(1u, 16384u))
        ->capture_default_str();
    view->add_option("--height", args->engine.height, "image height in pixels")
        ->check(CLI::Range(1u, 16384u))
        ->capture_default_str();
    view->add_option("--capture", args->capture, "write every frame as DIR/frame-NNNNN.png");
    view->add_option("-o,--output", args->output,
                     "also write every line here at the end, whole (standard output gets them as they come)");
    addForceFlag(*view, args->force);
    view->add_flag("--lockstep", args->lockstep,
                   "each frame refines and uploads until settled before drawing (reproducible frames)");
    view->add_option(
            "--quality-every", args->qualityEvery,
            "for every K-th frame, draw after the run the lockstep settled picture of its camera and "
            "print the frame's PSNR and SSIM against it (the summary: median and 5th percentile)")
        ->check(CLI::Range(std::size_t{1}, std::size_t{1000000}));
    view->add_flag("--measure-splats", args->measureSplats,
                   "measure each splat drawn (median_splat_px, max_splat_px, over_threshold; null "
                   "without): a pass on the CPU that the viewer's frames do not have, so off by default");
    addEngineOptions(*view, args->engine, true, false);
    addKeepOutliersOption(*view, args->keepOutliers);
    addFillHolesOption(*view, args->fillHoles);
    view->callback([args] { runBenchView(*args); });
}

} // namespace pnsplat::tools
