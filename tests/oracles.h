// Oracles shared by the test suite and the fuzz targets (tests/fuzz): bitwise equality, the
// convergence bound of ALGORITHM.md §4.7, the interpolation check of ALGORITHM.md §1.1, and a point set's
// consistency.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstring>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include <glm/geometric.hpp>

#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/refiner.h"

namespace pnsplat::test {

// c_β,max: the largest radius ratio of one level (ALGORITHM.md §4.7, paper eq. 14), the maximum over β of
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
// normal, attributes) in any bit; all of them when P0 is not a permutation of the input.
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
        same = same && out.attributes.size() == input.attributes.size();
        for (std::size_t a = 0; same && a < input.attributes.size(); ++a)
            same = sameBits(out.attributes[a].values[k], input.attributes[a].values[i]);
        bad += !same;
    }
    return bad;
}

struct Consistency {
    float normalTolerance = 1e-5f; // largest | |n| - 1 | of normals and second normals
    bool refined = false;          // a refiner's output: normals and radii present, radii > 0
};
// A refiner's output: its new normals come from cross products normalised in single precision.
inline constexpr Consistency kRefined{.normalTolerance = 1e-3f, .refined = true};

// What is wrong with a point set, empty where nothing is: attribute arrays that do not match the
// positions (normals, radii, colours and second normals for every point or none; for a refined
// set, normals and radii for every point), positions that are not finite, normals or second
// normals off unit length, radii not finite or negative (or zero, in a refined set).
inline std::string pointSetDefect(const PointSet& points, const Consistency& expect = {}) {
    const std::size_t n = points.size();
    const auto sized = [n](std::size_t size) { return size == 0 || size == n; };
    if (!sized(points.normal.size()) || !sized(points.radius.size()) || !sized(points.colour.size()) ||
        !sized(points.crease.size()))
        return "an attribute array does not match the positions";
    for (const Attribute& a : points.attributes)
        if (a.values.size() != n) return "the values of attribute " + a.name + " do not match the positions";
    if (expect.refined && n > 0 && (!points.hasNormal() || !points.hasRadius()))
        return "no normals or no radii";
    const auto unit = [&](glm::vec3 v) { return std::abs(glm::length(v) - 1.0f) <= expect.normalTolerance; };
    for (std::size_t i = 0; i < n; ++i) {
        const glm::vec3 x = points.position[i];
        if (!std::isfinite(x.x) || !std::isfinite(x.y) || !std::isfinite(x.z))
            return "position " + std::to_string(i) + " not finite";
        if (points.hasNormal() && !unit(points.normal[i]))
            return "normal " + std::to_string(i) + " not of unit length";
        if (points.isCrease(i) && !unit(points.crease[i]))
            return "second normal " + std::to_string(i) + " not of unit length";
        if (points.hasRadius()) {
            const float r = points.radius[i];
            if (!std::isfinite(r) || r < 0.0f || (expect.refined && r == 0.0f))
                return "radius " + std::to_string(i) + " out of range";
        }
    }
    return {};
}

} // namespace pnsplat::test
