// Normal estimation by local PCA and minimum-spanning-tree orientation (ALGORITHM.md §9.2).
#include "pnsplat/refine/normal_estimation.h"

#include <algorithm>
#include <array>
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
            double j[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
            j[p][p] = c, j[q][q] = c, j[p][q] = s, j[q][p] = -s;
            double aj[3][3] = {}, rotated[3][3] = {}, vj[3][3] = {};
            for (int r = 0; r < 3; ++r)
                for (int k = 0; k < 3; ++k)
                    for (int l = 0; l < 3; ++l) {
                        aj[r][k] += a[r][l] * j[l][k];
                        vj[r][k] += v[r][l] * j[l][k];
                    }
            for (int r = 0; r < 3; ++r)
                for (int k = 0; k < 3; ++k)
                    for (int l = 0; l < 3; ++l) rotated[r][k] += j[l][r] * aj[l][k];
            rotated[p][q] = rotated[q][p] = 0.0; // exactly, as the rotation was chosen
            std::copy(&rotated[0][0], &rotated[0][0] + 9, &a[0][0]);
            std::copy(&vj[0][0], &vj[0][0] + 9, &v[0][0]);
        }
    }
    std::array<int, 3> order{0, 1, 2};
    std::sort(order.begin(), order.end(), [&](int x, int y) { return a[x][x] < a[y][y]; });
    const int smallest = order[0];
    SmallestEigen result;
    result.vector = glm::normalize(glm::dvec3(v[0][smallest], v[1][smallest], v[2][smallest]));
    for (int k = 0; k < 3; ++k) result.values[k] = a[order[k]][order[k]];
    return result;
}

namespace {

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

// Prim's propagation along a minimum spanning forest: from the `seeds` (reached already), the
// points not yet `reached` that the graph connects to them are reached by the lightest edge of
// the frontier first (orientationWeight), and each takes the sign that agrees with the point it is
// reached from.
void propagateOrientation(const NeighbourGraph& graph, std::span<const glm::vec3> position,
                          std::span<glm::vec3> normal, std::vector<std::uint8_t>& reached,
                          std::span<const std::uint32_t> seeds) {
    std::priority_queue<FrontierEdge, std::vector<FrontierEdge>, std::greater<>> frontier;
    const auto extend = [&](std::uint32_t from) {
        graph.forEach(from, [&](std::uint32_t to) {
            if (reached[to]) return;
            frontier.push(FrontierEdge{
                orientationWeight(position[from], normal[from], position[to], normal[to]), to, from});
        });
    };
    for (const std::uint32_t seed : seeds) extend(seed);
    while (!frontier.empty()) {
        const FrontierEdge edge = frontier.top();
        frontier.pop();
        if (reached[edge.to]) continue;
        reached[edge.to] = 1;
        if (glm::dot(normal[edge.from], normal[edge.to]) < 0.0f) normal[edge.to] = -normal[edge.to];
        extend(edge.to);
    }
}

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

} // namespace

Result<NormalEstimate> estimateNormals(PointSet& points, unsigned threads) {
    const std::size_t count = points.size();
    if (count < 3)
        return Error{fmt::format("{} point(s): normals need at least 3 points to fit a plane", count)};
    for (std::size_t i = 0; i < count; ++i) {
        const glm::vec3 x = points.position[i];
        if (!std::isfinite(x.x) || !std::isfinite(x.y) || !std::isfinite(x.z))
            return Error{fmt::format("point {} has a non-finite position: no normal can be estimated", i)};
    }
    // Coincident points are one point of the fit and of the graph (they share its normal): the
    // distinct positions in lexicographic order, and each point's place among them.
    std::vector<glm::vec3> distinct;
    std::vector<std::uint32_t> distinctOf(count);
    for (const std::uint32_t i : orderByPosition(points)) {
        if (distinct.empty() || distinct.back() != points.position[i]) distinct.push_back(points.position[i]);
        distinctOf[i] = static_cast<std::uint32_t>(distinct.size() - 1);
    }
    const std::size_t m = distinct.size();
    if (m == 1) return Error{fmt::format("all {} points coincide: no normal can be estimated", count)};
    if (m < 3)
        return Error{fmt::format(
            "{} distinct positions among {} points: normals need at least 3 to fit a plane", m, count)};
    glm::vec3 lo = distinct[0], hi = lo;
    for (const glm::vec3& x : distinct) {
        lo = glm::min(lo, x);
        hi = glm::max(hi, x);
    }
    const float extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
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
    const KdCloud cloud{distinct};
    KdTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    tree.buildIndex();

    // The k nearest of each distinct position (itself left out: the only one at distance 0), and
    // the plane they fit.
    const std::size_t k = std::min<std::size_t>(kNormalNearest, m - 1);
    std::vector<glm::vec3> normal(m);
    std::vector<std::uint8_t> degenerate(m, 0);
    WorkerPool pool(threads);
    std::vector<std::uint32_t> nearest = nearestPoints(
        tree, distinct, k, pool, [&](std::size_t i, const std::uint32_t* mine, std::size_t stored) {
            const glm::vec3 x = distinct[i];
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
            degenerate[i] = !(e.values[1] > static_cast<double>(stored + 1) * rounding * rounding);
            normal[i] = glm::vec3(e.vector);
        });
    std::size_t bad = 0, first = count;
    for (std::size_t i = 0; i < count; ++i) {
        if (!degenerate[distinctOf[i]]) continue;
        ++bad;
        first = std::min(first, i);
    }
    if (bad > 0)
        return Error{fmt::format("no normal can be estimated for {} point(s) (the first: point {}): their {} "
                                 "nearest distinct points lie on one line",
                                 bad, first, k)};

    const NeighbourGraph graph(std::move(nearest), k);
    std::vector<std::uint32_t> starts(m);
    std::iota(starts.begin(), starts.end(), 0u);
    std::sort(starts.begin(), starts.end(),
              [&](std::uint32_t a, std::uint32_t b) { return startsBefore(distinct[a], distinct[b]); });
    std::vector<std::uint8_t> reached(m, 0);
    NormalEstimate estimate;
    for (const std::uint32_t start : starts) {
        if (reached[start]) continue;
        ++estimate.components;
        if (normal[start].z < 0.0f) normal[start] = -normal[start];
        reached[start] = 1;
        propagateOrientation(graph, distinct, normal, reached, std::span(&start, 1));
    }
    points.normal.resize(count);
    for (std::size_t i = 0; i < count; ++i) points.normal[i] = normal[distinctOf[i]];
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
        propagateOrientation(graph, points.position, normal, reached, seeds);
        if (normal == before) break;
    }
    std::vector<std::uint32_t> flipped;
    for (std::size_t i = 0; i < count; ++i)
        if (normal[i] != points.normal[i]) flipped.push_back(static_cast<std::uint32_t>(i));
    return flipped;
}

} // namespace pnsplat
