// The spatial structure of the refinement: paper section 7 ("Closest points query"), SPEC.md 7.
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
    void addLevel(std::vector<std::uint32_t> childBegin);

    // Children of point i inserted during the transition l → l+1 (i must be in P(l)).
    std::uint32_t childBegin(std::uint32_t l, std::uint32_t i) const { return children_[l][i]; }
    std::uint32_t childEnd(std::uint32_t l, std::uint32_t i) const { return children_[l][i + 1]; }
    // The block (level of first appearance) of point i.
    std::uint32_t levelOf(std::uint32_t i) const;

    // Recomputes the bounding radii of all points bottom-up:
    //   bound_i = max(ownReach_i, max over children c of |p_c - p_i| + bound_c),
    // and refits the kd-tree. `ownReach` (one entry per point) is what a point may still reach
    // beyond its recorded children (the refinement passes the reach of the level being built).
    void updateBounds(std::span<const glm::vec3> positions, std::span<const float> ownReach);
    float bound(std::uint32_t i) const { return bound_[i]; }

    // Calls visit(i, squaredDistance) for every point i of P(levels()-1) whose bounding sphere
    // meets the ball (centre, radius): |centre - p_i| <= radius + bound_i. This includes every
    // point closer than `radius`. `stack` is the caller's scratch memory. Order: deterministic.
    template <typename Visit>
    void query(std::span<const glm::vec3> positions, glm::vec3 centre, float radius,
               std::vector<std::uint32_t>& stack, Visit&& visit) const;

private:
    struct Node {
        glm::vec3 lo, hi;         // box of the spheres of the node's roots
        std::uint32_t begin, end; // roots in rootOrder_[begin, end)
        std::uint32_t right;      // index of the right child, 0 for a leaf (left child = this + 1)
    };
    std::uint32_t build(std::uint32_t begin, std::uint32_t end, std::span<const glm::vec3> roots);
    void refit(std::span<const glm::vec3> positions);

    std::vector<Node> nodes_;
    std::vector<std::uint32_t> rootOrder_;
    std::vector<std::uint32_t> levelEnd_;                 // levelEnd_[l] = |P(l)|
    std::vector<std::vector<std::uint32_t>> children_;   // children_[l][i], i in P(l)
    std::vector<float> bound_;
};

template <typename Visit>
void PointHierarchy::query(std::span<const glm::vec3> positions, glm::vec3 centre, float radius,
                           std::vector<std::uint32_t>& stack, Visit&& visit) const {
    const std::uint32_t lastLevel = levels() - 1;
    stack.clear();
    // Nodes: explicit stack of node indices, then points: the same stack reused per root.
    std::uint32_t nodeStack[64];
    std::uint32_t nodeTop = 0;
    if (!nodes_.empty()) nodeStack[nodeTop++] = 0;
    while (nodeTop > 0) {
        const Node& node = nodes_[nodeStack[--nodeTop]];
        const glm::vec3 nearest = glm::clamp(centre, node.lo, node.hi);
        const glm::vec3 gap = centre - nearest;
        if (glm::dot(gap, gap) > radius * radius) continue;
        if (node.right != 0) {
            nodeStack[nodeTop++] = node.right;
            nodeStack[nodeTop++] = static_cast<std::uint32_t>(&node - nodes_.data()) + 1;
            continue;
        }
        for (std::uint32_t k = node.begin; k < node.end; ++k) {
            stack.push_back(rootOrder_[k]);
            while (!stack.empty()) {
                const std::uint32_t i = stack.back();
                stack.pop_back();
                const glm::vec3 d = positions[i] - centre;
                const float d2 = glm::dot(d, d);
                const float reach = radius + bound_[i];
                if (d2 > reach * reach) continue;
                visit(i, d2);
                for (std::uint32_t l = levelOf(i); l < lastLevel; ++l) {
                    const std::uint32_t* range = children_[l].data() + i;
                    for (std::uint32_t c = range[1]; c-- > range[0];) stack.push_back(c);
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
