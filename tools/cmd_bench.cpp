// `pnsplat bench`: performance harness printing JSON (warm-up, then timed runs; medians).
#include <algorithm>
#include <cassert>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <sys/resource.h>
#ifdef __linux__
#include <sched.h>
#endif

#include <fmt/core.h>
#include <fmt/format.h>

#include "bench_pcl.h"
#include "commands.h"
#include "frame_json.h"
#include "pnsplat/engine/context.h"
#include "pnsplat/engine/engine.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/radius_estimation.h"
#include "pnsplat/refine/refiner.h"
#include "pnsplat/refine/shapes/shapes.h"
#include "pnsplat/refine/text.h"
#include "progress.h"
#include "refine_run.h"
#include "shared_models.h"

namespace pnsplat::tools {

namespace {

struct BenchArgs {
    std::size_t spherePoints = 600;
    std::size_t targetPoints = 0; // 0: kSweepTargetPoints for the sphere sweep, none with inputs
    unsigned repeat = 5;
    std::string output;
    // Inputs (--input, --models): a report per input and level instead of the sweep of variants.
    std::vector<std::string> inputs;
    std::string models;            // "default": the sphere and kSparseModels
    unsigned levels = 0;           // with inputs; 0: kDefaultBenchLevels
    std::vector<unsigned> threads; // with inputs; empty: 1 and 2
    std::size_t maxPoints = 0;     // with inputs: RefineJob::maxPoints
    std::string pclMlsOutput;      // with inputs and PCL: a folder for PCL's output, NAME-pcl-mls.ply
    bool force = false;            // write the JSON over an input (refuseToOverwriteInput)
};

inline constexpr std::size_t kSweepTargetPoints = 150000;
inline constexpr unsigned kDefaultBenchLevels = 4;
// With --target-points and no --levels: as many levels as --levels allows (refine's target runs 64).
inline constexpr unsigned kTargetBenchLevels = 16;
// `--models default`: the sparse real models of ../shared/data, relative to the working directory
// (the project's root), after the sphere.

struct RunResult {
    std::size_t generated = 0;
    double seconds = 0;
    unsigned levels = 0;
    PhaseTimes phases;
    long pageFaults = 0; // minor page faults of the process during the levels
};

long minorPageFaults() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return usage.ru_minflt;
}

RunResult refineOnce(const PointSet& input, const RefineOptions& options, std::size_t target) {
    Refiner refiner(input, options);
    RunResult result;
    const long faultsBefore = minorPageFaults();
    while (refiner.points().size() < target) {
        const LevelStats stats = refiner.refineLevel();
        result.seconds += stats.seconds;
        result.phases.neighbourhood += stats.phases.neighbourhood;
        result.phases.filtering += stats.phases.filtering;
        result.phases.selection += stats.phases.selection;
        result.phases.interpolation += stats.phases.interpolation;
        ++result.levels;
        if (stats.inserted == 0) break;
    }
    result.pageFaults = minorPageFaults() - faultsBefore;
    result.generated = refiner.points().size() - input.size();
    return result;
}

void writeJson(const std::string& output, const std::string& json) {
    if (output.empty()) {
        fmt::print("{}", json);
        return;
    }
    unwrap(writeFile(output, json));
}

double rate(const RunResult& r) {
    return static_cast<double>(r.generated) / r.seconds;
}

// One warm-up run, then args.repeat timed ones.
std::vector<RunResult> timedRuns(const PointSet& input, const RefineOptions& options, const BenchArgs& args) {
    refineOnce(input, options, args.targetPoints);
    std::vector<RunResult> runs;
    for (unsigned k = 0; k < args.repeat; ++k) runs.push_back(refineOnce(input, options, args.targetPoints));
    return runs;
}

// One configuration's JSON record: generated points per second over the timed runs, page faults,
// and on one thread the time split per phase.
std::string benchConfig(const std::string& name, const PointSet& input, RefineOptions options,
                        unsigned threads, const BenchArgs& args) {
    options.threads = threads;
    std::vector<double> rates, faults;
    const std::vector<RunResult> runs = timedRuns(input, options, args);
    for (const RunResult& r : runs) {
        rates.push_back(rate(r));
        faults.push_back(static_cast<double>(r.pageFaults));
    }
    const RunResult& last = runs.back();
    // Page faults are reported because they cost several microseconds each on virtual machines
    // (first touches of the arrays that grow with every level), a sizeable share of a run there.
    std::string json = fmt::format(
        R"({{"name": "{}", "threads": {}, "levels": {}, "points_out": {}, "generated": {}, )"
        R"("points_per_second_median": {:.0f}, "points_per_second_min": {:.0f}, "points_per_second_max": {:.0f}, )"
        R"("page_faults_median": {:.0f})",
        name, threads, last.levels, last.generated + input.size(), last.generated, median(rates),
        *std::min_element(rates.begin(), rates.end()), *std::max_element(rates.begin(), rates.end()),
        median(faults));
    if (threads == 1) {
        // The split per phase comes from a separate profiled run (timers cost a little).
        options.profile = true;
        const RunResult profiled = refineOnce(input, options, args.targetPoints);
        const PhaseTimes& p = profiled.phases;
        const double sum = p.neighbourhood + p.filtering + p.selection + p.interpolation;
        json += fmt::format(
            R"(, "phase_share": {{"neighbourhood": {:.3f}, "filtering": {:.3f}, "selection": {:.3f}, "interpolation": {:.3f}}})",
            p.neighbourhood / sum, p.filtering / sum, p.selection / sum, p.interpolation / sum);
    }
    fmt::print(stderr, "  {:<28} {} thread(s): {:>10.0f} points/s\n", name, threads, median(rates));
    return json + "}";
}

// Two threads over one thread from interleaved runs (1, 2, 1, 2, ...; medians): both see the same
// allocator state (a process that has run longer keeps more freed memory and faults less).
double twoThreadSpeedup(const PointSet& input, RefineOptions options, const BenchArgs& args) {
    std::vector<double> rates[2];
    for (unsigned k = 0; k <= args.repeat; ++k) {
        for (unsigned threads = 1; threads <= 2; ++threads) {
            options.threads = threads;
            const RunResult r = refineOnce(input, options, args.targetPoints);
            if (k > 0) rates[threads - 1].push_back(rate(r)); // k = 0: warm-up
        }
    }
    return median(rates[1]) / median(rates[0]);
}

// The full method on one thread pinned to each processor in turn (medians), as JSON
// {"0": rate, "1": rate, ...}; empty where threads cannot be pinned. Virtual machines' processors
// can differ in speed (the host runs other work): a one-thread figure then depends on where the
// run lands, and two threads gain at most (r0 + r1) / max(r0, r1) over the faster one.
std::string ratesByProcessor(const PointSet& input, RefineOptions options, const BenchArgs& args,
                             double& idealSpeedup) {
    idealSpeedup = 0.0;
#ifdef __linux__
    cpu_set_t original;
    if (sched_getaffinity(0, sizeof(original), &original) != 0) return "";
    std::vector<std::string> entries;
    std::vector<double> medians;
    options.threads = 1;
    for (int cpu = 0; cpu < CPU_SETSIZE && medians.size() < 8; ++cpu) {
        if (!CPU_ISSET(cpu, &original)) continue;
        cpu_set_t one;
        CPU_ZERO(&one);
        CPU_SET(cpu, &one);
        if (sched_setaffinity(0, sizeof(one), &one) != 0) continue;
        std::vector<double> rates;
        for (const RunResult& r : timedRuns(input, options, args)) rates.push_back(rate(r));
        medians.push_back(median(rates));
        entries.push_back(fmt::format(R"("{}": {:.0f})", cpu, medians.back()));
    }
    sched_setaffinity(0, sizeof(original), &original);
    if (medians.size() >= 2) {
        std::sort(medians.begin(), medians.end(), std::greater<>());
        idealSpeedup = (medians[0] + medians[1]) / medians[0];
    }
    return fmt::format("{}", fmt::join(entries, ", "));
#else
    (void)input, (void)options, (void)args;
    return "";
#endif
}

void runBenchInputs(const BenchArgs& args);

void runBenchRefine(const BenchArgs& given) {
    refuseToOverwriteInput(given.output, given.inputs, given.force);
    if (!given.inputs.empty() || !given.models.empty()) return runBenchInputs(given);
    if (given.levels != 0 || !given.threads.empty() || given.maxPoints != 0 || !given.pclMlsOutput.empty())
        throw CommandError("bench refine: --levels, --threads, --max-points and --pcl-mls-output apply to "
                           "--input and --models",
                           kExitUsage);
    BenchArgs args = given;
    if (args.targetPoints == 0) args.targetPoints = kSweepTargetPoints;
    PointSet sphere = sampleSphereUniform(args.spherePoints, 1.0f);
    estimateRadii(sphere, 1);
    struct Config {
        std::string name;
        RefineOptions options;
    };
    std::vector<Config> configs;
    configs.push_back({"full", RefineOptions{}});
    configs.push_back({"fast (all variants)", RefineOptions::fast()});
    RefineOptions v1;
    v1.euclideanGeodesic = true;
    configs.push_back({"variant 1 euclidean geodesic", v1});
    RefineOptions v2;
    v2.plainAngle = true;
    configs.push_back({"variant 2 plain angle", v2});
    RefineOptions v3;
    v3.neighbourhood = NeighbourhoodKind::Fuzzy;
    configs.push_back({"variant 3 fuzzy neighbourhood", v3});
    RefineOptions v4;
    v4.centroidCandidates = true;
    configs.push_back({"variant 4 centroid candidates", v4});

    fmt::print(stderr, "bench refine: sphere of {} uniform points to >= {} points, {} timed runs each\n",
               args.spherePoints, args.targetPoints, args.repeat);
    std::vector<std::string> runs;
    for (const Config& c : configs) runs.push_back(benchConfig(c.name, sphere, c.options, 1, args));
    runs.push_back(benchConfig("full", sphere, configs[0].options, 2, args));
    runs.push_back(benchConfig("fast (all variants)", sphere, configs[1].options, 2, args));
    const double fullSpeedup = twoThreadSpeedup(sphere, configs[0].options, args);
    const double fastSpeedup = twoThreadSpeedup(sphere, configs[1].options, args);
    double idealSpeedup = 0.0;
    const std::string byProcessor = ratesByProcessor(sphere, configs[0].options, args, idealSpeedup);
    fmt::print(stderr, "  2 threads / 1 thread: full {:.2f}, fast {:.2f}\n", fullSpeedup, fastSpeedup);
    if (idealSpeedup > 0.0)
        fmt::print(
            stderr,
            "  full, 1 thread pinned to each processor: {} points/s; two threads can gain at most {:.2f}\n",
            byProcessor, idealSpeedup);
    const std::string json = fmt::format(
        R"({{"benchmark": "refine", "case": "sphere {} uniform points to >= {} points", "cpu": "{}", "hardware_threads": {}, "repeat": {}, )"
        R"("two_thread_speedup": {{"full": {:.3f}, "fast": {:.3f}}}, "full_one_thread_by_processor": {{{}}}, )"
        R"("two_thread_ideal_speedup": {:.3f}, "runs": [
  {}
]}})"
        "\n",
        args.spherePoints, args.targetPoints, cpuName(), std::thread::hardware_concurrency(), args.repeat,
        fullSpeedup, fastSpeedup, byProcessor, idealSpeedup, fmt::join(runs, ",\n  "));
    writeJson(args.output, json);
}

// ---------------------------------------------------------------------------------------------
// Per input and level (--input, --models): the full method on each input, level by level, at each
// thread count.

struct BenchInput {
    std::string name;       // the file's stem, or "sphere-N-uniform"
    std::string file;       // as given; empty for the sphere
    PointSet points;        // completed (radii, normals) and valid for refinement
    glm::dvec3 origin{0.0}; // the points are stored less it (PlyData::origin)
};

// What one run of all levels measured, per level.
struct LevelRecord {
    LevelStats stats;
    double rate() const { return static_cast<double>(stats.inserted) / stats.seconds; }
};

// The input of a file as `refine` reads and completes it (readInput, completeInput); errors, a
// missing file among them, are a CommandError naming it.
BenchInput loadBenchInput(const std::string& file) {
    const std::string name = inputName(file);
    glm::dvec3 origin(0.0);
    PointSet points = readInput(file, nullptr, {}, &origin);
    if (points.size() < 3)
        throw CommandError(fmt::format("{}: {} point(s); refinement needs at least 3", name, points.size()));
    completeInput(points, 0, name, {}, origin);
    if (auto valid = validateForRefinement(points); !valid)
        throw CommandError(name + ": " + valid.error().message);
    return {std::filesystem::path(file).stem().string(), file, std::move(points), origin};
}

// The inputs in order: with `--models default` the sphere and the default models found (a missing
// one is skipped, saying so), then the --input files (a missing one is an error). All are read
// before any is timed.
std::vector<BenchInput> benchInputs(const BenchArgs& args) {
    std::vector<BenchInput> inputs;
    if (args.models == "default") {
        PointSet sphere = sampleSphereUniform(args.spherePoints, 1.0f);
        estimateRadii(sphere, 1);
        inputs.push_back({fmt::format("sphere-{}-uniform", args.spherePoints), "", std::move(sphere)});
        for (const std::string& file : sharedModelFiles(kSparseModels, "bench refine"))
            inputs.push_back(loadBenchInput(file));
    }
    for (const std::string& file : args.inputs) inputs.push_back(loadBenchInput(file));
    return inputs;
}

// One run of the full method on `input`: up to `levels` levels, stopping early at `target` points
// (0: no target) or at a level that inserts nothing.
std::vector<LevelRecord> runLevels(const PointSet& input, const RefineOptions& options, unsigned levels,
                                   std::size_t target) {
    Refiner refiner(input, options);
    std::vector<LevelRecord> records;
    while (records.size() < levels && (target == 0 || refiner.points().size() < target)) {
        records.push_back({refiner.refineLevel()});
        if (records.back().stats.inserted == 0) break;
    }
    return records;
}

// A level's JSON record: the counters of `counted` (a profiled run; they do not depend on the
// thread count), its phase shares, and the median rate at each thread count.
std::string levelJson(const LevelStats& counted, const std::vector<unsigned>& threads,
                      const std::vector<std::vector<double>>& rates) {
    std::vector<std::string> byThreads;
    for (std::size_t t = 0; t < threads.size(); ++t)
        byThreads.push_back(fmt::format(R"("{}": {:.0f})", threads[t], median(rates[t])));
    const PhaseTimes& p = counted.phases;
    const double sum = p.neighbourhood + p.filtering + p.selection + p.interpolation;
    const double refined = static_cast<double>(std::max<std::size_t>(counted.refinedPoints, 1));
    return fmt::format(
        R"({{"level": {}, "points_before": {}, "inserted": {}, "refined_points": {}, )"
        R"("scanned_per_point": {:.2f}, "neighbourhood_per_point": {:.2f}, "points_per_second": {{{}}}, )"
        R"("phase_share": {{"neighbourhood": {:.3f}, "filtering": {:.3f}, "selection": {:.3f}, "interpolation": {:.3f}}}}})",
        counted.level, counted.pointsBefore, counted.inserted, counted.refinedPoints,
        static_cast<double>(counted.scannedCandidates) / refined,
        static_cast<double>(counted.neighbourhoodPoints) / refined, fmt::join(byThreads, ", "),
        p.neighbourhood / sum, p.filtering / sum, p.selection / sum, p.interpolation / sum);
}

// With PCL (PNSPLAT_HAS_PCL): PCL's MLS upsampling of the same input to about `pointsOut` points
// (the step searched for first, untimed), one warm-up and args.repeat timed runs of process() per
// thread count, as JSON members ending in ", "; without PCL, nothing. `pnsplatRates` are pnsplat's
// medians per thread count, generated points per second; PCL's rate counts every output point (it
// keeps no input point), which favours PCL by the input's share of the output.
std::string pclMlsJson(const BenchInput& input, std::size_t pointsOut, const std::vector<unsigned>& threads,
                       const std::vector<double>& pnsplatRates, const BenchArgs& args) {
#ifdef PNSPLAT_HAS_PCL
    const unsigned most = *std::max_element(threads.begin(), threads.end());
    const PclMlsSettings settings = choosePclMlsSettings(input.points, pointsOut, most);
    std::size_t points = 0;
    std::vector<std::string> seconds, rates, ratios;
    for (std::size_t t = 0; t < threads.size(); ++t) {
        std::vector<double> times;
        for (unsigned k = 0; k <= args.repeat; ++k) { // k = 0: warm-up
            PclMlsRun run = runPclMls(input.points, settings, threads[t]);
            points = run.output.size();
            if (k > 0) times.push_back(run.seconds);
            if (k == 0 && t == 0 && !args.pclMlsOutput.empty())
                unwrap(writePly(std::filesystem::path(args.pclMlsOutput) / (input.name + "-pcl-mls.ply"),
                                run.output, PlyFormat::BinaryLittleEndian, {}, input.origin));
        }
        if (points == 0) throw CommandError(input.name + ": PCL's MLS upsampling made no point");
        const double rate = static_cast<double>(points) / median(times);
        seconds.push_back(fmt::format(R"("{}": {:.4f})", threads[t], median(times)));
        rates.push_back(fmt::format(R"("{}": {:.0f})", threads[t], rate));
        ratios.push_back(fmt::format(R"("{}": {:.3f})", threads[t], pnsplatRates[t] / rate));
        fmt::print(stderr,
                   "  {:<24} PCL MLS, {} thread(s): {:>10.0f} points/s ({} points), pnsplat / PCL {:.2f}\n",
                   input.name, threads[t], rate, points, pnsplatRates[t] / rate);
    }
    return fmt::format(
        R"("pcl_mls_method": {}, "pcl_mls_points": {}, "pcl_mls_seconds": {{{}}}, "pcl_mls_points_per_second": {{{}}}, )"
        R"("pnsplat_over_pcl_mls": {{{}}}, )",
        jsonString(describePclMls(settings)), points, fmt::join(seconds, ", "), fmt::join(rates, ", "),
        fmt::join(ratios, ", "));
#else
    (void)input, (void)pointsOut, (void)threads, (void)pnsplatRates, (void)args;
    return "";
#endif
}

// The timed runs of one input: per level and thread count, and over all levels per thread count.
struct InputRates {
    std::vector<std::vector<std::vector<double>>> byLevel; // [level][thread count][run]
    std::vector<std::vector<double>> total;                // [thread count][run]
};

// args.repeat rounds of one run per input and thread count, after one warm-up run of each. The
// inputs take turns within a round, so that a slower or faster spell of the machine (a busy
// neighbour, memory touched for the first time) falls on every input alike: issue 28 compares the
// models' rates with the sphere's, in the same run.
std::vector<InputRates> timeInputs(const std::vector<BenchInput>& inputs,
                                   const std::vector<unsigned>& threads, unsigned levels,
                                   const BenchArgs& args) {
    RefineOptions options;
    ProgressBar bar("bench refine: warm-up");
    const std::size_t runs = (std::size_t{args.repeat} + 1) * inputs.size() * threads.size();
    std::size_t done = 0;
    for (const BenchInput& input : inputs)
        for (const unsigned t : threads) {
            bar.update(done++, runs);
            options.threads = t;
            runLevels(input.points, options, levels, args.targetPoints);
        }
    std::vector<InputRates> rates(inputs.size());
    for (InputRates& r : rates) r.total.resize(threads.size());
    for (unsigned k = 0; k < args.repeat; ++k)
        for (std::size_t i = 0; i < inputs.size(); ++i)
            for (std::size_t t = 0; t < threads.size(); ++t) {
                bar.setLabel(
                    fmt::format("bench refine: round {} of {}, {}", k + 1, args.repeat, inputs[i].name));
                bar.update(done++, runs);
                options.threads = threads[t];
                const std::vector<LevelRecord> run =
                    runLevels(inputs[i].points, options, levels, args.targetPoints);
                InputRates& r = rates[i];
                if (r.byLevel.size() < run.size())
                    r.byLevel.resize(run.size(), std::vector<std::vector<double>>(threads.size()));
                std::size_t inserted = 0;
                double seconds = 0.0;
                for (std::size_t l = 0; l < run.size(); ++l) {
                    r.byLevel[l][t].push_back(run[l].rate());
                    inserted += run[l].stats.inserted;
                    seconds += run[l].stats.seconds;
                }
                r.total[t].push_back(static_cast<double>(inserted) / seconds);
            }
    bar.finish();
    return rates;
}

// One input's JSON record from its timed runs (medians per level and thread count), and one
// profiled run on the first thread count for the phase split and the counters.
std::string benchInputJson(const BenchInput& input, const std::vector<unsigned>& threads, unsigned levels,
                           const BenchArgs& args, const InputRates& timed) {
    const auto& rates = timed.byLevel;
    const auto& totals = timed.total;
    RefineOptions options;
    options.threads = threads.front();
    options.profile = true;
    const std::vector<LevelRecord> profiled = runLevels(input.points, options, levels, args.targetPoints);
    assert(!profiled.empty() && profiled.size() == rates.size()); // the same levels on any thread count
    std::vector<std::string> levelRecords, byThreads;
    for (std::size_t l = 0; l < profiled.size(); ++l) {
        levelRecords.push_back(levelJson(profiled[l].stats, threads, rates[l]));
        for (std::size_t t = 0; t < threads.size(); ++t)
            fmt::print(stderr, "  {:<24} level {}, {} thread(s): {:>10.0f} points/s\n", input.name, l + 1,
                       threads[t], median(rates[l][t]));
    }
    for (std::size_t t = 0; t < threads.size(); ++t)
        byThreads.push_back(fmt::format(R"("{}": {:.0f})", threads[t], median(totals[t])));
    const LevelStats& last = profiled.back().stats;
    const std::size_t pointsOut = last.pointsBefore + last.inserted;
    std::vector<double> pnsplatRates;
    for (const std::vector<double>& runs : totals) pnsplatRates.push_back(median(runs));
    return fmt::format(
        R"({{"name": {}, "file": {}, "points_in": {}, "points_out": {}, "points_per_second": {{{}}}, {}"levels": [
    {}
  ]}})",
        jsonString(input.name), input.file.empty() ? "null" : jsonString(input.file), input.points.size(),
        pointsOut, fmt::join(byThreads, ", "), pclMlsJson(input, pointsOut, threads, pnsplatRates, args),
        fmt::join(levelRecords, ",\n    "));
}

void runBenchInputs(const BenchArgs& args) {
    const std::vector<unsigned> threads = args.threads.empty() ? std::vector<unsigned>{1, 2} : args.threads;
    const unsigned levels =
        args.levels != 0 ? args.levels : (args.targetPoints != 0 ? kTargetBenchLevels : kDefaultBenchLevels);
    if (!args.pclMlsOutput.empty() && !std::filesystem::is_directory(args.pclMlsOutput))
        throw CommandError(fmt::format("--pcl-mls-output {}: not a folder", args.pclMlsOutput), kExitUsage);
    const std::vector<BenchInput> inputs = benchInputs(args);
    if (inputs.empty()) throw CommandError("bench refine: no input found");
    for (const BenchInput& input : inputs) {
        const std::string name = input.file.empty() ? input.name : inputName(input.file);
        if (args.targetPoints != 0 && args.targetPoints <= input.points.size())
            throw CommandError(fmt::format("{} has {} points: --target-points {} asks for no more", name,
                                           input.points.size(), args.targetPoints),
                               kExitUsage);
        RefineJob job;
        job.levels = levels;
        job.targetPoints = args.targetPoints;
        job.options.threads = *std::max_element(threads.begin(), threads.end());
        job.maxPoints = args.maxPoints;
        checkFits(input.points, job, name);
    }
    fmt::print(stderr, "bench refine: {} input(s), {} level(s){}, threads {}, {} timed runs each\n",
               inputs.size(), levels,
               args.targetPoints != 0 ? fmt::format(" or >= {} points", args.targetPoints) : "",
               fmt::join(threads, ","), args.repeat);
    const std::vector<InputRates> timed = timeInputs(inputs, threads, levels, args);
    std::vector<std::string> records;
    for (std::size_t i = 0; i < inputs.size(); ++i)
        records.push_back(benchInputJson(inputs[i], threads, levels, args, timed[i]));
    const std::string json = fmt::format(
        R"({{"benchmark": "refine", "case": "inputs per level, full method", "cpu": "{}", "hardware_threads": {}, "repeat": {}, )"
        R"("threads": [{}], "levels": {}, "target_points": {}, "inputs": [
  {}
]}})"
        "\n",
        cpuName(), std::thread::hardware_concurrency(), args.repeat, fmt::join(threads, ", "), levels,
        args.targetPoints != 0 ? fmt::format("{}", args.targetPoints) : "null", fmt::join(records, ",\n  "));
    writeJson(args.output, json);
}

// The defaults finish within two minutes on lavapipe with two cores (4M splats take four more).
struct BenchRenderArgs {
    std::vector<std::size_t> sizes{100000, 1000000};
    std::vector<float> splatPixels{2.0f, 4.0f, 8.0f};
    std::uint32_t width = 1280, height = 720;
    unsigned repeat = 3;
    std::string device;
    std::string output;
};

struct RenderTiming {
    double visibility = 0, accumulation = 0, normalization = 0, wall = 0; // medians, ms
    double gpu() const { return visibility + accumulation + normalization; }
};

// Frames of the engine drawing its input as it is, one at a time: wall time from the frame's start
// to its image in host memory.
RenderTiming timeRenders(engine::Engine& engine, const engine::RenderSettings& settings,
                         const engine::Camera& camera, unsigned repeat) {
    unwrap(engine.setRenderSettings(settings));
    engine::FrameOptions options;
    options.readBack = true;
    std::vector<double> v, a, n, w;
    for (unsigned k = 0; k <= repeat; ++k) { // the first is a warm-up
        const auto start = std::chrono::steady_clock::now();
        const engine::FrameReport report = unwrap(engine.frame(camera, options));
        unwrap(engine.image(report.frame));
        const double wall =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
        engine.finish();
        const engine::PassTimes gpu = engine.reports().back().gpu;
        if (k == 0) continue;
        v.push_back(gpu.visibilityMs);
        a.push_back(gpu.accumulationMs);
        n.push_back(gpu.normalizationMs);
        w.push_back(wall);
    }
    return {median(v), median(a), median(n), median(w)};
}

// Splats of a sphere seen whole at 1280x720 (it fills the image height), every splat given the
// radius that projects to `pixels` in diameter at the sphere's front; against the same points
// drawn once as plain 1-pixel points by the raster pipeline. Progress goes to stderr; each record
// is printed on stdout as one JSON line as soon as it is measured (the first line describes the
// run), so a stopped run keeps what it measured; -o receives the whole document at the end.
void runBenchRender(const BenchRenderArgs& args) {
    engine::ContextOptions contextOptions;
    contextOptions.deviceName = args.device;
    auto context = unwrap(engine::Context::create(contextOptions));
    const float fov = 0.7f;
    const float aspect = float(args.width) / float(args.height);
    const engine::Camera camera = engine::frameSphere({{0, 0, 0}, 1.0f}, aspect, fov, 0.0f);
    const float front = glm::length(camera.eye) - 1.0f;
    const float focalPixels = float(args.height) * 0.5f / std::tan(fov * 0.5f);
    const std::size_t configs = args.sizes.size() * args.splatPixels.size() * 2;
    fmt::print(stderr, "bench render: {}x{} on {} ({}), {} configurations, {} timed runs each\n", args.width,
               args.height, context->deviceName(), context->driverName(), configs, args.repeat);
    const std::string header = fmt::format(
        R"({{"benchmark": "render", "width": {}, "height": {}, "device": "{}", "driver": "{}", "cpu": "{}", "repeat": {}, "default_path": "compute"}})",
        args.width, args.height, context->deviceName(), context->driverName(), cpuName(), args.repeat);
    const auto emit = [](const std::string& line) {
        fmt::print("{}\n", line);
        std::fflush(stdout);
    };
    emit(header);

    std::vector<std::string> runs;
    for (std::size_t n : args.sizes) {
        fmt::print(stderr, "  {:>8} splats: sampling the sphere, uploading\n", n);
        PointSet sphere = sampleSphereUniform(n, 1.0f);
        const float basePixels = args.splatPixels.front();
        sphere.radius.assign(n, basePixels * front / (2.0f * focalPixels));
        engine::RenderSettings plain;
        plain.width = args.width;
        plain.height = args.height;
        plain.path = engine::RenderPath::PlainPoints;
        engine::EngineSettings settings;
        settings.render = plain;
        settings.adaptive = false;
        const auto engine = unwrap(engine::Engine::create(*context, std::move(sphere), settings));
        const RenderTiming baseline = timeRenders(*engine, plain, camera, args.repeat);
        fmt::print(stderr, "  {:>8} splats: plain 1-px points {:.1f} ms (GPU), {:.1f} ms (wall)\n", n,
                   baseline.gpu(), baseline.wall);
        for (float pixels : args.splatPixels) {
            for (engine::RenderPath path : {engine::RenderPath::Compute, engine::RenderPath::Graphics}) {
                engine::RenderSettings splats = plain;
                splats.path = path;
                splats.radiusScale = pixels / basePixels;
                const RenderTiming t = timeRenders(*engine, splats, camera, args.repeat);
                const char* name = path == engine::RenderPath::Compute ? "compute" : "graphics";
                fmt::print(stderr,
                           "  {:>8} splats, {} px, {:<8}: {:.1f} + {:.1f} + {:.1f} ms = {:.1f} ms, ratio to "
                           "points {:.2f} ({}/{})\n",
                           n, pixels, name, t.visibility, t.accumulation, t.normalization, t.gpu(),
                           t.gpu() / baseline.gpu(), runs.size() + 1, configs);
                runs.push_back(fmt::format(
                    R"({{"splats": {}, "splat_pixels": {}, "path": "{}", "visibility_ms": {:.2f}, "accumulation_ms": {:.2f}, )"
                    R"("normalization_ms": {:.2f}, "passes_ms": {:.2f}, "wall_ms": {:.2f}, "splats_per_second": {:.0f}, )"
                    R"("plain_points_ms": {:.2f}, "plain_points_wall_ms": {:.2f}, "ratio_to_plain_points": {:.3f}, "wall_ratio_to_plain_points": {:.3f}}})",
                    n, pixels, name, t.visibility, t.accumulation, t.normalization, t.gpu(), t.wall,
                    double(n) / (t.gpu() * 1e-3), baseline.gpu(), baseline.wall, t.gpu() / baseline.gpu(),
                    t.wall / baseline.wall));
                emit(runs.back());
            }
        }
    }
    if (args.output.empty()) return;
    const std::string json = fmt::format(R"({}, "runs": [
  {}
]}})"
                                         "\n",
                                         header.substr(0, header.size() - 1), fmt::join(runs, ",\n  "));
    writeJson(args.output, json);
}

} // namespace

void addBenchCommand(CLI::App& app) {
    CLI::App* bench = app.add_subcommand("bench", "Performance harness (JSON on standard output)");
    bench->require_subcommand(1);
    const auto [refine, args] = addSubcommand(
        *bench, "refine",
        "Points generated per second: full method and faster variants on a sphere, 1 and 2 threads; or "
        "per level of given inputs (--input, --models)",
        runBenchRefine);
    refine->add_option("--sphere-points", args->spherePoints, "input: uniform points on the unit sphere")
        ->check(CLI::Range(std::size_t{3}, std::size_t{100'000'000}))
        ->capture_default_str();
    refine
        ->add_option("--target-points", args->targetPoints,
                     "refine until at least this many points (default: 150000 for the sphere; with "
                     "inputs, no target: --levels)")
        ->check(kPositiveCount);
    refine->add_option("--repeat", args->repeat, "timed runs per configuration (after one warm-up)")
        ->check(CLI::Range(1u, 100u))
        ->capture_default_str();
    refine
        ->add_option("--input", args->inputs,
                     "PLY files to refine with the full method instead of the sweep of variants on the "
                     "sphere: per level, points/s at each --threads count, candidates scanned and "
                     "neighbourhood size per refined point, the split per phase")
        ->type_name("FILE");
    refine
        ->add_option("--models", args->models,
                     "default: the --input report on the sphere and the sparse real models, "
                     "../shared/data/*.ply from the working directory (the project's root; a missing "
                     "one is skipped), before any --input files")
        ->check(CLI::IsMember({"default"}));
    refine
        ->add_option("--levels", args->levels,
                     "with inputs: levels to refine each (default 4; 16 with --target-points)")
        ->check(CLI::Range(1u, 16u));
    refine->add_option("--threads", args->threads, "with inputs: thread counts to time (default 1,2)")
        ->delimiter(',')
        ->check(CLI::Range(1u, 256u));
    addMaxPointsOption(*refine, args->maxPoints);
#ifdef PNSPLAT_HAS_PCL
    refine
        ->add_option("--pcl-mls-output", args->pclMlsOutput,
                     "with inputs: write PCL's MLS upsampling of each into this folder as NAME-pcl-mls.ply")
        ->type_name("DIR");
#endif
    refine->add_option("-o,--output", args->output, "write the JSON here instead of standard output");
    addForceFlag(*refine, args->force);
    addBenchViewCommand(*bench);
    addBenchSettleCommand(*bench);

    const auto [render, renderArgs] = addSubcommand(
        *bench, "render",
        "Time per pass and splats per second for both paths, against plain 1-pixel points (Vulkan); one JSON "
        "line per record on standard output as it is measured",
        runBenchRender);
    render->add_option("--sizes", renderArgs->sizes, "splat counts")->delimiter(',')->capture_default_str();
    render->add_option("--splat-pixels", renderArgs->splatPixels, "splat diameters in pixels")
        ->delimiter(',')
        ->check(finiteRange(0.1, 256.0))
        ->capture_default_str();
    render->add_option("--width", renderArgs->width, "image width")
        ->check(CLI::Range(1u, 16384u))
        ->capture_default_str();
    render->add_option("--height", renderArgs->height, "image height")
        ->check(CLI::Range(1u, 16384u))
        ->capture_default_str();
    render->add_option("--repeat", renderArgs->repeat, "timed frames per configuration (after one warm-up)")
        ->check(CLI::Range(1u, 100u))
        ->capture_default_str();
    render->add_option("--device", renderArgs->device, "Vulkan device whose name contains this text");
    render->add_option(
        "-o,--output", renderArgs->output,
        "also write the whole JSON document here at the end (standard output gets one line per "
        "record as it is measured)");
}

} // namespace pnsplat::tools
