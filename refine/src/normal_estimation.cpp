// Normal estimation by local PCA and minimum-spanning-tree orientation (ALGORITHM.md §9.2).
#include "pnsplat/refine/normal_estimation.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <queue>
#include <span>
#include <vector>

#include <fmt/core.h>
#include <glm/geometric.hpp>

#include "kd_tree.h"
#include "pnsplat/refine/pn_triangle.h"
#include "pnsplat/refine/worker_pool.h"

namespace pnsplat {

SmallestEigen smallestEigenvector(const double (&m)[3][3]) {
    double a[3][3], v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) a[r][c] = r <= c ? m[r][c] : m[c][r];
    constexpr int kMaxSweeps = 32; // convergence is quadratic: a handful of sweeps in practice
    for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
        const double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        const double diagonal = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if (!(off > 1e-30 * diagonal)) break;
        for (const auto [p, q] : {std::array{0, 1}, std::array{0, 2}, std::array{1, 2}}) {
            if (a[p][q] == 0.0) continue;
            // The rotation J (J_pp = J_qq = c, J_pq = s, J_qp = -s) with (Jᵀ A J)_pq = 0:
            // t = s/c the smaller root of t² + 2θt - 1 = 0, θ = (a_qq - a_pp) / (2 a_pq).
            const double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            const double t = std::copysign(1.0, theta) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
            const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
            // A ← JᵀAJ and V ← VJ, written out: J changes columns p and q of what it multiplies on
            // the right, rows p and q on the left; the other entries stay.
            for (int r = 0; r < 3; ++r) {
                const double arp = a[r][p], arq = a[r][q];
                a[r][p] = arp * c + arq * -s;
                a[r][q] = arp * s + arq * c;
                const double vrp = v[r][p], vrq = v[r][q];
                v[r][p] = vrp * c + vrq * -s;
                v[r][q] = vrp * s + vrq * c;
            }
            for (int k = 0; k < 3; ++k) {
                const double apk = a[p][k], aqk = a[q][k];
                a[p][k] = c * apk + -s * aqk;
                a[q][k] = s * apk + c * aqk;
            }
            a[p][q] = a[q][p] = 0.0; // exactly, as the rotation was chosen
        }
    }
    std::array<int, 3> order{0, 1, 2};
    std::sort(order.begin(), order.end(), [&](int x, int y) { return a[x][x] < a[y][y]; });
    const int smallest = order[0];
    SmallestEigen result;
    result.vector = glm::normalize(glm::dvec3(v[0][smallest], v[1][smallest], v[2][smallest]));
    for (int k = 0; k < 3; ++k) result.values[k] = a[order[k]][order[k]];
    result.largest = glm::normalize(glm::dvec3(v[0][order[2]], v[1][order[2]], v[2][order[2]]));
    return result;
}

namespace {

// The visibility vote (orientByVisibility): a point's disk reaches its kSplatNearest-th nearest
// point; each side of it casts kSideRays rays (sideRays); regions are cut at spanning-tree edges of
// weight kRegionWeight or more, and decided by net votes of at least kRegionVotes and
// kRegionVoteShare times their points. Measured on ../shared/data (ALGORITHM.md §9.2).
constexpr std::size_t kSplatNearest = 6;
constexpr int kSideRays = 5;
constexpr double kRegionWeight = 0.5;
constexpr std::int64_t kRegionVotes = 3;
constexpr double kRegionVoteShare = 0.1;
// The neighbours' vote (agreeWithNeighbours): weak below a share kWeakAgreement of its weight; a
// point then faces away from its neighbours' centroid when it lies kTipOffset splat radii or more
// from their plane, on a part that fits no plane or where at least kTipOpenRays of the rays it
// casts on that side escape (orientByVisibility); kAgreementRounds rounds at most.
constexpr double kWeakAgreement = 0.5;
constexpr double kTipOffset = 0.15;
constexpr int kTipOpenRays = 1;
constexpr unsigned kAgreementRounds = 3;
// A neighbourhood that fits no plane (fitPlane): its smallest variance above kNoPlane times the
// middle one; a tube when its largest is above kTube times the middle one.
constexpr double kNoPlane = 0.5;
constexpr double kTube = 5.0;
// A crossing from one sheet to the next (acrossSheets).
constexpr float kParallelSheets = 0.9f;
constexpr float kAcrossSheets = 0.5f;

// Whether a's component starts before b's: larger z, then y, then x (distinct positions).
bool startsBefore(glm::vec3 a, glm::vec3 b) {
    if (a.z != b.z) return a.z > b.z;
    if (a.y != b.y) return a.y > b.y;
    return a.x > b.x;
}

// The weight of the graph edge (a, b) for the orientation's spanning tree: Hoppe's 1 - |n_a · n_b|
// plus how steeply the edge leaves the two tangent planes, |d · n_a| + |d · n_b| for the unit
// direction d from a to b. Choice (beyond Hoppe): with his weight alone, two points facing each
// other across a thin wall (antiparallel normals) or along a sharp crease look as flat as any, and
// the propagation crosses there early. Measured on ../shared/data's sparse inputs, the share of
// normals that end up flipped falls from 18 % to 0 on the rockerarm, 42 % to 0.13 % on the
// fandisk and 2.5 % to 0.5 % on the random bunny (estimateNormals' tests).
double orientationWeight(glm::vec3 a, glm::vec3 na, glm::vec3 b, glm::vec3 nb) {
    const glm::dvec3 n0(na), n1(nb), d = glm::dvec3(b) - glm::dvec3(a);
    const double length = glm::length(d);
    const double steep =
        length > 0.0 ? (std::abs(glm::dot(d, n0)) + std::abs(glm::dot(d, n1))) / length : 0.0;
    return 1.0 - std::abs(glm::dot(n0, n1)) + steep;
}

// Whether the edge (a, b) crosses from one sheet to the next rather than running along one: the
// two tangent planes are parallel (|n_a · n_b| above kParallelSheets) and the edge leaves both
// (|d · n| above kAcrossSheets for its unit direction d). Along any line, the boundary of a solid
// is crossed alternately inwards and outwards, so two parallel sheets one after the other (the
// two faces of a thin part, or facing sides across a narrow gap) face opposite ways: such an edge
// relates the two normals with the opposite sign. Choice of the bounds (kParallelSheets,
// kAcrossSheets), measured on 20 random 3,500-point subsets of each of ../shared/data's
// references: 0.5 lowers the mean share of inward normals on the lion from 0.76 to 0.66 % and
// changes the others by 0.05 % or less, and on a slab 0.04 thick sampled at a spacing of 0.05
// from 40 to 32 %; lower bounds take edges of curved parts for crossings (0.3: up to 1.6 % inward
// on a subset, 0.15: 4.4 %).
bool acrossSheets(glm::vec3 a, glm::vec3 na, glm::vec3 b, glm::vec3 nb) {
    const glm::vec3 d = b - a;
    const float length = glm::length(d);
    return length > 0.0f && std::abs(glm::dot(na, nb)) > kParallelSheets &&
           std::abs(glm::dot(d, na)) > kAcrossSheets * length &&
           std::abs(glm::dot(d, nb)) > kAcrossSheets * length;
}

// An edge of the spanning tree's frontier; the smallest weight first, ties by the indices.
struct FrontierEdge {
    double weight;
    std::uint32_t to, from;
    bool operator>(const FrontierEdge& o) const {
        if (weight != o.weight) return weight > o.weight;
        if (to != o.to) return to > o.to;
        return from > o.from;
    }
};

// The symmetric k-nearest-neighbour graph of the orientation: i ~ j when either is among the
// other's k nearest. `nearest` holds k indices per point (a row may repeat the point itself where
// fewer were found; the propagation never crosses such an edge).
class NeighbourGraph {
  public:
    NeighbourGraph(std::vector<std::uint32_t> nearest, std::size_t k)
        : nearest_(std::move(nearest)), k_(k), reverseBegin_(nearest_.size() / k + 1, 0),
          reverse_(nearest_.size()) {
        for (const std::uint32_t j : nearest_) ++reverseBegin_[j + 1];
        std::partial_sum(reverseBegin_.begin(), reverseBegin_.end(), reverseBegin_.begin());
        std::vector<std::size_t> fill(reverseBegin_.begin(), reverseBegin_.end() - 1);
        for (std::size_t e = 0; e < nearest_.size(); ++e)
            reverse_[fill[nearest_[e]]++] = static_cast<std::uint32_t>(e / k_);
    }

    // Calls visit(j) for each neighbour j of i: i's own nearest, then the points that have i among
    // theirs.
    template <typename Visit>
    void forEach(std::uint32_t i, const Visit& visit) const {
        forEachNearest(i, visit);
        for (std::size_t e = reverseBegin_[i]; e < reverseBegin_[i + 1]; ++e) visit(reverse_[e]);
    }
    // The same for i's own nearest only.
    template <typename Visit>
    void forEachNearest(std::uint32_t i, const Visit& visit) const {
        for (std::size_t r = 0; r < k_; ++r) visit(nearest_[std::size_t{i} * k_ + r]);
    }

  private:
    std::vector<std::uint32_t> nearest_;
    std::size_t k_;
    std::vector<std::size_t> reverseBegin_;
    std::vector<std::uint32_t> reverse_;
};

// No edge pushed yet (propagateOrientation's `lightest`): heavier than any edge of finite weight.
constexpr FrontierEdge kNoEdge{std::numeric_limits<double>::infinity(), 0, 0};

// Prim's propagation along a minimum spanning forest: from the `seeds` (reached already), the
// points not yet `reached` that the graph connects to them are reached by the lightest edge of
// the frontier first (orientationWeight), and each takes the sign that agrees with the point it is
// reached from, the opposite sign across two sheets when `sheets` is set (acrossSheets: for
// estimated normals, whose sign is unknown; given normals keep Hoppe's rule). When `tree` is
// given, the edges that reach a point are appended to it in the order they are taken.
// `lightest` (one entry per point) holds the lightest edge pushed towards each point, kNoEdge where
// none was: an edge no lighter never comes first (the frontier's top is the lightest edge of some
// point), so it is not pushed, and the same edges are taken in the same order as with every edge
// pushed, from a smaller heap. Every point that gets an entry is reached before the call returns,
// so the points still unreached keep kNoEdge: one buffer of kNoEdge serves calls that only add to
// `reached` (one a connected part), not calls after a point was made unreached again.
void propagateOrientation(const NeighbourGraph& graph, std::span<const glm::vec3> position,
                          std::span<glm::vec3> normal, std::vector<std::uint8_t>& reached,
                          std::span<const std::uint32_t> seeds, std::vector<FrontierEdge>& lightest,
                          std::vector<FrontierEdge>* tree = nullptr, bool sheets = false) {
    assert(lightest.size() == position.size());
    std::priority_queue<FrontierEdge, std::vector<FrontierEdge>, std::greater<>> frontier;
    const auto extend = [&](std::uint32_t from) {
        graph.forEach(from, [&](std::uint32_t to) {
            if (reached[to]) return;
            const FrontierEdge edge{orientationWeight(position[from], normal[from], position[to], normal[to]),
                                    to, from};
            // Finite: positions are checked finite and normals unit (a weight lies in [0, 3]).
            assert(std::isfinite(edge.weight));
            if (!(lightest[to] > edge)) return;
            lightest[to] = edge;
            frontier.push(edge);
        });
    };
    for (const std::uint32_t seed : seeds) extend(seed);
    while (!frontier.empty()) {
        const FrontierEdge edge = frontier.top();
        frontier.pop();
        if (reached[edge.to]) continue;
        reached[edge.to] = 1;
        const bool opposite = sheets && acrossSheets(position[edge.from], normal[edge.from],
                                                     position[edge.to], normal[edge.to]);
        if ((glm::dot(normal[edge.from], normal[edge.to]) < 0.0f) != opposite)
            normal[edge.to] = -normal[edge.to];
        if (tree) tree->push_back(edge);
        extend(edge.to);
    }
}

// The points' disks (centre, unit normal, radius) in a bounding-volume hierarchy, for the rays of
// the orientation's visibility vote. Built once, the root's two halves on the pool's workers (the
// same nodes in the same places for any thread count); escaping() may then be called from any
// thread.
class SplatRays {
  public:
    SplatRays(std::span<const glm::vec3> centre, std::span<const glm::vec3> normal,
              std::span<const float> radius, WorkerPool& pool)
        : centre_(centre), order_(centre.size()) {
        // A disk's box: along axis a it reaches r·sqrt(1 - m_a²) from its centre (the largest a
        // component of a unit vector across m), so that its slabs hold less empty space around
        // disks tilted to the axes than c ± r did. Widened by 1e-3 r and by
        // `slack`, far above the rounding of the box's edges and of a ray's distances (a few ulps of
        // the largest coordinate and of the longest ray, which the diagonal bounds), so that a ray
        // the disk test takes meets every box around the disk.
        {
            std::vector<glm::vec3> extent(centre.size()); // of each disk's box from its centre
            const Bounds bounds = boundsOf(centre);
            const glm::vec3 far = glm::max(glm::abs(bounds.lo), glm::abs(bounds.hi));
            const float slack = centre.empty() ? 0.0f
                                               : 64.0f * std::numeric_limits<float>::epsilon() *
                                                     (std::max({far.x, far.y, far.z}) + bounds.diagonal());
            for (std::size_t j = 0; j < centre.size(); ++j)
                for (int a = 0; a < 3; ++a) {
                    const float across = std::sqrt(std::max(0.0f, 1.0f - normal[j][a] * normal[j][a]));
                    extent[j][a] = radius[j] * (across + 1e-3f) + slack;
                }
            std::iota(order_.begin(), order_.end(), 0u);
            nodes_.emplace_back();
            const std::uint32_t middle =
                split(nodes_[0], 0, static_cast<std::uint32_t>(order_.size()), extent);
            // An inner root (more than a leaf's points): the halves, each in a list of its own, then
            // after the root.
            if (order_.size() > kLeafSize) {
                std::array<std::vector<Node>, 2> halves;
                const std::array<std::uint32_t, 3> ends{0, middle, static_cast<std::uint32_t>(order_.size())};
                parallelForRanges(pool, 2, 1, [&](std::size_t begin, std::size_t end, unsigned) {
                    for (std::size_t h = begin; h < end; ++h) {
                        halves[h].emplace_back();
                        build(halves[h], 0, ends[h], ends[h + 1], extent);
                    }
                });
                // As one build in a row would place them: the halves' roots at 1 and 2, then the
                // first half's other nodes, then the second's.
                nodes_[0].first = 1;
                nodes_.resize(1 + halves[0].size() + halves[1].size());
                const std::array<std::uint32_t, 2> rest{3, static_cast<std::uint32_t>(2 + halves[0].size())};
                for (std::size_t h = 0; h < 2; ++h)
                    for (std::size_t e = 0; e < halves[h].size(); ++e) {
                        Node node = halves[h][e];
                        if (node.count == 0) node.first += rest[h] - 1; // local index 1 is at rest[h]
                        nodes_[e == 0 ? 1 + h : rest[h] + e - 1] = node;
                    }
            }
        } // the extents go before the disks come
        // The disks in the leaves' order, each whole in one place: a leaf reads them in a row.
        disks_.resize(order_.size());
        for (std::size_t e = 0; e < order_.size(); ++e) {
            const std::uint32_t j = order_[e];
            disks_[e] = Disk{centre[j], normal[j], radius[j] * radius[j], j};
        }
    }

    // The points, in the order of the hierarchy's leaves.
    std::span<const std::uint32_t> order() const { return order_; }

    // How many of the rays from centre[i] along `rays` (unit) pass every other disk. A disk a ray
    // meets nearer than kGrazeBase + kGrazeTilt·sin(angle of the ray to the disk's normal) times
    // the distance of the disk's centre from its start does not count: on the curved surface
    // around i, the ray leaving i grazes the disks of i's neighbours (tilted against it as the
    // surface turns) at about the angle's sine times half that distance; a sheet across a thin
    // part, parallel to i's own, counts at any distance. The rays walk the hierarchy together: a
    // node is entered with the rays that met every box above it and still escape, and each ray
    // meets the nodes and disks it would meet alone: one walk instead of one a ray, which waits
    // on memory for each node it reads (a 1.3 million point scan's disks and nodes take 50 MB).
    template <std::size_t N>
    int escaping(std::uint32_t i, const std::array<glm::vec3, N>& rays) const {
        static_assert(N <= 8);
        const glm::vec3 o = centre_[i];
        std::array<glm::vec3, N> inverse;
        for (std::size_t k = 0; k < N; ++k)
            for (int a = 0; a < 3; ++a) inverse[k][a] = 1.0f / (rays[k][a] != 0.0f ? rays[k][a] : 1e-30f);
        unsigned open = (1u << N) - 1; // the rays that met no disk yet
        std::array<std::pair<std::uint32_t, unsigned>, 64> stack;
        std::size_t top = 0;
        stack[top++] = {0, open};
        while (top > 0) {
            const auto [index, entered] = stack[--top];
            const Node& node = nodes_[index];
            assert(top + 2 <= stack.size()); // the depth is below 32 for 2^32 points
            unsigned met = 0;
            for (unsigned left = entered & open; left != 0; left &= left - 1) {
                const int k = std::countr_zero(left);
                float enter = 0.0f, leave = std::numeric_limits<float>::infinity();
                for (int a = 0; a < 3; ++a) {
                    const float t0 = (node.lo[a] - o[a]) * inverse[k][a],
                                t1 = (node.hi[a] - o[a]) * inverse[k][a];
                    enter = std::max(enter, std::min(t0, t1));
                    leave = std::min(leave, std::max(t0, t1));
                }
                met |= enter <= leave ? 1u << k : 0u;
            }
            if (met == 0) continue;
            if (node.count == 0) {
                stack[top++] = {node.first, met};
                stack[top++] = {node.first + 1, met};
                continue;
            }
            for (std::uint32_t e = node.first; e < node.first + node.count; ++e) {
                const Disk& disk = disks_[e];
                if (disk.index == i) continue;
                const glm::vec3 c = disk.centre, m = disk.normal;
                for (unsigned left = met & open; left != 0; left &= left - 1) {
                    const int k = std::countr_zero(left);
                    const glm::vec3 u = rays[k];
                    const float facing = glm::dot(u, m);
                    if (facing == 0.0f) continue;
                    const float t = glm::dot(c - o, m) / facing;
                    // The disk is met beyond the graze distance, which is never negative: the
                    // cheaper tests first (t ahead of the start, inside the disk), the distance's
                    // roots last.
                    if (!(t > 0.0f)) continue;
                    const glm::vec3 h = o + t * u - c;
                    if (!(glm::dot(h, h) <= disk.radius2)) continue;
                    const float graze = kGrazeBase + kGrazeTilt * glm::length(glm::cross(u, m));
                    if (t > graze * glm::length(c - o)) open &= ~(1u << k);
                }
            }
            if (open == 0) return 0;
        }
        return std::popcount(open);
    }

  private:
    // Disks a leaf: 16 against 4 took the normal estimation of a 1.3 million point scan from
    // 11.6-11.9 to 10.5-10.8 s (fewer nodes to wait for; 8: 11.2, 32: 11.2-11.3).
    static constexpr std::uint32_t kLeafSize = 16;
    static constexpr float kGrazeBase = 0.2f, kGrazeTilt = 0.5f;
    // A node's box; an inner node (count 0) has its two children at first and first + 1, a leaf
    // its disks at order_[first, first + count).
    struct Node {
        glm::vec3 lo, hi;
        std::uint32_t first, count;
    };

    // Sets `node` to order_[begin, end) in the box of their disks' boxes (`extent` from each
    // centre): a leaf where they are few, else split at the median of the centres along their box's
    // longest side (returned; its children are not placed yet).
    std::uint32_t split(Node& node, std::uint32_t begin, std::uint32_t end,
                        std::span<const glm::vec3> extent) {
        glm::vec3 lo(std::numeric_limits<float>::infinity()), hi(-lo), centreLo = lo, centreHi = hi;
        for (std::uint32_t e = begin; e < end; ++e) {
            const glm::vec3 c = centre_[order_[e]];
            lo = glm::min(lo, c - extent[order_[e]]);
            hi = glm::max(hi, c + extent[order_[e]]);
            centreLo = glm::min(centreLo, c);
            centreHi = glm::max(centreHi, c);
        }
        node.lo = lo;
        node.hi = hi;
        node.first = begin;
        node.count = end - begin;
        if (end - begin <= kLeafSize) return end;
        const glm::vec3 side = centreHi - centreLo;
        const int axis = side.x >= side.y && side.x >= side.z ? 0 : side.y >= side.z ? 1 : 2;
        const std::uint32_t middle = begin + (end - begin) / 2;
        std::nth_element(order_.begin() + begin, order_.begin() + middle, order_.begin() + end,
                         [&](std::uint32_t a, std::uint32_t b) {
                             const float ca = centre_[a][axis], cb = centre_[b][axis];
                             return ca != cb ? ca < cb : a < b;
                         });
        node.count = 0;
        return middle;
    }

    // Fills nodes[index] and its subtree with order_[begin, end) (split), children pairs appended
    // to `nodes` as they are made.
    void build(std::vector<Node>& nodes, std::uint32_t index, std::uint32_t begin, std::uint32_t end,
               std::span<const glm::vec3> extent) {
        const std::uint32_t middle = split(nodes[index], begin, end, extent);
        if (nodes[index].count != 0) return;
        const auto children = static_cast<std::uint32_t>(nodes.size());
        nodes[index].first = children;
        nodes.resize(nodes.size() + 2);
        build(nodes, children, begin, middle, extent);
        build(nodes, children + 1, middle, end, extent);
    }

    struct Disk {
        glm::vec3 centre, normal;
        float radius2; // the radius squared
        std::uint32_t index;
    };

    std::span<const glm::vec3> centre_;
    std::vector<std::uint32_t> order_;
    std::vector<Node> nodes_;
    std::vector<Disk> disks_; // order_'s disks
};

// The k nearest points (k <= kNormalNearest) of each of `positions`, the point itself left out, by
// `tree` over them: k per point, on the pool's workers. A row found short (only where squared
// distances overflow) is completed with the point itself, which the graph ignores. Each point's
// `visit(i, row, found)` runs on its worker once its row is found.
template <typename T, typename Visit>
std::vector<std::uint32_t> nearestPoints(const KdTreeIn<T>& tree, std::span<const glm::vec3> positions,
                                         std::size_t k, WorkerPool& pool, const Visit& visit) {
    assert(k <= kNormalNearest);
    std::vector<std::uint32_t> nearest(positions.size() * k);
    constexpr std::size_t kBatch = 256;
    parallelForRanges(pool, positions.size(), kBatch, [&](std::size_t begin, std::size_t end, unsigned) {
        std::array<std::uint32_t, kNormalNearest + 1> index;
        std::array<T, kNormalNearest + 1> distance2;
        for (std::size_t i = begin; i < end; ++i) {
            const glm::vec<3, T> query(positions[i]);
            const std::size_t found = tree.knnSearch(&query.x, k + 1, index.data(), distance2.data());
            std::uint32_t* row = &nearest[i * k];
            std::size_t stored = 0;
            for (std::size_t r = 0; r < found && stored < k; ++r)
                if (index[r] != i) row[stored++] = index[r];
            visit(i, row, stored);
            for (std::size_t r = stored; r < k; ++r) row[r] = static_cast<std::uint32_t>(i);
        }
    });
    return nearest;
}

// The kSideRays directions a point's side facing n casts its rays along: n, and four tilted from
// it by atan(1/2) (27°) towards ±t1 and ±t2 of a frame chosen from n alone.
std::array<glm::vec3, kSideRays> sideRays(glm::vec3 n) {
    const glm::vec3 axis = std::abs(n.x) < 0.6f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
    const glm::vec3 t1 = glm::normalize(glm::cross(n, axis)), t2 = glm::cross(n, t1);
    return {n, glm::normalize(n + 0.5f * t1), glm::normalize(n + 0.5f * t2), glm::normalize(n - 0.5f * t1),
            glm::normalize(n - 0.5f * t2)};
}

// The regions of the spanning forest `tree` (edges in the order reached, a start as an edge from
// itself) cut at its edges of weight kRegionWeight or more: within one, the propagation crossed no
// wall or crease, so its normals agree. Each region is turned as the visibility of its points
// votes: each of a point's sideRays votes for its normal when the ray along it escapes the disks
// of all the other points (SplatRays) and the opposite ray does not, and against it in the
// opposite case: outward rays leave a closed surface, inward ones meet its other side. A region
// whose votes sum to at least kRegionVotes and kRegionVoteShare times its points, in either
// direction, is decided by them; the other regions of a connected part with a decided one are
// reached again from the decided ones by propagateOrientation (a region deep in a concavity sees
// little). A part with no decided region keeps the orientation of its start. Returns where
// agreeWithNeighbours' tip rule may decide: 1 for a point lying kTipOffset splat radii or more
// from its neighbours' plane that fits no plane (`across`) or of whose sideRays, cast along its
// normal on the side away from their `centroid`, at least kTipOpenRays escape; 0 elsewhere.
std::vector<std::uint8_t> orientByVisibility(const NeighbourGraph& graph, std::span<const glm::vec3> position,
                                             std::span<const glm::vec3> centroid,
                                             std::span<const std::uint8_t> across,
                                             std::span<glm::vec3> normal, std::span<const float> splatRadius,
                                             std::span<const FrontierEdge> tree, WorkerPool& pool) {
    const std::size_t m = position.size();
    std::vector<std::uint32_t> part(m), region(m);
    for (const FrontierEdge& e : tree) {
        const bool start = e.to == e.from;
        part[e.to] = start ? e.to : part[e.from];
        region[e.to] = start || e.weight >= kRegionWeight ? e.to : region[e.from];
    }
    std::vector<std::int8_t> vote(m);
    std::vector<std::uint8_t> tip(m);
    {
        const SplatRays rays(position, normal, splatRadius, pool);
        // The points in the hierarchy's order: one after the other, rays start near each other
        // and walk the same nodes, which stay in cache (a 1.3 million point scan written level
        // after level by a refinement: the rays 1.3 times faster than in the file's order).
        parallelForRanges(pool, m, 256, [&](std::size_t begin, std::size_t end, unsigned) {
            for (std::size_t e = begin; e < end; ++e) {
                const std::uint32_t p = rays.order()[e];
                const std::size_t i = p;
                // The rays that escape along the normal's side and along the other. sideRays(-n) are
                // the rays -u of sideRays(n), in another order (negation is exact at every step), so the tip
                // rule below reads these counts instead of casting its rays again.
                std::array<glm::vec3, kSideRays> side = sideRays(normal[i]), opposite;
                for (std::size_t k = 0; k < kSideRays; ++k) opposite[k] = -side[k];
                const int along = rays.escaping(p, side), against = rays.escaping(p, opposite);
                vote[i] = static_cast<std::int8_t>(along - against);
                // The offset from the neighbours' plane; its size does not depend on the normal's sign.
                const double off =
                    glm::dot(glm::dvec3(normal[i]), glm::dvec3(position[i]) - glm::dvec3(centroid[i]));
                const double r = splatRadius[i];
                if (std::abs(off) < kTipOffset * r || !(r > 0.0)) continue;
                const int open =
                    off > 0.0 ? along : against; // of sideRays(±normal[i]), away from the centroid
                tip[i] = across[i] || open >= kTipOpenRays ? 1 : 0;
            }
        });
    }
    std::vector<std::int64_t> votes(m, 0), size(m, 0);
    for (std::size_t i = 0; i < m; ++i) {
        votes[region[i]] += vote[i];
        ++size[region[i]];
    }
    const auto decided = [&](std::uint32_t r) {
        const std::int64_t v = std::abs(votes[r]);
        return v >= kRegionVotes && static_cast<double>(v) >= kRegionVoteShare * static_cast<double>(size[r]);
    };
    std::vector<std::uint8_t> partDecided(m, 0), reached(m, 1);
    for (std::size_t i = 0; i < m; ++i)
        if (region[i] == i && decided(static_cast<std::uint32_t>(i))) partDecided[part[i]] = 1;
    std::vector<std::uint32_t> seeds;
    for (std::size_t i = 0; i < m; ++i) {
        const std::uint32_t r = region[i];
        if (decided(r)) {
            if (votes[r] < 0) normal[i] = -normal[i];
            seeds.push_back(static_cast<std::uint32_t>(i));
        } else if (partDecided[part[i]]) {
            reached[i] = 0;
        }
    }
    std::vector<FrontierEdge> lightest(m, kNoEdge);
    propagateOrientation(graph, position, normal, reached, seeds, lightest, nullptr, true);
    return tip;
}

// Turns each normal that its neighbours outvote: the graph's neighbours j of i vote with
// n_i · n_j, weighted by how flat the edge lies in j's tangent plane, 1 - |d · n_j| (d the edge's
// unit direction), so that the other side of a thin wall, facing away, counts little. Where the
// vote is weak (below kWeakAgreement of its weight) and `tip` says so (orientByVisibility), i
// faces away from the `centroid` of its fit instead: at the tip of a thin part, or on a sheet
// thinner than the spacing whose fit mixes both sides, the point lies outward of the centroid.
// `tip` holds where i lies off its neighbours' plane by kTipOffset splat radii or more, and looks
// out on that side (at least kTipOpenRays of the sideRays cast away from the centroid along i's
// normal escape) or fits no plane (normalOf: its normal is already the direction away from the
// centroid). In a concave spot the point lies inward of the centroid and the choice would be
// wrong: where every such ray meets the surface, i lies in a hollow (an ear's, a fold's), and the
// neighbours' vote, weak as it is, decides. All points are decided from the same normals, in
// rounds, until none turns or kAgreementRounds have run: each point's vote reads only the normals
// of the round's start, so the pool's workers share a round's points (the same bits).
void agreeWithNeighbours(const NeighbourGraph& graph, std::span<const glm::vec3> position,
                         std::span<const glm::vec3> centroid, std::span<const std::uint8_t> tip,
                         std::span<glm::vec3> normal, WorkerPool& pool) {
    const std::size_t m = position.size();
    std::vector<std::uint8_t> turn(m);
    for (unsigned round = 0; round < kAgreementRounds; ++round) {
        parallelForRanges(pool, m, 1024, [&](std::size_t begin, std::size_t end, unsigned) {
            for (std::size_t i = begin; i < end; ++i) {
                const glm::dvec3 x(position[i]), n(normal[i]);
                double vote = 0.0, weight = 0.0;
                graph.forEach(static_cast<std::uint32_t>(i), [&](std::uint32_t j) {
                    if (j == i) return;
                    const glm::dvec3 d = glm::normalize(glm::dvec3(position[j]) - x), nj(normal[j]);
                    const double flat = 1.0 - std::abs(glm::dot(d, nj));
                    const double sign =
                        acrossSheets(position[i], normal[i], position[j], normal[j]) ? -1.0 : 1.0;
                    vote += sign * flat * glm::dot(n, nj);
                    weight += flat;
                });
                if (std::abs(vote) < kWeakAgreement * weight && tip[i])
                    vote = glm::dot(n, x - glm::dvec3(centroid[i]));
                turn[i] = vote < 0.0 ? 1 : 0;
            }
        });
        if (std::ranges::find(turn, std::uint8_t{1}) == turn.end()) break;
        for (std::size_t i = 0; i < m; ++i)
            if (turn[i]) normal[i] = -normal[i];
    }
}

// Fails for fewer than 3 points or a non-finite position.
Result<void> checkPositions(const PointSet& points) {
    const std::size_t count = points.size();
    if (count < 3)
        return Error{fmt::format("{} point(s): normals need at least 3 points to fit a plane", count)};
    for (std::size_t i = 0; i < count; ++i) {
        const glm::vec3 x = points.position[i];
        if (!std::isfinite(x.x) || !std::isfinite(x.y) || !std::isfinite(x.z))
            return Error{fmt::format("point {} has a non-finite position: no normal can be estimated", i)};
    }
    return {};
}

// Coincident points are one point of the fit and of the graph (they share its normal): the
// distinct positions in lexicographic order, and each point's place among them.
struct DistinctPositions {
    std::vector<glm::vec3> position;
    std::vector<std::uint32_t> of; // a point's index into `position`
};

DistinctPositions distinctPositions(const PointSet& points) {
    DistinctPositions distinct{{}, std::vector<std::uint32_t>(points.size())};
    for (const std::uint32_t i : orderByPosition(points)) {
        if (distinct.position.empty() || distinct.position.back() != points.position[i])
            distinct.position.push_back(points.position[i]);
        distinct.of[i] = static_cast<std::uint32_t>(distinct.position.size() - 1);
    }
    return distinct;
}

// Fails for fewer than 3 distinct positions, or for an extent the k-d tree cannot measure.
Result<void> checkDistinct(std::span<const glm::vec3> distinct, std::size_t count) {
    const std::size_t m = distinct.size();
    if (m == 1) return Error{fmt::format("all {} points coincide: no normal can be estimated", count)};
    if (m < 3)
        return Error{fmt::format(
            "{} distinct positions among {} points: normals need at least 3 to fit a plane", m, count)};
    const float extent = boundsOf(distinct).extent();
    // The k-d tree measures squared distances in single precision: up to 3·extent² must fit, and
    // extent² must not vanish into its denormals.
    const bool large = !(extent * extent <= 0.25f * std::numeric_limits<float>::max());
    if (large || !(extent * extent >= std::numeric_limits<float>::min())) {
        const float largest = std::sqrt(0.25f * std::numeric_limits<float>::max()),
                    smallest = std::sqrt(std::numeric_limits<float>::min());
        return Error{fmt::format("the points span {:.3g}, too {} to estimate normals (spans from {:.2g} to "
                                 "{:.2g} can be measured): scale the model {}",
                                 extent, large ? "large" : "small", smallest, largest,
                                 large ? "down" : "up")};
    }
    return {};
}

// A point's normal from its neighbourhood (normalOf).
struct PointNormal {
    glm::dvec3 normal;
    bool across; // the direction across a part that fits no plane, not the least variance's
};

// The normal of a point x from the eigen decomposition e of the covariance of x and its
// neighbours (`count` points; d = x - their centroid). Where they spread about a plane, the
// direction of least variance. Where they spread as much across it (a part thinner than the
// spacing, whose neighbours lie all around it: a tail, a strand of a mane, a tuft), the direction
// from the centroid to x, taken across the axis of largest variance for a tube (kNoPlane, kTube).
// Choice (beyond Hoppe): there the least variance is any direction across the part, often far
// from x's own, and its sign had nothing to go by; x lies outward of the centroid on such a part.
// Measured on 60 random 3,500-point subsets of each reference of ../shared/data (ALGORITHM.md
// §9.2): subsets above 1 % inward from 8 to 1.
// `across` says which of the two it is.
PointNormal normalOf(glm::dvec3 d, const SmallestEigen& e, std::size_t count) {
    if (!(e.values[0] > kNoPlane * e.values[1])) return {e.vector, false};
    const glm::dvec3 across = e.values[2] > kTube * e.values[1] ? d - glm::dot(d, e.largest) * e.largest : d;
    // x too near the centroid (within half the least standard deviation) to say which way it lies.
    if (!(glm::dot(across, across) > 0.25 * e.values[0] / static_cast<double>(count)))
        return {e.vector, false};
    return {glm::normalize(across), true};
}

// The plane through x and its `stored` neighbours `mine` (of `distinct`), and x's normal (normalOf).
struct PlaneFit {
    glm::vec3 normal;
    glm::vec3 centroid;
    bool degenerate; // no plane: the points lie on one line
    bool across;     // the normal is the direction across a part that fits no plane (normalOf)
};

PlaneFit fitPlane(std::span<const glm::vec3> distinct, glm::vec3 x, const std::uint32_t* mine,
                  std::size_t stored) {
    // The covariance of the point and its neighbours about their centroid, in double.
    glm::dvec3 centroid(x);
    float largest = std::max({std::abs(x.x), std::abs(x.y), std::abs(x.z)});
    for (std::size_t r = 0; r < stored; ++r) {
        const glm::vec3 y = distinct[mine[r]];
        centroid += glm::dvec3(y);
        largest = std::max({largest, std::abs(y.x), std::abs(y.y), std::abs(y.z)});
    }
    centroid /= static_cast<double>(stored + 1);
    double covariance[3][3] = {};
    const auto add = [&](glm::vec3 y) {
        const glm::dvec3 d = glm::dvec3(y) - centroid;
        for (int row = 0; row < 3; ++row)
            for (int c = row; c < 3; ++c) covariance[row][c] += d[row] * d[c];
    };
    add(x);
    for (std::size_t r = 0; r < stored; ++r) add(distinct[mine[r]]);
    const SmallestEigen e = smallestEigenvector(covariance);
    // No plane: the neighbours spread across a line by no more than the rounding of their
    // single-precision coordinates (about (ε·|x|)² per point).
    const double rounding =
        static_cast<double>(std::numeric_limits<float>::epsilon()) * static_cast<double>(largest);
    const bool degenerate = !(e.values[1] > static_cast<double>(stored + 1) * rounding * rounding);
    const PointNormal n = normalOf(glm::dvec3(x) - centroid, e, stored + 1);
    return {glm::vec3(n.normal), glm::vec3(centroid), degenerate, n.across};
}

// The k nearest of each distinct position (itself left out: the only one at distance 0), and
// the plane they fit.
struct PlaneFits {
    std::vector<std::uint32_t> nearest; // k per position (nearestPoints)
    std::vector<glm::vec3> normal, centroid;
    std::vector<std::uint8_t> degenerate, across;
};

PlaneFits fitPlanes(const KdTree& tree, std::span<const glm::vec3> distinct, std::size_t k,
                    WorkerPool& pool) {
    const std::size_t m = distinct.size();
    PlaneFits fits{{},
                   std::vector<glm::vec3>(m),
                   std::vector<glm::vec3>(m),
                   std::vector<std::uint8_t>(m, 0),
                   std::vector<std::uint8_t>(m, 0)};
    fits.nearest = nearestPoints(tree, distinct, k, pool,
                                 [&](std::size_t i, const std::uint32_t* mine, std::size_t stored) {
                                     const PlaneFit fit = fitPlane(distinct, distinct[i], mine, stored);
                                     fits.degenerate[i] = fit.degenerate;
                                     fits.across[i] = fit.across;
                                     fits.normal[i] = fit.normal;
                                     fits.centroid[i] = fit.centroid;
                                 });
    return fits;
}

// Fails, naming the first, when any point's nearest distinct points lie on one line.
Result<void> checkPlanes(const PlaneFits& fits, std::span<const std::uint32_t> distinctOf, std::size_t k) {
    const std::size_t count = distinctOf.size();
    std::size_t bad = 0, first = count;
    for (std::size_t i = 0; i < count; ++i) {
        if (!fits.degenerate[distinctOf[i]]) continue;
        ++bad;
        first = std::min(first, i);
    }
    if (bad > 0)
        return Error{fmt::format("no normal can be estimated for {} point(s) (the first: point {}): their {} "
                                 "nearest distinct points lie on one line",
                                 bad, first, k)};
    return {};
}

// Each distinct position's splat radius for the visibility vote: the distance of its
// kSplatNearest-th nearest point.
std::vector<float> splatRadii(std::span<const glm::vec3> distinct, std::span<const std::uint32_t> nearest,
                              std::size_t k) {
    std::vector<float> splatRadius(distinct.size());
    for (std::size_t i = 0; i < distinct.size(); ++i)
        splatRadius[i] =
            glm::length(distinct[nearest[i * k + std::min<std::size_t>(kSplatNearest, k) - 1]] - distinct[i]);
    return splatRadius;
}

// Orients each connected part of the graph from its start (startsBefore first), whose normal is
// turned to face +z, by propagateOrientation; appends the spanning forest to `spanning` (in the
// order reached; a start as an edge from itself). Returns the number of parts.
std::size_t orientComponents(const NeighbourGraph& graph, std::span<const glm::vec3> distinct,
                             std::span<glm::vec3> normal, std::vector<FrontierEdge>& spanning) {
    const std::size_t m = distinct.size();
    std::vector<std::uint32_t> starts(m);
    std::iota(starts.begin(), starts.end(), 0u);
    std::sort(starts.begin(), starts.end(),
              [&](std::uint32_t a, std::uint32_t b) { return startsBefore(distinct[a], distinct[b]); });
    std::vector<std::uint8_t> reached(m, 0);
    std::vector<FrontierEdge> lightest(m, kNoEdge); // one for every part: reached only grows
    std::size_t components = 0;
    for (const std::uint32_t start : starts) {
        if (reached[start]) continue;
        ++components;
        if (normal[start].z < 0.0f) normal[start] = -normal[start];
        reached[start] = 1;
        spanning.push_back(FrontierEdge{0.0, start, start});
        propagateOrientation(graph, distinct, normal, reached, std::span(&start, 1), lightest, &spanning,
                             true);
    }
    return components;
}

} // namespace

Result<NormalEstimate> estimateNormals(PointSet& points, unsigned threads) {
    if (Result<void> checked = checkPositions(points); !checked) return checked.error();
    const std::size_t count = points.size();
    const DistinctPositions distinct = distinctPositions(points);
    if (Result<void> checked = checkDistinct(distinct.position, count); !checked) return checked.error();
    const std::size_t m = distinct.position.size();
    const KdCloud cloud{distinct.position};
    KdTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    tree.buildIndex();

    const std::size_t k = std::min<std::size_t>(kNormalNearest, m - 1);
    WorkerPool pool(threads);
    PlaneFits fits = fitPlanes(tree, distinct.position, k, pool);
    if (Result<void> checked = checkPlanes(fits, distinct.of, k); !checked) return checked.error();

    const std::vector<float> splatRadius = splatRadii(distinct.position, fits.nearest, k);
    const NeighbourGraph graph(std::move(fits.nearest), k);
    std::vector<glm::vec3>& normal = fits.normal;
    std::vector<FrontierEdge> spanning; // in the order reached; a start as an edge from itself
    NormalEstimate estimate;
    estimate.components = orientComponents(graph, distinct.position, normal, spanning);
    const std::vector<std::uint8_t> tip = orientByVisibility(
        graph, distinct.position, fits.centroid, fits.across, normal, splatRadius, spanning, pool);
    agreeWithNeighbours(graph, distinct.position, fits.centroid, tip, normal, pool);
    points.normal.resize(count);
    for (std::size_t i = 0; i < count; ++i) points.normal[i] = normal[distinct.of[i]];
    points.crease.clear();
    return estimate;
}

std::vector<std::uint32_t> findFlippedNormals(const PointSet& points, unsigned threads) {
    const std::size_t count = points.size();
    assert(points.normal.size() == count);
    if (count < 2) return {};
    // In double precision: squared distances of any finite coordinates stay finite and apart.
    const KdCloudDouble cloud{points.position};
    KdTreeDouble tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    tree.buildIndex();
    const std::size_t k = std::min<std::size_t>(kNormalNearest, count - 1);
    WorkerPool pool(threads);
    std::vector<std::uint32_t> nearest =
        nearestPoints(tree, points.position, k, pool, [](std::size_t, const std::uint32_t*, std::size_t) {});
    // Rounds: once the flipped points of a cluster are turned, the others of the cluster, whose
    // valid neighbours they were, become suspects.
    std::vector<glm::vec3> normal(points.normal.begin(), points.normal.end());
    std::vector<std::uint8_t> reached(count);
    std::vector<std::uint32_t> seeds;
    const NeighbourGraph graph(std::move(nearest), k);
    for (unsigned round = 0; round < kFlipRounds; ++round) {
        seeds.clear();
        for (std::size_t i = 0; i < count; ++i) {
            const glm::vec3 x = points.position[i], n = normal[i];
            unsigned asGiven = 0, turned = 0;
            graph.forEachNearest(static_cast<std::uint32_t>(i), [&](std::uint32_t j) {
                asGiven += validNeighbours(x, n, points.position[j], normal[j]) ? 1 : 0;
                turned += validNeighbours(x, -n, points.position[j], normal[j]) ? 1 : 0;
            });
            reached[i] = asGiven <= kFlippedFits && turned > asGiven ? 0 : 1;
            if (reached[i]) seeds.push_back(static_cast<std::uint32_t>(i));
        }
        if (seeds.size() == count) break;
        const std::vector<glm::vec3> before = normal;
        std::vector<FrontierEdge> lightest(count, kNoEdge); // anew: a round starts from its own seeds
        propagateOrientation(graph, points.position, normal, reached, seeds, lightest);
        if (normal == before) break;
    }
    std::vector<std::uint32_t> flipped;
    for (std::size_t i = 0; i < count; ++i)
        if (normal[i] != points.normal[i]) flipped.push_back(static_cast<std::uint32_t>(i));
    return flipped;
}

} // namespace pnsplat
