// Oracles shared by the test suite and the fuzz targets (tests/fuzz): bitwise equality, the
// convergence bound of SPEC 4, and the interpolation check of SPEC 1.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstring>
#include <span>
#include <type_traits>
#include <vector>

#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/refiner.h"

namespace pnsplat::test {

// c_β,max: the largest radius ratio of one level (SPEC 4, paper eq. 14), the maximum over β of
// c_β = 1/3 (5/6 + 5/6 + cos(β/2) + 2/3 sin(β/2)); cos x + 2/3 sin x peaks at sqrt(1 + 4/9).
inline const double kConvergenceBound = (5.0 / 6.0 + 5.0 / 6.0 + std::sqrt(1.0 + 4.0 / 9.0)) / 3.0;

template <typename T>
    requires std::is_trivially_copyable_v<T>
bool sameBits(const T& a, const T& b) {
    return std::memcmp(&a, &b, sizeof(T)) == 0;
}

template <typename T, typename Allocator>
bool sameBits(const std::vector<T, Allocator>& a, const std::vector<T, Allocator>& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

// P0 points of the output that differ from their input twin (position, normal, colour, second
// normal) in any bit; all of them when P0 is not a permutation of the input.
inline std::size_t inputMismatches(const Refiner& refiner, const PointSet& input) {
    const PointSet& out = refiner.points();
    const auto order = refiner.inputOrder();
    if (order.size() != input.size() || refiner.levelEnd(0) != input.size()) return input.size();
    std::size_t bad = 0;
    for (std::size_t k = 0; k < order.size(); ++k) {
        const std::size_t i = order[k];
        if (i >= input.size()) return input.size();
        bool same = sameBits(out.position[k], input.position[i]) && sameBits(out.normal[k], input.normal[i]);
        if (input.hasColour()) same = same && out.hasColour() && sameBits(out.colour[k], input.colour[i]);
        if (input.hasCrease()) same = same && out.hasCrease() && sameBits(out.crease[k], input.crease[i]);
        bad += !same;
    }
    return bad;
}

} // namespace pnsplat::test
