// `pnsplat refine`: refine a point set of a file (PLY, PCD, text) or the embedded default model offline.
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "commands.h"
#include "pnsplat/refine/angles.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/io/point_file.h"
#include "pnsplat/refine/refiner.h"
#include "pnsplat/refine/shapes/shapes.h"
#include "pnsplat/refine/text.h"
#include "refine_run.h"

namespace pnsplat::tools {

namespace {

struct RefineArgs {
    std::string input;
    std::string output;
    unsigned levels = 0;
    std::size_t targetPoints = 0;
    std::string neighbourhood = "accurate";
    unsigned threads = 0;
    bool fast = false;
    bool euclideanGeodesic = false;
    bool plainAngle = false;
    bool centroidCandidates = false;
    bool noSmoothing = false;
    bool ascii = false;
    bool force = false;
    bool estimateRadii = false;
    bool json = false;
    bool keepNormals = false;
    bool keepOutliers = false;
    double thetaFDegrees = 30.0;
    double thetaBDegrees = 165.0;
    float evenOut = 0.0f;
    std::vector<std::string> holes; // "X,Y,Z,R", one per --fill-hole
    std::string fillHoles;          // --fill-holes SIZE
    std::size_t maxPoints = 0;
    std::vector<std::string> columns; // the input's, when it is text
};

constexpr unsigned kDefaultLevels = 4;

void runRefine(const RefineArgs& args) {
    using Clock = std::chrono::steady_clock;
    // Standard input without -o goes to standard output, as filters do.
    std::string output = args.output;
    if (output.empty())
        output = args.input == "-"
                     ? "-"
                     : (args.input.empty() ? std::string("default")
                                           : std::filesystem::path(args.input).stem().string()) +
                           "-refined.ply";
    refuseToOverwriteInput(output, {args.input}, args.force);
    if (args.ascii && pointFileKindOf(output) == PointFileKind::Text)
        fmt::print(stderr, "pnsplat: {}: a text point file is ascii already: --ascii not used\n", output);
    // Standard output carries the file: the summary goes to standard error.
    std::FILE* summary = isStandardOutput(output) ? stderr : stdout;

    PointSet points;
    std::vector<std::string> comments; // the input's header comments, carried on to the output
    glm::dvec3 origin(0.0);            // the input's (PlyData::origin), added back to the output
    std::string inputName = pnsplat::inputName(args.input);
    if (args.input.empty()) {
        points = makeDefaultModel();
        inputName = "the default model";
    } else {
        points = readInput(args.input, &comments, args.columns, &origin);
    }

    RefineJob job;
    RefineOptions& options = job.options;
    options = args.fast ? RefineOptions::fast() : RefineOptions{};
    if (!args.fast)
        options.neighbourhood =
            args.neighbourhood == "fuzzy" ? NeighbourhoodKind::Fuzzy : NeighbourhoodKind::Accurate;
    options.euclideanGeodesic |= args.euclideanGeodesic;
    options.plainAngle |= args.plainAngle;
    options.centroidCandidates |= args.centroidCandidates;
    options.smoothing = !args.noSmoothing;
    options.thetaF = static_cast<float>(radians(args.thetaFDegrees));
    options.thetaB = static_cast<float>(radians(args.thetaBDegrees));
    options.threads = args.threads;

    const auto start = Clock::now();
    const std::size_t inputCount = points.size();
    if (args.targetPoints != 0 && args.targetPoints <= inputCount)
        throw CommandError(
            fmt::format("{} has {} points: --target-points {} asks for no more, so nothing would be "
                        "refined (give a larger target, or --levels)",
                        inputName, inputCount, args.targetPoints),
            kExitUsage);
    job.levels = args.levels != 0 ? args.levels : (args.targetPoints != 0 ? 64u : kDefaultLevels);
    job.targetPoints = args.targetPoints;
    job.evenOutFactor = args.evenOut;
    job.estimateRadii = args.estimateRadii;
    job.keepNormals = args.keepNormals;
    job.keepOutliers = args.keepOutliers;
    job.holes = parseHoles(args.holes, origin);
    job.origin = origin;
    job.fillHolesUpTo = parseHoleSize(args.fillHoles);
    job.maxPoints = args.maxPoints;
    const RefineRun run = refineWithProgress(std::move(points), job, inputName);
    const double refineSeconds = run.seconds;
    const unsigned done = run.levels;
    const std::size_t outputCount = run.points.size();

    unwrap(writePointFile(output, run.points, args.ascii, comments, origin));
    const double total = std::chrono::duration<double>(Clock::now() - start).count();
    const double rate =
        refineSeconds > 0 ? static_cast<double>(outputCount - run.inputPoints) / refineSeconds : 0.0;
    if (args.json) {
        fmt::print(
            summary,
            R"({{"input": {}, "output": {}, "points_in": {}, "distinct_in": {}, "points_out": {}, "levels": {}, )"
            R"("evening_out_levels": {}, "hole_filling_levels": {}, "holes": {}, "holes_found": {}, "holes_left_open": {}, "rim_points": {}, )"
            R"("refine_seconds": {:.4f}, "seconds": {:.4f}, "points_per_second": {:.0f}, "capped_neighbourhoods": {}, "turned_normals": {}, )"
            R"("outliers": {}}})"
            "\n",
            args.input.empty() ? "null" : jsonString(args.input), jsonString(outputName(output)), inputCount,
            run.inputPoints + run.outliers, outputCount, done, run.evenOutLevels, run.holeFillingLevels,
            run.holes, run.holesFound, run.holesLeftOpen, run.enlargedRadii, refineSeconds, total, rate,
            run.cappedNeighbourhoods, run.turnedNormals, run.outliers);
    } else {
        std::string levelDetail =
            run.evenOutLevels > 0 ? fmt::format(" ({} evening out)", run.evenOutLevels) : "";
        if (run.holes > 0)
            levelDetail += fmt::format(", {} hole(s) filled from {} rim points in {} of them", run.holes,
                                       run.enlargedRadii, run.holeFillingLevels);
        std::vector<std::string> inputDetail;
        if (run.inputPoints + run.outliers != inputCount)
            inputDetail.push_back(fmt::format("{} distinct", run.inputPoints + run.outliers));
        if (run.outliers > 0) inputDetail.push_back(fmt::format("{} outlier(s) left out", run.outliers));
        if (run.turnedNormals > 0)
            inputDetail.push_back(fmt::format("{} flipped normal(s) turned back", run.turnedNormals));
        const std::string distinct =
            inputDetail.empty() ? std::string() : fmt::format(" ({})", fmt::join(inputDetail, ", "));
        fmt::print(
            summary,
            "{}: {} points in{}, {} out, {} level(s){}, {:.3f} s refining ({:.0f} points/s generated), "
            "{:.3f} s in all -> {}\n",
            inputName, inputCount, distinct, outputCount, done, levelDetail, refineSeconds, rate, total,
            outputName(output));
    }
    if (run.cappedNeighbourhoods > 0) {
        // Estimating the radii again changes nothing when they were estimated already. Where the
        // first level cut none, the input's radii are not the cause: a few points of a later level
        // grew to reach a ring neighbour across a thin part or a gap (ALGORITHM.md §4.6; seen on
        // 2,500 random points of the rockerarm, at levels 4 and 5).
        const std::string cause =
            run.holes > 0 ? "a hole looks too wide for its sampling, and may stay open"
            : run.firstCappedLevel > 1
                ? fmt::format("from level {} on (none before): a few points grew radii that reach across a "
                              "thin part or a gap; the rest of the output is refined as usual",
                              run.firstCappedLevel)
            : run.radiiEstimated
                ? "the sampling is very uneven: the estimated radii of some sparse points "
                  "reach many dense ones"
                : "the radii look too large for the sampling (--estimate-radii replaces them)";
        fmt::print(
            stderr,
            "pnsplat: warning: {} neighbourhood(s) held more than {} points within the radius and used "
            "the {} nearest; {}\n",
            run.cappedNeighbourhoods, run.maxNeighbours, run.maxNeighbours, cause);
    }
}

} // namespace

void addRefineCommand(CLI::App& app) {
    const auto [cmd, args] = addSubcommand(
        app, "refine", "Refine an oriented point set (interpolatory sqrt(3)-like refinement)", runRefine);
    cmd->add_option(
        "input", args->input,
        "input point file: PLY (x y z [nx ny nz] [radius] [red green blue] [nx2 ny2 nz2 "
        "[crease]]: crease points), PCD, or text (.xyz .txt .pts .csv: x y z [nx ny nz] [r g b], "
        "README, Use); other scalar properties are carried through (new points: the mean of "
        "their triangle's corners); normals and radii estimated when absent; - for standard input; "
        "omitted: the embedded default model");
    addColumnsOption(*cmd, args->columns);
    cmd->add_option("-o,--output", args->output,
                    "output file, - for standard output (default: <input>-refined.ply; standard output for "
                    "input -): PLY, or PCD for NAME.pcd, or text with a header line for NAME.xyz .txt .pts "
                    ".csv; links are followed, devices and pipes written through");
    auto* levels = cmd->add_option("-l,--levels", args->levels,
                                   fmt::format("refinement levels (default {})", kDefaultLevels))
                       ->check(CLI::Range(1u, 64u));
    cmd->add_option("-n,--target-points", args->targetPoints,
                    "refine level by level until at least this many points (more than the input has)")
        ->check(kPositiveCount)
        ->excludes(levels);
    cmd->add_option("--neighbourhood", args->neighbourhood,
                    "one-ring: accurate (Ng, geodesic projection) or fuzzy (Nf)")
        ->check(CLI::IsMember({"fuzzy", "accurate"}))
        ->capture_default_str();
    cmd->add_option("-t,--threads", args->threads,
                    "worker threads (0 = all; output is identical for any count)")
        ->capture_default_str();
    cmd->add_flag("--fast", args->fast, "all four faster variants of the paper (section 7) at once");
    cmd->add_flag("--euclidean-geodesic", args->euclideanGeodesic,
                  "variant 1: Euclidean distance for the geodesic distance");
    cmd->add_flag("--plain-angle", args->plainAngle, "variant 2: plain angle for the curved angle");
    cmd->add_flag("--centroid-candidates", args->centroidCandidates,
                  "variant 4: smooth only the candidates inserted");
    cmd->add_flag("--no-smoothing", args->noSmoothing,
                  "baseline: insert plain centroids (no PN displacement)");
    cmd->add_option("--theta-f", args->thetaFDegrees, "fuzzy-plane tolerance in degrees")
        ->check(finiteRange(1.0, 89.0))
        ->capture_default_str();
    cmd->add_option("--theta-b", args->thetaBDegrees, "boundary gap threshold in degrees, (120, 180]")
        ->check(finiteRange(120.001, 180.0))
        ->capture_default_str();
    cmd->add_option(
           "--even-out", args->evenOut,
           fmt::format(
               "after the levels, refine the points whose radius is above this multiple of the median until "
               "none "
               "is (at most {} more levels, a few percent more points; 0 = off, {} suits irregular inputs): "
               "fills their sparse patches. Not for inputs with undetected openings, which it fills further",
               kEvenOutMaxLevels, kEvenOutFactor))
        ->check(CLI::Validator(
            [](const std::string& value) {
                double f = -1.0;
                const auto [end, error] = std::from_chars(value.data(), value.data() + value.size(), f);
                const bool valid = error == std::errc() && end == value.data() + value.size() &&
                                   (f == 0.0 || (f >= 1.0 && f <= 100.0));
                return valid ? std::string() : "must be 0 (off) or a number in [1, 100]";
            },
            "0 or [1, 100]"))
        ->capture_default_str();
    addFillHoleOptions(*cmd, args->holes, args->fillHoles);
    addMaxPointsOption(*cmd, args->maxPoints);
    cmd->add_flag("--estimate-radii", args->estimateRadii, "estimate radii even when the input has them");
    addKeepNormalsOption(*cmd, args->keepNormals);
    addKeepOutliersOption(*cmd, args->keepOutliers);
    cmd->add_flag("--ascii", args->ascii, "write an ascii PLY or PCD (default binary little-endian)");
    cmd->add_flag("--json", args->json,
                  "print the summary as one JSON line on standard output (fields: see README, Use)");
    addForceFlag(*cmd, args->force);
}

} // namespace pnsplat::tools
