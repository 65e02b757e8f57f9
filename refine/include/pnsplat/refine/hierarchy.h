// The spatial structure of the refinement: paper section 7 ("Closest points query"), ALGORITHM.md §7.2.
//
// A static kd-tree is built once over P0. Every refinement level l → l+1 appends the new points as
// one block, grouped by the point whose refinement inserted them (their parent), and records per
// point of P(l) the index range of its children. Children lie close to their parent, so with a
// bounding radius per point (covering the point and all its descendants) the points form a
// hierarchy of bounding spheres rooted at P0: a query at level l finds the P0 roots through the
// kd-tree, then walks down the children ranges. Memory: one offset per point and level plus one
// bound per point.
//
// Thread use: build and addLevel/updateBounds from one thread; query is const and may run on any
// number of threads at once between those calls.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <glm/vector_relational.hpp>

#include "pnsplat/refine/huge_pages.h"

namespace pnsplat {

class PointHierarchy {
  public:
    // Builds the kd-tree over the roots P0 = positions[0, rootCount).
    explicit PointHierarchy(std::span<const glm::vec3> roots);

    // Number of levels recorded: points of level `levels()-1` are the newest block.
    std::uint32_t levels() const { return static_cast<std::uint32_t>(levelEnd_.size()); }
    // P(l) is the index range [0, levelEnd(l)).
    std::uint32_t levelEnd(std::uint32_t l) const { return levelEnd_[l]; }
    std::uint32_t pointCount() const { return levelEnd_.back(); }

    // Records level l+1 = levels(): childBegin has |P(l)| + 1 entries, non-decreasing, with
    // childBegin[0] = |P(l)| and childBegin.back() = |P(l+1)|; the children of point i are
    // [childBegin[i], childBegin[i+1]).
    void addLevel(HugePageVector<std::uint32_t> childBegin);
    // Makes room for `points` points ahead of the addLevel that brings them (which would otherwise
    // grow its storage itself), so that another thread can take the page faults.
    void growTo(std::uint32_t points);

    // Children of point i inserted during the transition l → l+1 (i must be in P(l)).
    std::uint32_t childBegin(std::uint32_t l, std::uint32_t i) const { return children_[l][i]; }
    std::uint32_t childEnd(std::uint32_t l, std::uint32_t i) const { return children_[l][i + 1]; }
    // The block (level of first appearance) of point i.
    std::uint32_t levelOf(std::uint32_t i) const;

    // Recomputes the bounding radii of all points bottom-up,
    //   bound_i = max over children c of (|p_c - p_i| + bound_c), 0 without children,
    // and refits the kd-tree. `positions` holds at least pointCount() points; queries read them
    // until the next updateBounds, so they must stay valid and unchanged until then.
    void updateBounds(std::span<const glm::vec3> positions);
    float bound(std::uint32_t i) const { return bounds_[i]; }

    // Calls visit(i, squaredDistance) for every point i of P(levels()-1) whose bounding sphere
    // meets the ball (centre, radius): |centre - p_i| <= radius + bound_i. This includes every
    // point closer than `radius`. Positions are those given to the last updateBounds (or to the
    // constructor before it). `stack` is the caller's scratch memory. Order: deterministic.
    struct StackEntry {
        std::uint32_t index, level;
        float distance2;
    };
    template <typename Visit>
    void query(glm::vec3 centre, float radius, std::vector<StackEntry>& stack, Visit&& visit) const {
        queryBox(centre, centre, radius, stack, visit);
    }
    // The same for the box [lo, hi] grown by `margin`: visit(i, d2) for every point whose sphere
    // meets it, d2 the squared distance from p_i to the box [lo, hi]. This includes every point
    // within `margin` of the box. Precondition: lo <= hi.
    template <typename Visit>
    void queryBox(glm::vec3 lo, glm::vec3 hi, float margin, std::vector<StackEntry>& stack,
                  Visit&& visit) const;

  private:
    struct Node {
        glm::vec3 lo, hi;         // box of the spheres of the node's roots
        std::uint32_t begin, end; // roots in rootOrder_[begin, end)
        std::uint32_t right;      // index of the right child, 0 for a leaf (left child = this + 1)
    };
    std::uint32_t build(std::uint32_t begin, std::uint32_t end, std::span<const glm::vec3> roots);
    void refit();

    std::vector<Node> nodes_;
    std::vector<std::uint32_t> rootOrder_;
    std::vector<std::uint32_t> levelEnd_;                 // levelEnd_[l] = |P(l)|
    std::vector<HugePageVector<std::uint32_t>> children_; // children_[l][i], i in P(l)
    std::span<const glm::vec3> positions_; // given to the last updateBounds (or the constructor)
    HugePageVector<float> bounds_;         // bound_i
};

template <typename Visit>
void PointHierarchy::queryBox(glm::vec3 lo, glm::vec3 hi, float margin, std::vector<StackEntry>& stack,
                              Visit&& visit) const {
    const std::uint32_t lastLevel = levels() - 1;
    // A sphere (p_i, bound_i) meets the grown box when dist(p_i, [lo, hi]) <= margin + bound_i.
    const auto reaches = [&](std::uint32_t i, float& d2) {
        const glm::vec3 centre = positions_[i];
        const glm::vec3 d = centre - glm::clamp(centre, lo, hi);
        d2 = glm::dot(d, d);
        const float reach = margin + bounds_[i];
        return d2 <= reach * reach;
    };
    const glm::vec3 grownLo = lo - margin, grownHi = hi + margin;
    std::uint32_t nodeStack[64];
    std::uint32_t nodeTop = 0;
    if (!nodes_.empty()) nodeStack[nodeTop++] = 0;
    while (nodeTop > 0) {
        const std::uint32_t n = nodeStack[--nodeTop];
        const Node& node = nodes_[n];
        if (glm::any(glm::lessThan(node.hi, grownLo)) || glm::any(glm::greaterThan(node.lo, grownHi)))
            continue;
        if (node.right != 0) {
            nodeStack[nodeTop++] = node.right;
            nodeStack[nodeTop++] = n + 1;
            continue;
        }
        for (std::uint32_t k = node.begin; k < node.end; ++k) {
            float d2;
            if (!reaches(rootOrder_[k], d2)) continue;
            stack.clear();
            stack.push_back(StackEntry{rootOrder_[k], 0, d2});
            while (!stack.empty()) {
                const StackEntry e = stack.back();
                stack.pop_back();
                visit(e.index, e.distance2);
                for (std::uint32_t l = e.level; l < lastLevel; ++l) {
                    const std::uint32_t* range = children_[l].data() + e.index;
                    for (std::uint32_t c = range[1]; c-- > range[0];) {
                        float c2;
                        if (reaches(c, c2)) stack.push_back(StackEntry{c, l + 1, c2});
                    }
                }
            }
        }
    }
}

inline std::uint32_t PointHierarchy::levelOf(std::uint32_t i) const {
    std::uint32_t l = 0;
    while (i >= levelEnd_[l]) ++l;
    return l;
}

} // namespace pnsplat
