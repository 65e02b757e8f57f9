// libFuzzer target: the first byte picks the method's variant, the rest goes through what
// `pnsplat refine` does with a file — read (normals optional), repeated positions merged, normals
// and radii estimated where missing, validated — and then two levels of refinement. Inputs are
// kept small (at most kMaxPoints points) so that each run takes milliseconds.
// Oracles, on every input that is refined:
// - interpolation (ALGORITHM.md §1.1): every input point is in the output bit for bit (position, normal,
//   colour, second normal);
// - convergence (ALGORITHM.md §4.7): every old radius shrinks at least by c_β,max per level (the refiner
//   keeps r' <= c_β,max·r in single precision with c_β,max rounded down, below the exact bound);
// - determinism (ALGORITHM.md §5.1): one and two threads give the same bits;
// - finite positions, unit normals, finite positive radii.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>

#include "fuzz_check.h"
#include "oracles.h"
#include "pnsplat/refine/input.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/refiner.h"

using namespace pnsplat;
using pnsplat::fuzz::check;
using pnsplat::test::sameBits;

namespace {

constexpr std::size_t kMaxPoints = 300;
constexpr unsigned kLevels = 2;

// The input as `pnsplat refine` completes it; false where the tool would stop with an error.
bool completeForRefinement(PointSet& points) {
    return completeInput(points, 1).ok() && validateForRefinement(points).ok();
}

RefineOptions optionsFrom(std::uint8_t knob, unsigned threads) {
    RefineOptions options = (knob & 1) != 0 ? RefineOptions::fast() : RefineOptions{};
    if ((knob & 2) != 0) options.neighbourhood = NeighbourhoodKind::Fuzzy;
    if ((knob & 4) != 0) options.smoothing = false;
    if ((knob & 8) != 0) options.boundaries = false;
    options.threads = threads;
    return options;
}

PointSet refine(const PointSet& input, std::uint8_t knob, unsigned threads) {
    Refiner refiner(input, optionsFrom(knob, threads));
    for (unsigned l = 0; l < kLevels; ++l) {
        const auto before = refiner.points().radius;
        refiner.refineLevel();
        const PointSet& after = refiner.points();
        for (std::size_t i = 0; i < before.size(); ++i)
            check(static_cast<double>(after.radius[i]) <=
                      test::kConvergenceBound * static_cast<double>(before[i]),
                  "every old radius shrinks by c_beta,max");
    }
    check(test::inputMismatches(refiner, input) == 0, "every input point kept bit for bit");
    const std::string defect = test::pointSetDefect(refiner.points(), test::kRefined);
    check(defect.empty(), defect.c_str());
    return std::move(refiner).takePoints();
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 2) return 0;
    const std::uint8_t knob = data[0];
    PlyReadOptions options;
    options.requireNormals = false;
    Result<PlyData> read =
        parsePly(std::string_view(reinterpret_cast<const char*>(data) + 1, size - 1), "input", options);
    if (!read || read->points.size() > kMaxPoints) return 0;
    PointSet points = std::move(read->points);
    if (!completeForRefinement(points)) return 0;
    const PointSet one = refine(points, knob, 1), two = refine(points, knob, 2);
    check(sameBits(one.position, two.position) && sameBits(one.normal, two.normal) &&
              sameBits(one.radius, two.radius) && sameBits(one.colour, two.colour) &&
              sameBits(one.crease, two.crease) && one.attributes.size() == two.attributes.size(),
          "the same output for one and two threads");
    for (std::size_t a = 0; a < one.attributes.size(); ++a)
        check(sameBits(one.attributes[a].values, two.attributes[a].values),
              "the same attributes for one and two threads");
    return 0;
}
