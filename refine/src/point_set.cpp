#include "pnsplat/refine/point_set.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <utility>
#include <vector>

#include "pnsplat/refine/morton.h"

namespace pnsplat {

std::size_t scalarTypeBytes(ScalarType type) {
    static constexpr std::size_t kBytes[] = {1, 1, 2, 2, 4, 4, 4, 8};
    return kBytes[static_cast<std::size_t>(type)];
}

double representable(ScalarType type, double value) {
    // The range of each integer type, in the order of ScalarType.
    static constexpr std::pair<double, double> kRange[] = {
        {-128.0, 127.0},    {0.0, 255.0}, {-32768.0, 32767.0}, {0.0, 65535.0}, {-2147483648.0, 2147483647.0},
        {0.0, 4294967295.0}};
    switch (type) {
    case ScalarType::Float32:
        return static_cast<float>(value);
    case ScalarType::Float64:
        return value;
    default: {
        if (std::isnan(value)) return 0.0;
        const auto [lo, hi] = kRange[static_cast<std::size_t>(type)];
        return std::clamp(std::round(value), lo, hi);
    }
    }
}

Bounds boundsOf(std::span<const glm::vec3> positions) {
    Bounds b;
    for (const glm::vec3& x : positions) {
        b.lo = glm::min(b.lo, x);
        b.hi = glm::max(b.hi, x);
    }
    return b;
}

bool sameAttributes(const PointSet& a, const PointSet& b) {
    return std::equal(
        a.attributes.begin(), a.attributes.end(), b.attributes.begin(), b.attributes.end(),
        [](const Attribute& u, const Attribute& v) { return u.name == v.name && u.type == v.type; });
}

std::vector<Attribute> emptyAttributesLike(const PointSet& model) {
    std::vector<Attribute> attributes;
    attributes.reserve(model.attributes.size());
    for (const Attribute& a : model.attributes) attributes.push_back(Attribute{a.name, a.type, {}});
    return attributes;
}

void PointSet::appendAttributesFrom(const PointSet& other, std::size_t i) {
    // The position is appended already: a set that was empty has one point now.
    if (attributes.empty() && size() == 1) attributes = emptyAttributesLike(other);
    assert(sameAttributes(*this, other));
    for (std::size_t a = 0; a < attributes.size(); ++a)
        attributes[a].values.push_back(other.attributes[a].values[i]);
}

void PointSet::appendCoreFrom(const PointSet& other, std::size_t i) {
    assert(hasNormal() == other.hasNormal() || empty());
    assert(hasRadius() == other.hasRadius() || empty());
    assert(other.hasAttributes() || !hasAttributes());
    position.push_back(other.position[i]);
    if (other.hasNormal()) normal.push_back(other.normal[i]); // positions only: before estimateNormals
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
    for (Attribute& a : attributes) a.values.reserve(n);
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
    for (Attribute& a : attributes) a.values.resize(n);
}

void removePoints(PointSet& points, std::span<const std::uint32_t> drop) {
    assert(std::is_sorted(drop.begin(), drop.end()));
    std::size_t kept = 0, next = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (next < drop.size() && drop[next] == i) {
            ++next;
            continue;
        }
        points.position[kept] = points.position[i];
        if (points.hasNormal()) points.normal[kept] = points.normal[i];
        if (points.hasRadius()) points.radius[kept] = points.radius[i];
        if (points.hasColour()) points.colour[kept] = points.colour[i];
        if (points.hasCrease()) points.crease[kept] = points.crease[i];
        for (Attribute& a : points.attributes) a.values[kept] = a.values[i];
        ++kept;
    }
    assert(next == drop.size());
    points.resize(kept);
}

namespace {
bool sameBits(double a, double b) {
    return std::memcmp(&a, &b, sizeof a) == 0;
}
} // namespace

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

std::vector<std::uint32_t> mortonOrder(std::span<const glm::vec3> positions) {
    const auto count = static_cast<std::uint32_t>(positions.size());
    const Bounds bounds = boundsOf(positions);
    const glm::vec3 lo = bounds.lo;
    static constexpr float kLast = float((1u << kMortonBits) - 1); // the last cell along an axis
    const float extent = std::max(bounds.extent(), std::numeric_limits<float>::min());
    const float scale = kLast / extent;
    // A cell coordinate from [0, kLast]: the same as an unchecked conversion for a set the
    // refinement accepts; completeInput orders sets not yet checked, whose extent may pass the
    // largest float (a scale of 0, and ∞ · 0), or whose positions may not be finite (NaN: cell 0).
    const auto cell = [](float v) {
        return static_cast<std::uint32_t>(v >= 0.0f ? std::min(v, kLast) : 0.0f);
    };
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(count);
    for (std::uint32_t i = 0; i < count; ++i) {
        const glm::vec3 q = (positions[i] - lo) * scale;
        keyed[i] = {mortonCode(cell(q.x), cell(q.y), cell(q.z)), i};
    }
    std::sort(keyed.begin(), keyed.end());
    std::vector<std::uint32_t> order(count);
    for (std::uint32_t k = 0; k < count; ++k) order[k] = keyed[k].second;
    return order;
}

std::optional<CoincidentPair> findCoincident(const PointSet& points) {
    const std::vector<std::uint32_t> order = orderByPosition(points);
    std::optional<CoincidentPair> found;
    for (std::size_t k = 1; k < order.size(); ++k) {
        // The second member of a group: the group's first two (smallest indices) are order[k-1, k].
        const bool second = points.position[order[k]] == points.position[order[k - 1]] &&
                            (k == 1 || points.position[order[k - 2]] != points.position[order[k - 1]]);
        if (second && (!found || order[k - 1] < found->first)) found = CoincidentPair{order[k - 1], order[k]};
    }
    return found;
}

CoincidentRemoval removeCoincident(PointSet& points) {
    const std::size_t n = points.size();
    assert(!points.hasNormal() || points.normal.size() == n);
    assert(!points.hasRadius() || points.radius.size() == n);
    assert(!points.hasColour() || points.colour.size() == n);
    assert(!points.hasCrease() || points.crease.size() == n);
    for ([[maybe_unused]] const Attribute& a : points.attributes) assert(a.values.size() == n);
    const std::vector<std::uint32_t> order = orderByPosition(points);
    CoincidentRemoval removal;
    std::vector<std::uint8_t> keep(n, 1);
    for (std::size_t k = 1, first = 0; k < order.size(); ++k) {
        if (points.position[order[k]] != points.position[order[first]]) {
            first = k;
            continue;
        }
        const std::uint32_t i = order[k], kept = order[first];
        keep[i] = 0;
        ++removal.points;
        const bool differs =
            (points.hasNormal() && points.normal[i] != points.normal[kept]) ||
            (points.hasRadius() && points.radius[i] != points.radius[kept]) ||
            (points.hasColour() && points.colour[i] != points.colour[kept]) ||
            (points.hasCrease() && points.crease[i] != points.crease[kept]) ||
            std::any_of(points.attributes.begin(), points.attributes.end(),
                        [&](const Attribute& a) { return !sameBits(a.values[i], a.values[kept]); });
        removal.withOtherAttributes += differs ? 1 : 0;
    }
    std::vector<std::uint32_t> drop;
    for (std::size_t i = 0; i < n; ++i)
        if (!keep[i]) drop.push_back(static_cast<std::uint32_t>(i));
    removePoints(points, drop);
    return removal;
}

} // namespace pnsplat
