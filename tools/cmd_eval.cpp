// `pnsplat eval`: measures a refined point set against the true surface (an analytic sphere or
// torus, or a dense reference PLY) and prints the metrics of refine/evaluation/quality.h as JSON.
#include <filesystem>
#include <memory>
#include <string>

#include <fmt/core.h>

#include "commands.h"
#include "pnsplat/refine/evaluation/quality.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/io/point_file.h"
#include "refine_run.h"

namespace pnsplat::tools {
namespace {

struct EvalArgs {
    std::string refined;
    std::string reference;
    std::string input;
    std::string output;
    std::string holeMap;
    unsigned threads = 0;
    bool flatNormals = false;
    bool force = false;
};

// The refined points in grey with the reference points counted as holes among them, in their
// colours (quality.h), as discs as wide as the hole test's distance: where the holes are, to
// render with `pnsplat render`.
PointSet holeMap(PointSet refined, const QualityReport& report) {
    constexpr glm::u8vec3 kGrey{200, 200, 200};
    refined.colour.assign(refined.size(), kGrey);
    const PointSet& holes = report.holePoints;
    for (std::size_t i = 0; i < holes.size(); ++i) {
        refined.position.push_back(holes.position[i]);
        refined.normal.push_back(holes.normal[i]);
        refined.colour.push_back(holes.colour[i]);
        if (refined.hasRadius()) refined.radius.push_back(static_cast<float>(2.0 * report.spacingMean));
        if (refined.hasCrease()) refined.crease.emplace_back(0.0f);
    }
    return refined;
}

void runEval(const EvalArgs& args) {
    for (const std::string& output : {args.output, args.holeMap})
        refuseToOverwriteInput(output, {args.refined, args.reference, args.input}, args.force);
    Result<Reference> parsed = parseReference(args.reference);
    if (!parsed) {
        // A spec ("sphere:abc", "cube:2") is a usage error; a file that cannot be read, a failure.
        const bool spec =
            args.reference.find(':') != std::string::npos && !std::filesystem::exists(args.reference);
        throw CommandError(parsed.error().message, spec ? kExitUsage : kExitFailure);
    }
    Reference reference = std::move(parsed).value();
    PlyData read = unwrap(readPointFile(args.refined)).data; // any point file, with normals
    PointSet refined = std::move(read.points);
    if (refined.size() < 2)
        throw CommandError(fmt::format("{}: needs at least 2 points to measure spacing", args.refined));
    // One origin for the files (PlyData::origin): the refined points', or 0 for an analytic surface.
    glm::dvec3 origin = read.origin;
    if (reference.isAnalytic()) {
        moveToOrigin(refined.position, origin, glm::dvec3(0.0));
        origin = glm::dvec3(0.0);
    }
    moveToOrigin(reference.points.position, reference.origin, origin);
    reference.origin = origin;

    PointSet input;
    glm::dvec3 inputOrigin(0.0);
    if (!args.input.empty()) input = readInput(args.input, nullptr, {}, &inputOrigin); // compared by position
    moveToOrigin(input.position, inputOrigin, origin);

    EvalOptions options;
    options.threads = args.threads;
    options.flatNormals = args.flatNormals;
    const QualityReport report =
        evaluateQuality(refined, reference, args.input.empty() ? nullptr : &input, options);
    // Files in other units or places than the reference's: say so beside the report, which is
    // written all the same. Far from its surface on average, or a box of another size altogether.
    const double ownDiagonal = boundsOf(refined.position).diagonal();
    const double sizes = ownDiagonal / report.diagonal;
    if (report.diagonal > 0.0 && (report.distanceMeanRel > 1.0 || sizes > 100.0 || sizes < 0.01)) {
        const auto plain = [](double v) {
            return v >= 1000.0 ? fmt::format("{:.0f}", v) : fmt::format("{:.4g}", v);
        };
        fmt::print(
            stderr,
            "pnsplat: {}: its points lie on average {} times the reference's diagonal ({}) from the "
            "reference's surface, and their own box's diagonal is {}: are the two in the same units and "
            "place?\n",
            inputName(args.refined), plain(report.distanceMeanRel), plain(report.diagonal),
            plain(ownDiagonal));
    }
    if (!args.holeMap.empty())
        unwrap(writePly(args.holeMap, holeMap(std::move(refined), report), PlyFormat::BinaryLittleEndian, {},
                        origin));
    const std::string json = toJson(report) + "\n";
    if (args.output.empty())
        fmt::print("{}", json);
    else
        unwrap(writeFile(args.output, json));
}

} // namespace

void addEvalCommand(CLI::App& app) {
    const auto [cmd, args] = addSubcommand(
        app, "eval", "Measure a refined point set against the true surface; print JSON", runEval);
    cmd->add_option("REFINED", args->refined, "Refined point set (PLY, PCD or text, with normals)")
        ->required();
    cmd->add_option("--reference", args->reference,
                    "True surface: sphere:R | torus:R,r (centred at the origin, torus axis z) | "
                    "DENSE.ply (with faces: a mesh, exact distances; without: reference points)")
        ->required();
    cmd->add_option("--input", args->input,
                    "The original sparse input (PLY), to check it is kept bit for bit");
    cmd->add_option("-o,--output", args->output, "Write the JSON report to this file instead of stdout");
    addForceFlag(*cmd, args->force);
    cmd->add_option(
        "--hole-map", args->holeMap,
        "Write a PLY to look at (pnsplat render): the refined points in grey and the reference points "
        "counted as holes or gaps, red where they are gaps (no refined point projected onto the surface "
        "is near: the true surface is uncovered), orange where the refined surface passes off the true one");
    cmd->add_flag(
        "--flat-normals", args->flatNormals,
        "A mesh reference's true normal is the closest triangle's own, not its vertex normals interpolated "
        "(CAD parts with sharp edges, whose vertex normals average the faces on both sides)");
    cmd->add_option("--threads", args->threads,
                    "Worker threads (0 = all hardware threads); results do not depend on it")
        ->capture_default_str();
    cmd->footer(
        "Metrics (JSON keys), one value per refined point reduced over the set:\n"
        "  distance          to the true surface: mean, rms, p99 (99th percentile), max; *_rel\n"
        "                    divide by the reference's bbox diagonal\n"
        "  normal_error_deg  angle to the true normal at the closest surface point: mean, p95, max\n"
        "  spacing_mean      mean distance from a refined point to its nearest other refined point\n"
        "  uniformity_cv     std / mean of those nearest-neighbour distances (0 = perfectly even)\n"
        "  holes             share of reference points with no refined point within 2 x spacing_mean\n"
        "  holes_tangential  the same, distances measured in the reference point's tangent plane\n"
        "  gaps              share of reference points farther than 2 x spacing_mean from every refined "
        "point\n"
        "                    projected onto the true surface (its closest point there): the surface left "
        "uncovered\n"
        "  input_preserved   every --input point's position and normal (position alone for an input without "
        "normals)\n"
        "                    in the output bit for bit (+ input_missing)\n"
        "True surface: sphere/torus exact (holes use 200k samples); a mesh PLY exact (true normal = vertex\n"
        "normals interpolated at the closest point, or its face's with --flat-normals; holes use its "
        "vertices);\n"
        "a points-only PLY approximate\n"
        "(nearest reference point's tangent plane and normal).");
}

} // namespace pnsplat::tools
