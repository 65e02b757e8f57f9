// `pnsplat bench settle`: the settled picture of the real-time engine (`render --adaptive`) against
// the offline refinement, for models and cameras: the measurements of issue 26's first three lines
// in one run (docs/REALTIME.md, "Measuring a settled picture"). One JSON object per model and
// camera on standard output, then a summary line.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <fmt/core.h>
#include <fmt/format.h>
#include <glm/geometric.hpp>

#include "commands.h"
#include "engine_setup.h"
#include "frame_json.h"
#include "pnsplat/engine/image.h"
#include "pnsplat/refine/refiner.h"
#include "pnsplat/refine/text.h"
#include "progress.h"
#include "render_compare.h"
#include "shared_models.h"

namespace pnsplat::tools {

namespace {

// A camera about the model's bounding sphere (centre c, radius R): the eye at
// c + distance · R · normalize(direction), looking at c + lookOffset · R; or, for "framing", the
// camera `render` chooses.
struct SettleView {
    const char* name;
    glm::vec3 direction;
    float distance;
    glm::vec3 lookOffset;
};
// The close-up and grazing cameras of EngineTest.SettledPictureMatchesTheOfflineRefinement.
constexpr SettleView kSettleViews[] = {
    {"framing", {0.0f, 0.0f, 0.0f}, 0.0f, {0.0f, 0.0f, 0.0f}},
    {"close-up", {0.15f, 0.1f, 1.0f}, 1.0f, {0.05f, 0.15f, 0.55f}},
    {"grazing", {0.15f, 1.0f, 0.35f}, 2.4f, {0.0f, -0.15f, 0.0f}},
};

struct SettleArgs {
    std::vector<std::string> inputs; // empty: the first kSettleModelCount of kSparseModels
    std::vector<std::string> views;  // empty: all of kSettleViews
    // The splats in view of a reference picture, drawn without the node tree in one buffer (lavapipe's
    // texel buffers hold 67 million splats): its refinement's time and memory.
    std::size_t maxReferencePoints = 4'000'000;
    // The points of the offline refinement, every level, of the whole model or of a box about the
    // picture past it (about 90 bytes each while refining: 20 million take 1.8 GB).
    std::size_t maxRefinedPoints = 20'000'000;
    std::string pictures; // where to write each case's pictures (empty: nowhere)
    EngineArgs engine;
};

// An offline refinement at `levels` levels, only its splats that can change the picture of the
// camera (splatsOutOfPicture: the picture is the same).
struct OfflineReference {
    PointSet points;
    std::uint32_t levels = 0;
    bool capped = false; // a level shallower than asked: the next would pass a limit of SettleArgs
    std::optional<std::uint32_t> regionFrom; // levels past this one were refined in a box about the picture
};
// The references of issue 26's lines 1 and 2: the offline refinement at the deepest level the
// settled frame draws, and one level deeper. A level triples the points: a reference stops at the
// last level whose next would pass the in-view limit (or, in a box, the refined one), and is then
// capped.
struct OfflineReferences {
    OfflineReference deepest, deeper;
};

// The levels past what the whole model's refinement may hold (SettleArgs::maxRefinedPoints; the
// close-ups draw nine and ten levels deep, and the bunny's tenth level would hold 200 million
// points) go on in a box about the picture: refineRegion refines the points in the box, with
// those around it as context (docs/REALTIME.md, "Measuring a settled picture"). From the next
// level on, the box's points near its faces would miss their neighbours beyond it, so each level's
// box is the last one shrunk by twice a neighbourhood search's reach, 2 · kRetryReach times the
// largest radius, which a level multiplies by at most kCBetaMax (ALGORITHM.md §4.7): the first box
// is that of the splats in the picture widened by every shrink to come, and the last still holds
// it. Within it, the same surface by the same rules as the whole model's refinement, not the same
// bits (a level's order follows its cells).
// Calls f(i) for every i < count not in `outside` (sorted: splatsOutOfPicture).
template <typename F>
void forEachInPicture(std::size_t count, std::span<const std::uint32_t> outside, F&& f) {
    for (std::size_t i = 0, k = 0; i < count; ++i) {
        if (k < outside.size() && outside[k] == i)
            ++k;
        else
            f(i);
    }
}

struct RegionSchedule {
    float firstShrink = 0.0f; // the first level's; each next one kCBetaMax times the last
    Region box;
};
RegionSchedule regionSchedule(const PointSet& points, std::span<const std::uint32_t> outside,
                              float radiusScale, std::uint32_t levels) {
    RegionSchedule schedule;
    const float largest = *std::ranges::max_element(points.radius);
    schedule.firstShrink = 2.0f * kRetryReach * largest;
    // The sum of the shrinks to come, as the loop of offlineReferences makes them.
    float widen = 0.0f, shrink = schedule.firstShrink;
    for (std::uint32_t k = 0; k < levels; ++k, shrink *= kCBetaMax) widen += shrink;
    glm::vec3 lo(std::numeric_limits<float>::infinity()), hi(-std::numeric_limits<float>::infinity());
    forEachInPicture(points.size(), outside, [&](std::size_t i) {
        const float reach = points.radius[i] * radiusScale;
        lo = glm::min(lo, points.position[i] - reach);
        hi = glm::max(hi, points.position[i] + reach);
    });
    schedule.box = Region{lo - widen, hi + widen};
    return schedule;
}

// One level of `points` (P(l) in `box`) in `box`: the points in it owned, those within the reach of
// a refined context point's search as context.
RegionResult refineInBox(const PointSet& points, const Region& box, std::uint32_t level,
                         std::vector<SegmentEnds> segments, const RefineOptions& options) {
    const float reach = 2.0f * kRetryReach * *std::ranges::max_element(points.radius);
    const Region near{box.lo - reach, box.hi + reach};
    RegionLevel run;
    run.region = box;
    run.level = level;
    run.segments = std::move(segments);
    run.threads = options.threads;
    for (std::size_t i = 0; i < points.size(); ++i)
        if (box.contains(points.position[i])) run.points.appendFrom(points, i);
    run.owned = run.points.size();
    for (std::size_t i = 0; i < points.size(); ++i)
        if (!box.contains(points.position[i]) && near.contains(points.position[i]))
            run.points.appendFrom(points, i);
    return refineRegion(std::move(run), options);
}

// `bar` shows the level being made (`what`: the case), of the whole model or in the box.
OfflineReferences offlineReferences(const PointSet& input, std::uint32_t deepest,
                                    const engine::Camera& camera, const SettleArgs& args, float radiusScale,
                                    ProgressBar& bar, const std::string& what) {
    RefineOptions options;
    options.threads = 0;
    Refiner refiner(input, options);
    OfflineReferences out;
    // The splats of the level so far that cannot change the picture, and the reference of the
    // others: copied only for the levels kept, and only those.
    std::vector<std::uint32_t> outside;
    const auto measure = [&](const PointSet& points) {
        outside = engine::splatsOutOfPicture(points.position, points.normal, points.radius, camera,
                                             args.engine.width, args.engine.height, radiusScale);
        return points.size() - outside.size();
    };
    std::optional<std::uint32_t> regionFrom;
    const auto reference = [&](const PointSet& points, std::uint32_t levels, bool capped) {
        OfflineReference r{{}, levels, capped, regionFrom};
        r.points.reserve(points.size() - outside.size());
        forEachInPicture(points.size(), outside, [&](std::size_t i) { r.points.appendFrom(points, i); });
        return r;
    };
    // Returns whether the next level would pass the in-view limit, or the refined one with
    // `refined` points to refine: the references are then set.
    std::size_t inView = measure(refiner.points());
    const auto stopsAt = [&](const PointSet& points, std::uint32_t levels, std::size_t refined) {
        if (levels == deepest) out.deepest = reference(points, levels, false);
        if (3 * inView <= args.maxReferencePoints && 3 * refined <= args.maxRefinedPoints) return false;
        out.deeper = reference(points, levels, true);
        if (levels < deepest) out.deepest = out.deeper; // capped before the deepest level
        return true;
    };
    while (refiner.levels() < deepest + 1 && 3 * refiner.points().size() <= args.maxRefinedPoints) {
        if (stopsAt(refiner.points(), refiner.levels(), 0)) return out;
        bar.setLabel(fmt::format("{}: offline level {} of {}", what, refiner.levels() + 1, deepest + 1));
        refiner.refineLevel([&](std::size_t done, std::size_t total) { bar.update(done, total); });
        inView = measure(refiner.points());
    }
    if (refiner.levels() == deepest + 1) {
        out.deeper = reference(refiner.points(), refiner.levels(), false);
        return out;
    }
    // On in a box about the picture (above).
    std::uint32_t level = refiner.levels();
    regionFrom = level;
    std::vector<SegmentEnds> segments =
        level > 0 ? refiner.segmentEnds() : findSegments(refiner.points(), options);
    PointSet points = std::move(refiner).takePoints();
    RegionSchedule schedule = regionSchedule(points, outside, radiusScale, deepest + 1 - level);
    for (float shrink = schedule.firstShrink; level < deepest + 1; shrink *= kCBetaMax) {
        const auto inBox =
            std::ranges::count_if(points.position, [&](glm::vec3 p) { return schedule.box.contains(p); });
        if (stopsAt(points, level, static_cast<std::size_t>(inBox))) return out;
        bar.setLabel(fmt::format("{}: offline level {} of {} in a box", what, level + 1, deepest + 1));
        bar.update(level, deepest + 1);
        RegionResult next = refineInBox(points, schedule.box, level, std::move(segments), options);
        points = std::move(next.points);
        segments = std::move(next.segments);
        ++level;
        schedule.box = Region{schedule.box.lo + shrink, schedule.box.hi - shrink};
        inView = measure(points);
    }
    out.deeper = reference(points, level, false);
    return out;
}

engine::Camera settleCamera(const SettleView& view, const PointSet& points, const engine::Sphere& bounds,
                            float aspect) {
    const float fov = 40.0f * std::numbers::pi_v<float> / 180.0f;
    if (view.distance == 0.0f) {
        std::optional<engine::Viewpoint> chosen;
        CameraArgs framing;
        return chooseCamera(framing, points, aspect, chosen);
    }
    engine::Camera camera;
    camera.target = bounds.centre + view.lookOffset * bounds.radius;
    camera.eye = bounds.centre + glm::normalize(view.direction) * view.distance * bounds.radius;
    camera.fovY = fov;
    return camera;
}

void runBenchSettle(const SettleArgs& args) {
    std::vector<std::string> files = args.inputs;
    if (files.empty()) {
        files = sharedModelFiles(std::span(kSparseModels).first(kSettleModelCount), "bench settle");
        if (files.empty()) throw CommandError("bench settle: none of the default models found");
    }
    // Every model loaded first: a bad file fails before any work, in one line.
    struct Model {
        std::string name, loaded;
        PointSet points;
    };
    std::vector<Model> models;
    for (const std::string& file : files) {
        Model& model = models.emplace_back();
        model.points = loadForRendering(file, {}, model.loaded);
        model.name = std::filesystem::path(file).stem().string();
    }
    std::vector<const SettleView*> views;
    for (const SettleView& view : kSettleViews)
        if (args.views.empty() || std::ranges::find(args.views, view.name) != args.views.end())
            views.push_back(&view);
    if (!args.pictures.empty()) {
        std::error_code error;
        std::filesystem::create_directories(args.pictures, error);
        if (error)
            throw CommandError(args.pictures + ": cannot create the pictures folder: " + error.message());
    }
    auto context = createContext(args.engine);
    const engine::EngineSettings adaptive = engineSettings(args.engine, *context, true);
    const engine::EngineSettings drawOnly = engineSettings(args.engine, *context, false);
    const glm::u8vec3 background = engine::backgroundPixel(adaptive.render.background);
    const float aspect = float(args.engine.width) / float(args.engine.height);
    fmt::print(stderr, "bench settle: {} model(s), {} camera(s), {}x{} on {}, threshold {} px\n",
               models.size(), views.size(), args.engine.width, args.engine.height, context->deviceName(),
               args.engine.threshold);
    double lowestPsnr = kIdenticalPsnr, lowestDeeperPsnr = kIdenticalPsnr, lowestDeeperSsim = 1.0;
    double mostDrawn = 0.0, mostMade = 0.0;
    std::size_t holePixels = 0, cases = 0;
    for (const Model& model : models) {
        const PointSet& input = model.points;
        const std::string& name = model.name;
        const std::string& loaded = model.loaded;
        for (const SettleView* view : views) {
            const std::string what = name + " " + view->name;
            ProgressBar bar(what + ": settling");
            bar.update(0, 1);
            auto created = engine::Engine::create(*context, input, adaptive);
            if (!created) throw CommandError(loaded + ": " + created.error().message);
            engine::Engine& engine = **created;
            const engine::Camera camera = settleCamera(*view, input, engine.bounds(), aspect);
            engine::FrameOptions options;
            options.lockstep = options.readBack = options.measureSplats = true;
            const engine::FrameReport settled = unwrap(engine.frame(camera, options));
            const engine::RgbaImage picture = unwrap(engine.image(settled.frame));
            const std::uint32_t deepest = engine.deepestDrawnLevel();
            const std::size_t made = engine.tree().pointCount();
            const double refineMs = engine.refinementMs(settled);
            engine.finish();

            const OfflineReferences references =
                offlineReferences(input, deepest, camera, args, drawOnly.render.radiusScale, bar, what);
            bar.setLabel(what + ": drawing the offline references");
            bar.update(0, 1);
            const auto drawReference = [&](const OfflineReference& reference) {
                auto offline = engine::Engine::create(*context, reference.points, drawOnly);
                if (!offline) throw CommandError(loaded + ": offline reference: " + offline.error().message);
                engine::FrameOptions once;
                once.readBack = true;
                const engine::FrameReport drawn = unwrap((*offline)->frame(camera, once));
                engine::RgbaImage image = unwrap((*offline)->image(drawn.frame));
                (*offline)->finish();
                return image;
            };
            const engine::RgbaImage offlinePicture = drawReference(references.deepest);
            const engine::RgbaImage deeperPicture = drawReference(references.deeper);
            const engine::ImageDifference difference = unwrap(engine::compareImages(picture, offlinePicture));
            const engine::ImageDifference deeper = unwrap(engine::compareImages(picture, deeperPicture));
            const auto holes =
                unwrap(engine::enclosedBackgroundAbsentIn(picture, offlinePicture, background));
            std::size_t holeArea = 0;
            for (const engine::ImageRegion& hole : holes) holeArea += hole.pixels;
            const auto caption = [](const OfflineReference& reference) {
                return fmt::format("offline, {} levels{}{}", reference.levels,
                                   reference.regionFrom
                                       ? fmt::format(" (in a box from level {})", *reference.regionFrom)
                                       : "",
                                   reference.capped ? " (capped)" : "");
            };
            if (!args.pictures.empty()) {
                const engine::RgbaImage panels[4] = {picture, offlinePicture, difference.heatmap,
                                                     deeperPicture};
                const std::string captions[4] = {
                    fmt::format("settled adaptive, deepest level {}", deepest), caption(references.deepest),
                    fmt::format("difference: {:.2f} dB", std::min(difference.psnr, kIdenticalPsnr)),
                    caption(references.deeper)};
                unwrap(engine::writePng(fmt::format("{}/{}-{}.png", args.pictures, name, view->name),
                                        sideBySide(panels, captions)));
            }
            const auto covered = static_cast<double>(engine::coveredPixels(picture.pixels, background));
            const double drawnPerPixel = covered > 0.0 ? double(settled.splatsDrawn) / covered : 0.0;
            const double madePerPixel = covered > 0.0 ? double(made) / covered : 0.0;
            bar.finish(); // the record below on a line of its own
            const OfflineReference& first = references.deepest;
            const OfflineReference& second = references.deeper;
            fmt::print(
                R"({{"model": {}, "camera": {}, "width": {}, "height": {}, "settled": {}, "psnr": {:.3f}, "ssim": {:.5f}, )"
                R"("psnr_deeper": {:.3f}, "ssim_deeper": {:.5f}, )"
                R"("holes": {}, "hole_pixels": {}, "covered_px": {}, "splats_drawn": {}, "drawn_per_covered_px": {:.2f}, )"
                R"("points_made": {}, "made_per_covered_px": {:.2f}, "median_splat_px": {:.2f}, "deepest_level": {}, )"
                R"("refine_ms": {:.0f}, "reference_levels": {}, "reference_points_in_view": {}, "reference_capped": {}, )"
                R"("deeper_levels": {}, "deeper_points_in_view": {}, "deeper_capped": {}, "box_from_level": {}, )"
                R"("smooth_edges": {}, "fill_pinholes": {}}})"
                "\n",
                jsonString(name), jsonString(view->name), args.engine.width, args.engine.height,
                settled.settled ? "true" : "false", std::min(difference.psnr, kIdenticalPsnr),
                difference.ssim, std::min(deeper.psnr, kIdenticalPsnr), deeper.ssim, holes.size(), holeArea,
                covered, settled.splatsDrawn, drawnPerPixel, made, madePerPixel, settled.medianSplatPx,
                deepest, refineMs, first.levels, first.points.size(), first.capped ? "true" : "false",
                second.levels, second.points.size(), second.capped ? "true" : "false",
                second.regionFrom ? std::to_string(*second.regionFrom) : std::string("null"),
                args.engine.hardEdges ? "false" : "true", args.engine.keepPinholes ? "false" : "true");
            std::fflush(stdout);
            lowestPsnr = std::min(lowestPsnr, std::min(difference.psnr, kIdenticalPsnr));
            lowestDeeperPsnr = std::min(lowestDeeperPsnr, std::min(deeper.psnr, kIdenticalPsnr));
            lowestDeeperSsim = std::min(lowestDeeperSsim, deeper.ssim);
            mostDrawn = std::max(mostDrawn, drawnPerPixel);
            mostMade = std::max(mostMade, madePerPixel);
            holePixels += holeArea;
            ++cases;
        }
    }
    fmt::print(R"({{"summary": true, "cases": {}, "psnr_lowest": {:.3f}, "psnr_deeper_lowest": {:.3f}, )"
               R"("ssim_deeper_lowest": {:.5f}, "hole_pixels": {}, "drawn_per_covered_px_highest": {:.2f}, )"
               R"("made_per_covered_px_highest": {:.2f}}})"
               "\n",
               cases, lowestPsnr, lowestDeeperPsnr, lowestDeeperSsim, holePixels, mostDrawn, mostMade);
    checkValidation(*context);
}

} // namespace

void addBenchSettleCommand(CLI::App& bench) {
    auto args = std::make_shared<SettleArgs>();
    args->engine.width = 640;
    args->engine.height = 480;
    CLI::App* settle = bench.add_subcommand(
        "settle", "The real-time engine's settled picture against the offline refinement, for models and "
                  "cameras: PSNR, SSIM, holes, splats drawn and points made per covered pixel (JSON lines)");
    settle->add_option(
        "input", args->inputs,
        "input PLYs (default: the sparse bunny, igea, lion, nefertiti, banana and rockerarm of "
        "../shared/data, from the project root)");
    settle
        ->add_option("--cameras", args->views, "framing (render's camera), close-up, grazing (default: all)")
        ->delimiter(',')
        ->check(CLI::IsMember({"framing", "close-up", "grazing"}));
    settle
        ->add_option("--max-reference-points", args->maxReferencePoints,
                     "draw an offline reference of at most this many splats in view (a shallower one is "
                     "reported as capped)")
        ->capture_default_str()
        ->check(kPositiveCount);
    settle
        ->add_option("--max-refined-points", args->maxRefinedPoints,
                     "refine the whole model for the offline references up to this many points (memory: "
                     "about 90 bytes each), then the levels left in a box about the picture up to as many")
        ->capture_default_str()
        ->check(kPositiveCount);
    settle->add_option("--pictures", args->pictures,
                       "write each case as DIR/MODEL-CAMERA.png: the settled picture, the offline one and "
                       "their difference side by side");
    settle->add_option("--width", args->engine.width, "image width in pixels")->capture_default_str();
    settle->add_option("--height", args->engine.height, "image height in pixels")->capture_default_str();
    addEngineOptions(*settle, args->engine, true, false);
    settle->callback([args] { runBenchSettle(*args); });
}

} // namespace pnsplat::tools
