// libFuzzer target: any bytes through what `pnsplat refine` does with a file — read (normals
// optional), repeated positions merged, normals and radii estimated where missing, validated —
// and then two levels of refinement, the method's variant picked by the last byte. Inputs are
// kept small (at most kMaxPoints points) so that each run takes milliseconds.
// Oracles, on every input that is refined:
// - interpolation (SPEC 1): every input point is in the output bit for bit;
// - convergence (SPEC 4): every old radius shrinks at least by c_β,max per level;
// - determinism (SPEC 5): one and two threads give the same bits;
// - finite positions, unit normals, finite positive radii.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string_view>
#include <utility>

#include <glm/geometric.hpp>

#include "fuzz_check.h"
#include "pnsplat/refine/normal_estimation.h"
#include "pnsplat/refine/ply.h"
#include "pnsplat/refine/radius_estimation.h"
#include "pnsplat/refine/refiner.h"

using namespace pnsplat;
using pnsplat::fuzz::check;

namespace {

constexpr std::size_t kMaxPoints = 300;
constexpr unsigned kLevels = 2;
// c_β,max (SPEC 4, eq. 14), with room for the rounding of r' (kRadiusMargin in refiner.cpp).
const double kConvergenceBound = (5.0 / 6.0 + 5.0 / 6.0 + std::sqrt(1.0 + 4.0 / 9.0)) / 3.0 * (1.0 + 1e-6);

template <typename Array>
bool sameBits(const Array& a, const Array& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0);
}

// The input as `pnsplat refine` completes it; false where the tool would stop with an error.
bool completeInput(PointSet& points) {
    removeCoincident(points);
    if (points.size() < 3) return false;
    if (!points.hasNormal() && !estimateNormals(points, 1)) return false;
    if (!points.hasRadius()) {
        estimateRadii(points, 1);
        for (const float r : points.radius)
            if (!(r > 0.0f) || !std::isfinite(r)) return false;
    }
    return validateForRefinement(points).ok();
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
            check(static_cast<double>(after.radius[i]) <= kConvergenceBound * static_cast<double>(before[i]),
                  "every old radius shrinks by c_beta,max");
    }
    const PointSet& out = refiner.points();
    const std::span<const std::uint32_t> order = refiner.inputOrder();
    for (std::size_t k = 0; k < input.size(); ++k) {
        check(std::memcmp(&out.position[k], &input.position[order[k]], sizeof(glm::vec3)) == 0, "input positions kept");
        check(std::memcmp(&out.normal[k], &input.normal[order[k]], sizeof(glm::vec3)) == 0, "input normals kept");
    }
    for (std::size_t i = 0; i < out.size(); ++i) {
        const glm::vec3 x = out.position[i];
        check(std::isfinite(x.x) && std::isfinite(x.y) && std::isfinite(x.z), "finite positions");
        check(std::abs(glm::length(out.normal[i]) - 1.0f) < 1e-3f, "unit normals");
        check(out.radius[i] > 0.0f && std::isfinite(out.radius[i]), "finite positive radii");
    }
    return std::move(refiner).takePoints();
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    PlyReadOptions options;
    options.requireNormals = false;
    Result<PlyData> read = parsePly(std::string_view(reinterpret_cast<const char*>(data), size), "input", options);
    if (!read || read->points.size() > kMaxPoints) return 0;
    PointSet points = std::move(read->points);
    if (!completeInput(points)) return 0;
    const std::uint8_t knob = data[size - 1];
    const PointSet one = refine(points, knob, 1), two = refine(points, knob, 2);
    check(sameBits(one.position, two.position) && sameBits(one.normal, two.normal) && sameBits(one.radius, two.radius) &&
              sameBits(one.colour, two.colour) && sameBits(one.crease, two.crease),
          "the same output for one and two threads");
    return 0;
}
