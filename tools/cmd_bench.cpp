// `pnsplat bench`: performance harness printing JSON (warm-up, then timed runs; medians).
#include <algorithm>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <fmt/core.h>
#include <fmt/format.h>

#include "commands.h"
#include "pnsplat/refine/radius_estimation.h"
#include "pnsplat/refine/refiner.h"
#include "pnsplat/refine/shapes.h"

namespace pnsplat::tools {

namespace {

struct BenchArgs {
    std::size_t spherePoints = 600;
    std::size_t targetPoints = 150000;
    unsigned repeat = 5;
    std::string output;
};

struct RunResult {
    std::size_t generated = 0;
    double seconds = 0;
    unsigned levels = 0;
    PhaseTimes phases;
};

RunResult refineOnce(const PointSet& input, const RefineOptions& options, std::size_t target) {
    Refiner refiner(input, options);
    RunResult result;
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
    result.generated = refiner.points().size() - input.size();
    return result;
}

// The processor's name from /proc/cpuinfo ("unknown" elsewhere), for the JSON record.
std::string cpuName() {
    std::ifstream in("/proc/cpuinfo");
    std::string line;
    while (std::getline(in, line)) {
        if (line.rfind("model name", 0) != 0) continue;
        const std::size_t colon = line.find(':');
        if (colon != std::string::npos && colon + 2 <= line.size()) return line.substr(colon + 2);
    }
    return "unknown";
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

std::string benchConfig(const std::string& name, const PointSet& input, RefineOptions options, unsigned threads,
                        const BenchArgs& args) {
    options.threads = threads;
    refineOnce(input, options, args.targetPoints); // warm-up
    std::vector<double> rates;
    RunResult last;
    for (unsigned k = 0; k < args.repeat; ++k) {
        last = refineOnce(input, options, args.targetPoints);
        rates.push_back(static_cast<double>(last.generated) / last.seconds);
    }
    std::string json = fmt::format(R"({{"name": "{}", "threads": {}, "levels": {}, "points_out": {}, "generated": {}, )"
                                   R"("points_per_second_median": {:.0f}, "points_per_second_min": {:.0f}, "points_per_second_max": {:.0f})",
                                   name, threads, last.levels, last.generated + input.size(), last.generated, median(rates),
                                   *std::min_element(rates.begin(), rates.end()), *std::max_element(rates.begin(), rates.end()));
    if (threads == 1) {
        // The split per phase comes from a separate profiled run (timers cost a little).
        options.profile = true;
        const RunResult profiled = refineOnce(input, options, args.targetPoints);
        const PhaseTimes& p = profiled.phases;
        const double sum = p.neighbourhood + p.filtering + p.selection + p.interpolation;
        json += fmt::format(R"(, "phase_share": {{"neighbourhood": {:.3f}, "filtering": {:.3f}, "selection": {:.3f}, "interpolation": {:.3f}}})",
                            p.neighbourhood / sum, p.filtering / sum, p.selection / sum, p.interpolation / sum);
    }
    fmt::print(stderr, "  {:<28} {} thread(s): {:>10.0f} points/s\n", name, threads, median(rates));
    return json + "}";
}

void runBenchRefine(const BenchArgs& args) {
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
    const std::string json = fmt::format(
        R"({{"benchmark": "refine", "case": "sphere {} uniform points to >= {} points", "cpu": "{}", "hardware_threads": {}, "repeat": {}, "runs": [
  {}
]}})"
        "\n",
        args.spherePoints, args.targetPoints, cpuName(), std::thread::hardware_concurrency(), args.repeat,
        fmt::join(runs, ",\n  "));
    if (args.output.empty()) {
        fmt::print("{}", json);
    } else {
        std::ofstream out(args.output);
        out << json;
        if (!out) throw CommandError(args.output + ": cannot write");
    }
}

} // namespace

void addBenchCommand(CLI::App& app) {
    CLI::App* bench = app.add_subcommand("bench", "Performance harness (JSON on standard output)");
    bench->require_subcommand(1);
    auto args = std::make_shared<BenchArgs>();
    CLI::App* refine = bench->add_subcommand("refine", "Points generated per second, full method and faster variants, 1 and 2 threads");
    refine->add_option("--sphere-points", args->spherePoints, "input: uniform points on the unit sphere")->capture_default_str();
    refine->add_option("--target-points", args->targetPoints, "refine until at least this many points")->capture_default_str();
    refine->add_option("--repeat", args->repeat, "timed runs per configuration (after one warm-up)")
        ->check(CLI::Range(1u, 100u))
        ->capture_default_str();
    refine->add_option("-o,--output", args->output, "write the JSON here instead of standard output");
    refine->callback([args] { runBenchRefine(*args); });
}

} // namespace pnsplat::tools
