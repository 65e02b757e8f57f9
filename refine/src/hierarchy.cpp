// The bounding-sphere hierarchy over a static kd-tree of P0: paper section 7, ALGORITHM.md §7.2.
#include "pnsplat/refine/hierarchy.h"

#include <algorithm>
#include <cassert>
#include <limits>
#include <numeric>

namespace pnsplat {

namespace {
constexpr std::uint32_t kLeafSize = 8;
// Bounds are rounded up so that the float test |c - p_i|² <= (radius + bound_i)² in query() can
// never exclude a descendant the bound covers in exact arithmetic.
constexpr float kBoundRoundUp = 1.0f + 1.0f / (1u << 18);
} // namespace

PointHierarchy::PointHierarchy(std::span<const glm::vec3> roots) {
    const auto count = static_cast<std::uint32_t>(roots.size());
    rootOrder_.resize(count);
    std::iota(rootOrder_.begin(), rootOrder_.end(), 0u);
    levelEnd_.push_back(count);
    positions_ = roots;
    bounds_.assign(count, 0.0f);
    if (count > 0) {
        nodes_.reserve(2 * (count / kLeafSize + 1));
        build(0, count, roots);
        refit();
    }
}

std::uint32_t PointHierarchy::build(std::uint32_t begin, std::uint32_t end,
                                    std::span<const glm::vec3> roots) {
    const auto index = static_cast<std::uint32_t>(nodes_.size());
    nodes_.push_back(Node{glm::vec3(0.0f), glm::vec3(0.0f), begin, end, 0});
    if (end - begin <= kLeafSize) return index;
    glm::vec3 lo(std::numeric_limits<float>::max());
    glm::vec3 hi(std::numeric_limits<float>::lowest());
    for (std::uint32_t k = begin; k < end; ++k) {
        lo = glm::min(lo, roots[rootOrder_[k]]);
        hi = glm::max(hi, roots[rootOrder_[k]]);
    }
    const glm::vec3 extent = hi - lo;
    const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
    const std::uint32_t middle = begin + (end - begin) / 2;
    std::nth_element(rootOrder_.begin() + begin, rootOrder_.begin() + middle, rootOrder_.begin() + end,
                     [&](std::uint32_t a, std::uint32_t b) {
                         if (roots[a][axis] != roots[b][axis]) return roots[a][axis] < roots[b][axis];
                         return a < b;
                     });
    build(begin, middle, roots);
    const std::uint32_t right = build(middle, end, roots);
    nodes_[index].right = right;
    return index;
}

void PointHierarchy::addLevel(HugePageVector<std::uint32_t> childBegin) {
    assert(childBegin.size() == levelEnd_.back() + 1u);
    assert(childBegin.front() == levelEnd_.back());
    assert(std::is_sorted(childBegin.begin(), childBegin.end()));
    levelEnd_.push_back(childBegin.back());
    children_.push_back(std::move(childBegin));
    bounds_.resize(levelEnd_.back(), 0.0f);
}

void PointHierarchy::growTo(std::uint32_t points) {
    if (points > bounds_.size()) bounds_.resize(points, 0.0f);
}

void PointHierarchy::updateBounds(std::span<const glm::vec3> positions) {
    assert(positions.size() >= pointCount());
    const std::uint32_t lastLevel = levels() - 1;
    // Children have larger indices than their parents: one backward sweep sees every child first.
    for (std::uint32_t i = pointCount(); i-- > 0;) {
        float bound = 0.0f;
        for (std::uint32_t l = levelOf(i); l < lastLevel; ++l) {
            for (std::uint32_t c = children_[l][i]; c < children_[l][i + 1]; ++c)
                bound =
                    std::max(bound, (glm::length(positions[c] - positions[i]) + bounds_[c]) * kBoundRoundUp);
        }
        bounds_[i] = bound;
    }
    positions_ = positions;
    refit();
}

void PointHierarchy::refit() {
    // Nodes are stored in depth-first preorder, so children follow their parent: sweep backwards.
    for (std::size_t n = nodes_.size(); n-- > 0;) {
        Node& node = nodes_[n];
        if (node.right == 0) {
            node.lo = glm::vec3(std::numeric_limits<float>::max());
            node.hi = glm::vec3(std::numeric_limits<float>::lowest());
            for (std::uint32_t k = node.begin; k < node.end; ++k) {
                const std::uint32_t i = rootOrder_[k];
                node.lo = glm::min(node.lo, positions_[i] - bounds_[i]);
                node.hi = glm::max(node.hi, positions_[i] + bounds_[i]);
            }
        } else {
            const Node& left = nodes_[n + 1];
            const Node& right = nodes_[node.right];
            node.lo = glm::min(left.lo, right.lo);
            node.hi = glm::max(left.hi, right.hi);
        }
    }
}

} // namespace pnsplat
