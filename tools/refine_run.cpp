#include "refine_run.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <new>
#include <optional>
#include <string_view>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <glm/geometric.hpp>

#include "commands.h"
#include "pnsplat/refine/hole_detection.h"
#include "pnsplat/refine/input.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/io/point_file.h"
#include "pnsplat/refine/memory_budget.h"
#include "pnsplat/refine/normal_estimation.h"
#include "pnsplat/refine/outliers.h"
#include "pnsplat/refine/text.h"
#include "progress.h"

namespace pnsplat::tools {

namespace {

// "X,Y,Z,R": four finite numbers (a leading '+' allowed), R > 0; a usage error naming the option
// and the text.
Hole parseHole(std::string_view text, glm::dvec3 origin) {
    double values[4];
    std::size_t count = 0;
    for (std::size_t begin = 0; begin <= text.size() && count <= 4;) {
        const std::size_t end = std::min(text.find(',', begin), text.size());
        std::string_view part = text.substr(begin, end - begin);
        if (part.starts_with('+')) part.remove_prefix(1);
        // Near 0 as floats (as before origins); far from it, in double until the origin is taken off.
        std::optional<double> value;
        if (origin != glm::dvec3(0.0))
            value = parseDouble(part);
        else if (const std::optional<float> single = parseFloat(part))
            value = *single;
        if (!value || count == 4)
            count = 5; // not a number, or a fifth one
        else
            values[count++] = *value;
        begin = end + 1;
    }
    if (count != 4)
        throw CommandError(fmt::format("--fill-hole {}: expected X,Y,Z,R, four finite numbers", text),
                           kExitUsage);
    // In the file's coordinates: the points' are stored less their origin.
    const Hole hole{glm::vec3(glm::dvec3(values[0], values[1], values[2]) - origin),
                    static_cast<float>(values[3])};
    if (!std::isfinite(hole.centre.x) || !std::isfinite(hole.centre.y) || !std::isfinite(hole.centre.z))
        throw CommandError(fmt::format("--fill-hole {}: expected X,Y,Z,R, four finite numbers", text),
                           kExitUsage);
    if (!(hole.radius > 0.0f))
        throw CommandError(fmt::format("--fill-hole {}: the radius is not positive", text), kExitUsage);
    return hole;
}

// "about 35.4 million", "2.1e+33": a count for messages.
std::string approximately(double count) {
    if (count >= 1e15) return fmt::format("{:.1e}", count);
    if (count >= 1e9) return fmt::format("{:.1f} billion", count / 1e9);
    if (count >= 1e6) return fmt::format("{:.1f} million", count / 1e6);
    return fmt::format("{:.0f}", count);
}

// "5.6 GB", "120 MB": a size for messages (decimal units).
std::string bytesText(double bytes) {
    if (bytes >= 1e15) return fmt::format("{:.1e} bytes", bytes);
    if (bytes >= 1e9) return fmt::format("{:.1f} GB", bytes / 1e9);
    if (bytes >= 1e6) return fmt::format("{:.0f} MB", bytes / 1e6);
    return fmt::format("{:.0f} kB", bytes / 1e3);
}

// The levels of the job on a Refiner of `points`, counted in `run`, whose points they fill.
void refineLevels(PointSet points, const RefineJob& job, const HoleRims& rims, RefineRun& run) {
    Refiner refiner(std::move(points), job.options);
    ProgressBar bar("refining");
    const auto progress = [&](std::size_t done, std::size_t total) { bar.update(done, total); };
    const auto count = [&](const LevelStats& stats) {
        run.seconds += stats.seconds;
        run.cappedNeighbourhoods += stats.cappedNeighbourhoods;
        ++run.levels;
        if (stats.cappedNeighbourhoods > 0 && run.firstCappedLevel == 0) run.firstCappedLevel = run.levels;
    };
    if (!job.holes.empty()) {
        bar.setLabel("filling holes");
        for (const LevelStats& stats : fillHoles(refiner, rims, progress)) {
            count(stats);
            ++run.holeFillingLevels;
        }
    }
    for (unsigned level = 1;
         level <= job.levels && (job.targetPoints == 0 || refiner.points().size() < job.targetPoints);
         ++level) {
        bar.setLabel(fmt::format("level {}", level));
        const LevelStats stats = refiner.refineLevel(progress);
        count(stats);
        if (stats.inserted == 0) break; // converged: nothing more to insert
    }
    if (job.evenOutFactor > 0.0f) {
        bar.setLabel("evening out");
        for (const LevelStats& stats : evenOut(refiner, job.evenOutFactor, kEvenOutMaxLevels, progress)) {
            count(stats);
            ++run.evenOutLevels;
        }
    }
    bar.finish();
    run.points = std::move(refiner).takePoints();
}

} // namespace

void checkFits(const PointSet& points, const RefineJob& job, const std::string& inputName) {
    RefinementPlan plan;
    plan.inputPoints = points.size();
    plan.levels = job.levels;
    plan.targetPoints = job.targetPoints;
    plan.evenOutFactor = job.evenOutFactor;
    plan.colour = points.hasColour();
    plan.crease = points.hasCrease();
    plan.attributes = points.attributes.size();
    for (const Attribute& a : points.attributes) plan.attributeFileBytes += scalarTypeBytes(a.type);
    plan.threads = job.options.threads;
    const RefinementEstimate estimate = estimateRefinement(plan);
    const std::string would = fmt::format(
        "{}: {} would make about {} points (a {} file) and need about {} of memory", inputName,
        job.targetPoints != 0 ? fmt::format("--target-points {}", job.targetPoints)
                              : fmt::format("{} level(s)", job.levels),
        approximately(estimate.points), bytesText(estimate.fileBytes), bytesText(estimate.residentBytes));
    if (job.maxPoints != 0) {
        if (estimate.points > static_cast<double>(job.maxPoints))
            throw CommandError(fmt::format("{}, more than --max-points {}", would, job.maxPoints));
        return;
    }
    // The limit that allows the fewest points.
    std::optional<MemoryBudget> tightest;
    std::size_t fits = 0;
    for (const MemoryBudget& limit : memoryLimits())
        if (const std::size_t within = pointsWithin(limit, plan); !tightest || within < fits)
            tightest = limit, fits = within;
    if (estimate.points > static_cast<double>(fits))
        throw CommandError(fmt::format(
            "{}{}; {} allows {}, about {} points (refine less, or with fewer threads; "
            "--max-points sets the bound to try anyway)",
            would,
            tightest->addressSpace ? fmt::format(" ({} of address space)", bytesText(estimate.memoryBytes))
                                   : "",
            tightest->source, bytesText(tightest->bytes), approximately(static_cast<double>(fits))));
}

HoleSize parseHoleSize(std::string_view text) {
    if (text.empty()) return {};
    HoleSize size;
    std::string_view number = text;
    if (number.ends_with('x')) {
        number.remove_suffix(1);
        size.relative = true;
    }
    const std::optional<float> value = parseFloat(number);
    if (!value || !(*value > 0.0f))
        throw CommandError(
            fmt::format(
                "--fill-holes {}: expected a positive length, or a multiple of the spacing such as 20x",
                text),
            kExitUsage);
    size.value = *value;
    return size;
}

std::vector<Hole> parseHoles(const std::vector<std::string>& texts, glm::dvec3 origin) {
    std::vector<Hole> holes;
    for (const std::string& text : texts) holes.push_back(parseHole(text, origin));
    return holes;
}

void addFillHoleOptions(CLI::App& cmd, std::vector<std::string>& holes, std::string& upTo) {
    cmd.add_option(
           "--fill-hole", holes,
           "fill the hole inside the ball X,Y,Z,R (no input point within it; repeatable) before the "
           "levels: the radii of the points around it are enlarged to span it, and they and the points "
           "they insert are refined until they match their surroundings (paper figure 9; holes of a "
           "radius up to about 20 spacings)")
        ->type_name("X,Y,Z,R")
        ->expected(1)
        ->allow_extra_args(false)
        ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
    addFillHolesOption(cmd, upTo);
}

void addFillHolesOption(CLI::App& cmd, std::string& upTo) {
    cmd.add_option(
           "--fill-holes", upTo,
           "find the input's holes (empty regions surrounded by points, several spacings wide) and fill "
           "those up to SIZE across as --fill-hole does: a length, or a multiple of the median spacing "
           "such as 30x; open boundaries and wider holes stay open")
        ->type_name("SIZE");
}

void addMaxPointsOption(CLI::App& cmd, std::size_t& maxPoints) {
    cmd.add_option(
           "--max-points", maxPoints,
           "refuse to start a refinement estimated to make more points than this (default: as many as "
           "the memory allows: the least of the physical memory, a control group's limit and ulimit -v "
           "or -d, at about 140 bytes per point, and 4 MiB of memory or 84 MiB of address space per thread)")
        ->check(kPositiveCount);
}

void addKeepNormalsOption(CLI::App& cmd, bool& keep) {
    cmd.add_flag("--keep-normals", keep,
                 "keep the input's normals as given: refuse normals that point against their neighbours' "
                 "(by default they are turned back, with a note)");
}

void addColumnsOption(CLI::App& cmd, std::vector<std::string>& columns) {
    // One argument, split at its commas here: a list option of CLI11 would take the input file's
    // name after it for one more column.
    cmd.add_option_function<std::string>(
           "--columns", [&columns](const std::string& names) { columns = CLI::detail::split(names, ','); },
           "text input (.xyz .txt .pts .csv): the names of its columns, left to right, e.g. "
           "x,y,z,nx,ny,nz,r,g,b (names: x y z nx ny nz r g b rf gf bf radius; other names are "
           "carried through as attributes); default: the file's header line, else by their "
           "number (README, Use)")
        ->type_name("NAME,...");
}

void addKeepOutliersOption(CLI::App& cmd, bool& keep) {
    cmd.add_flag(
        "--keep-outliers", keep,
        fmt::format("keep every input point: by default points isolated at the scale of the sampling "
                    "(the mean distance to their {} nearest points far above the median) are left "
                    "out, with a note",
                    kOutlierNearest));
}

PointSet readInput(const std::string& path, std::vector<std::string>* comments,
                   const std::vector<std::string>& columns, glm::dvec3* origin) {
    PointFileOptions options;
    options.requireNormals = false;
    options.columns = columns;
    PointFileData file = unwrap(readPointFile(path, options));
    PlyData& data = file.data;
    const char* what = file.kind == PointFileKind::Ply   ? "vertex propert"
                       : file.kind == PointFileKind::Pcd ? "field"
                                                         : "column";
    const bool plural = data.unusedProperties.size() != 1;
    std::vector<std::string> unused;
    if (!data.unusedProperties.empty())
        unused.push_back(fmt::format(
            "{}{} {}", what, file.kind == PointFileKind::Ply ? (plural ? "ies" : "y") : (plural ? "s" : ""),
            fmt::join(data.unusedProperties, ", ")));
    for (const PlyData::Element& element : data.unusedElements)
        unused.push_back(fmt::format("element {} ({} item(s))", element.name, element.count));
    if (!unused.empty())
        fmt::print(stderr, "pnsplat: warning: {}: not used, dropped: {}\n", inputName(path),
                   fmt::join(unused, "; "));
    if (data.zeroNormals)
        fmt::print(stderr, "pnsplat: {}: every normal is 0 0 0: taken as none\n", inputName(path));
    if (!columns.empty() && file.kind != PointFileKind::Text)
        fmt::print(stderr, "pnsplat: {}: a {} file names its own {}: --columns not used\n", inputName(path),
                   file.kind == PointFileKind::Ply ? "PLY" : "PCD",
                   file.kind == PointFileKind::Ply ? "properties" : "fields");
    if (file.skippedPoints > 0)
        fmt::print(stderr,
                   "pnsplat: {}: {} point(s) with a NaN position (holes of an organised cloud) left out\n",
                   inputName(path), file.skippedPoints);
    if (data.origin != glm::dvec3(0.0))
        fmt::print(
            stderr,
            "pnsplat: {}: coordinates near {:.17g}, {:.17g}, {:.17g}: held less that origin, in single "
            "precision (point files written add it back, in double)\n",
            inputName(path), data.origin.x, data.origin.y, data.origin.z);
    if (data.roundedBy > 0.0)
        fmt::print(
            stderr,
            "pnsplat: warning: {}: coordinates far from 0 in single precision are rounded by about {:.2g} "
            "times the mean spacing (repeated positions, rough surfaces); write them in double, or move "
            "the points near 0\n",
            inputName(path), data.roundedBy);
    if (origin) *origin = data.origin;
    if (comments) *comments = std::move(data.comments);
    return std::move(data.points);
}

InputCompletion completeInput(PointSet& points, unsigned threads, const std::string& inputName,
                              const InputOptions& options, glm::dvec3 origin) {
    ProgressBar bar("completing " + inputName);
    const Result<InputCompletion> done = pnsplat::completeInput(
        points, threads, options, [&](std::size_t step, std::size_t steps) { bar.update(step, steps); });
    bar.finish();
    if (!done) throw CommandError(inputName + ": " + done.error().message);
    if (const CoincidentRemoval& removed = done->repeats; removed.points > 0)
        fmt::print(
            stderr,
            "pnsplat: {}: {} point(s) repeat the position of an earlier one: each kept once (the first){}\n",
            inputName, removed.points,
            removed.withOtherAttributes > 0 ? fmt::format("; {} of the repeats had another normal, radius, "
                                                          "colour, crease or attribute value, now lost",
                                                          removed.withOtherAttributes)
                                            : "");
    if (done->outliers > 0)
        fmt::print(
            stderr,
            "pnsplat: {}: {} outlier(s) left out: points far from their {} nearest (a mean distance "
            "above {:.4g}, {:.1f} times the median, in the first pass) or off their plane (the first at "
            "{}); --keep-outliers keeps them\n",
            inputName, done->outliers, kOutlierNearest, done->outlierThreshold,
            done->outlierThreshold / done->outlierMedian,
            placeText(origin + glm::dvec3(done->firstOutlier), done->outlierThreshold, ' '));
    if (done->normalComponents > 0)
        fmt::print(stderr,
                   "pnsplat: {} has no normals: estimated from the {} nearest points of each (PCA), oriented "
                   "along a spanning tree and outward where rays along them leave the surface ({} connected "
                   "part(s))\n",
                   inputName, kNormalNearest, done->normalComponents);
    if (done->turnedNormals > 0)
        fmt::print(stderr,
                   "pnsplat: {}: {} normal(s) pointed against their neighbours' and were turned back (the "
                   "first: point {}); --keep-normals refuses them instead\n",
                   inputName, done->turnedNormals, done->firstTurned);
    return *done;
}

namespace {

// The holes findHoles finds in `points` up to job.fillHolesUpTo, appended to job.holes but for those
// also given (their balls meet one of job.holes: filled once, from the ball given), counted in
// `run` and said on standard error.
void addFoundHoles(const PointSet& points, RefineJob& job, RefineRun& run, const std::string& inputName) {
    const HoleSearch found =
        findHoles(points, job.fillHolesUpTo.value, job.fillHolesUpTo.relative, job.options.threads);
    const std::size_t given = job.holes.size();
    const auto meetsGiven = [&](const Hole& ball) {
        return std::any_of(job.holes.begin(), job.holes.begin() + static_cast<std::ptrdiff_t>(given),
                           [&](const Hole& other) {
                               return glm::distance(ball.centre, other.centre) < ball.radius + other.radius;
                           });
    };
    for (const FoundHole& hole : found.holes)
        if (!meetsGiven(hole.ball)) job.holes.push_back(hole.ball);
    run.holesFound = job.holes.size() - given;
    run.holesLeftOpen = found.tooLarge.size();
    if (found.maxSize == 0.0f) {
        fmt::print(stderr, "pnsplat: {}: too few points to look for holes (--fill-holes)\n", inputName);
        return;
    }
    std::string detail;
    for (const FoundHole& hole : found.holes) {
        const glm::dvec3 centre = glm::dvec3(hole.ball.centre) + job.origin; // in the file's coordinates
        detail += fmt::format("{}{:.4g} across at {}", detail.empty() ? ": " : "; ", hole.size,
                              placeText(centre, hole.size, ','));
    }
    const std::size_t alsoGiven = found.holes.size() - run.holesFound;
    fmt::print(stderr, "pnsplat: {}: {} hole(s) up to {:.4g} across found{}{}{}\n", inputName,
               found.holes.size(), found.maxSize, detail,
               alsoGiven == 0 ? "" : fmt::format("; {} of them given by --fill-hole too", alsoGiven),
               found.tooLarge.empty() ? "" : fmt::format("; {} wider left open", found.tooLarge.size()));
}

// The job on completed `points` (completeInput; `run` holds what it did): the holes found and
// given filled, then the levels.
RefineRun fillAndRefine(PointSet points, RefineJob job, RefineRun run, const std::string& inputName) {
    if (auto valid = validateForRefinement(points); !valid)
        throw CommandError(inputName + ": " + valid.error().message);
    if (job.fillHolesUpTo.value > 0.0f) addFoundHoles(points, job, run, inputName);
    run.holes = job.holes.size();
    HoleRims rims;
    if (!job.holes.empty()) {
        auto enlarged = enlargeAroundHoles(points, job.holes);
        if (!enlarged) throw CommandError(inputName + ": " + enlarged.error().message);
        rims = *enlarged;
        run.enlargedRadii = rims.enlarged;
        job.options.maxNeighbours = kHoleFillingMaxNeighbours;
    }

    run.maxNeighbours = job.options.maxNeighbours;
    try {
        refineLevels(std::move(points), job, rims, run);
    } catch (const std::bad_alloc&) { // the refiner's memory is free again here
        throw CommandError(
            fmt::format("{}: out of memory in refinement level {}; refine less, or with fewer threads",
                        inputName, run.levels + 1));
    }
    return run;
}

} // namespace

RefineRun refineWithProgress(PointSet points, RefineJob job, const std::string& inputName) {
    if (points.size() < 3)
        throw CommandError(
            fmt::format("{}: {} point(s); refinement needs at least 3", inputName, points.size()));
    checkFits(points, job, inputName);
    const InputCompletion completed = completeInput(
        points, job.options.threads, inputName,
        {.replaceRadii = job.estimateRadii, .keepNormals = job.keepNormals, .keepOutliers = job.keepOutliers},
        job.origin);
    RefineRun run;
    run.radiiEstimated = completed.radiiEstimated;
    run.inputPoints = points.size();
    run.turnedNormals = completed.turnedNormals;
    run.outliers = completed.outliers;
    return fillAndRefine(std::move(points), std::move(job), std::move(run), inputName);
}

PointSet withHolesFilled(PointSet points, const HoleSize& upTo, const std::string& inputName,
                         glm::dvec3 origin) {
    if (!(upTo.value > 0.0f)) return points;
    RefineJob job;
    job.fillHolesUpTo = upTo;
    job.origin = origin;
    RefineRun run;
    run.inputPoints = points.size();
    addFoundHoles(points, job, run, inputName);
    if (job.holes.empty()) return points; // nothing to fill: the points as they came
    job.fillHolesUpTo = {};               // found already
    return fillAndRefine(std::move(points), std::move(job), std::move(run), inputName).points;
}

} // namespace pnsplat::tools
