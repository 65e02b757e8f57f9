#include "pnsplat/refine/point_set.h"

#include <algorithm>
#include <cassert>
#include <numeric>
#include <vector>

namespace pnsplat {

void PointSet::appendFrom(const PointSet& other, std::size_t i) {
    assert(hasRadius() == other.hasRadius() || empty());
    position.push_back(other.position[i]);
    normal.push_back(other.normal[i]);
    if (other.hasRadius()) radius.push_back(other.radius[i]);
    if (other.hasColour()) colour.push_back(other.colour[i]);
    if (other.hasCrease()) crease.push_back(other.crease[i]);
}

void PointSet::reserve(std::size_t n) {
    position.reserve(n);
    normal.reserve(n);
    radius.reserve(n);
    colour.reserve(n);
    if (hasCrease()) crease.reserve(n);
}

void PointSet::resize(std::size_t n) {
    const bool withRadius = hasRadius();
    const bool withColour = hasColour();
    const bool withCrease = hasCrease();
    const bool withNormal = hasNormal() || empty();
    position.resize(n);
    if (withNormal) normal.resize(n);
    if (withRadius) radius.resize(n);
    if (withColour) colour.resize(n);
    if (withCrease) crease.resize(n);
}

std::vector<std::uint32_t> orderByPosition(const PointSet& points) {
    std::vector<std::uint32_t> order(points.size());
    std::iota(order.begin(), order.end(), 0u);
    std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
        const glm::vec3 pa = points.position[a], pb = points.position[b];
        if (pa.x != pb.x) return pa.x < pb.x;
        if (pa.y != pb.y) return pa.y < pb.y;
        if (pa.z != pb.z) return pa.z < pb.z;
        return a < b;
    });
    return order;
}

std::optional<CoincidentPair> findCoincident(const PointSet& points) {
    const std::vector<std::uint32_t> order = orderByPosition(points);
    std::optional<CoincidentPair> found;
    for (std::size_t k = 1; k < order.size(); ++k) {
        if (points.position[order[k]] != points.position[order[k - 1]]) continue;
        // order[k - 1] is not necessarily the group's first: the first of a group is its smallest.
        std::size_t g = k - 1;
        while (g > 0 && points.position[order[g - 1]] == points.position[order[k]]) --g;
        const CoincidentPair pair{order[g], order[g + 1]};
        if (!found || pair.first < found->first) found = pair;
    }
    return found;
}

std::size_t removeCoincident(PointSet& points) {
    const std::vector<std::uint32_t> order = orderByPosition(points);
    std::vector<std::uint8_t> keep(points.size(), 1);
    for (std::size_t k = 1; k < order.size(); ++k)
        if (points.position[order[k]] == points.position[order[k - 1]]) keep[order[k]] = 0;
    std::size_t kept = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (!keep[i]) continue;
        points.position[kept] = points.position[i];
        if (points.hasNormal()) points.normal[kept] = points.normal[i];
        if (points.hasRadius()) points.radius[kept] = points.radius[i];
        if (points.hasColour()) points.colour[kept] = points.colour[i];
        if (points.hasCrease()) points.crease[kept] = points.crease[i];
        ++kept;
    }
    const std::size_t removed = points.size() - kept;
    points.resize(kept);
    return removed;
}

} // namespace pnsplat
