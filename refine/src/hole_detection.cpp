// Holes found from the input's rims (ALGORITHM.md §9.8; hole_detection.h has the rules).
#include "pnsplat/refine/hole_detection.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <span>
#include <utility>

#include <glm/geometric.hpp>

#include "kd_tree.h"
#include "pnsplat/refine/neighbourhood.h"
#include "pnsplat/refine/worker_pool.h"

namespace pnsplat {
namespace {

constexpr std::size_t kBatch = 256; // points per task

struct Proposal {
    std::uint32_t point = 0;
    glm::vec3 centre{0.0f};
    float radius = 0.0f;
};

std::uint32_t findRoot(std::vector<std::uint32_t>& parent, std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
}

constexpr std::size_t kCount = kHoleNearest + 1; // a point's nearest points, itself first

// Each point's nearest points (kCount a point, itself first) and the distance to its nearest other.
struct Nearest {
    std::vector<std::uint32_t> index;
    std::vector<float> spacing;
};

Nearest findNearest(const PointSet& points, const KdTree& tree, WorkerPool& pool) {
    const std::size_t n = points.size();
    Nearest nearest{std::vector<std::uint32_t>(n * kCount), std::vector<float>(n)};
    parallelForRanges(pool, n, kBatch, [&](std::size_t begin, std::size_t end, unsigned) {
        std::array<float, kCount> distance2;
        for (std::size_t i = begin; i < end; ++i) {
            // Fewer are found where squared distances overflow single precision (points about
            // 1e19 apart): the missing ones repeat i itself, and the spacing is unmeasured (infinite).
            const std::size_t found =
                tree.knnSearch(&points.position[i].x, kCount, &nearest.index[i * kCount], distance2.data());
            std::fill(nearest.index.begin() + static_cast<std::ptrdiff_t>(i * kCount + found),
                      nearest.index.begin() + static_cast<std::ptrdiff_t>((i + 1) * kCount),
                      static_cast<std::uint32_t>(i));
            nearest.spacing[i] = found > 1 ? std::sqrt(distance2[1]) : std::numeric_limits<float>::infinity();
        }
    });
    return nearest;
}

// The input as the search for rims reads it.
struct Surface {
    const PointSet& points;
    const KdTree& tree;
    const Nearest& nearest;
};

// The median of `values` (of an even count, the upper of the middle two).
float median(std::span<const float> values) {
    std::vector<float> sorted(values.begin(), values.end());
    const auto middle = sorted.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
    std::nth_element(sorted.begin(), middle, sorted.end());
    return *middle;
}

// The largest ball through p centred at p + t·d that holds no point but i, t at most `cap`.
// `inBall` is scratch for the search.
float emptyBallRadius(const Surface& surface, std::size_t i, glm::vec3 d, float cap,
                      std::vector<std::pair<std::uint32_t, float>>& inBall) {
    const glm::vec3 p = surface.points.position[i];
    // A point q with e = q - p lies outside the ball while |e|² >= 2 t (e · d). The ball of
    // t = cap holds every ball of smaller t along d, so the points in it are all that can bound t.
    float t = cap;
    const glm::vec3 far = p + cap * d;
    surface.tree.radiusSearch(&far.x, cap * cap, inBall, nanoflann::SearchParams(32, 0.0f, false));
    for (const auto& [q, distance2] : inBall) {
        const glm::vec3 e = surface.points.position[q] - p;
        const float along = glm::dot(e, d);
        if (q != i && along > 0.0f) t = std::min(t, glm::dot(e, e) / (2.0f * along));
    }
    return t;
}

// 1. Rim points and the empty balls they propose, in point order.
std::vector<Proposal> proposeBalls(const Surface& surface, float cap, WorkerPool& pool) {
    const PointSet& points = surface.points;
    const std::vector<std::uint32_t>& nearest = surface.nearest.index;
    const std::size_t n = points.size();
    std::vector<Proposal> proposal(n);
    std::vector<std::uint8_t> proposes(n, 0);
    parallelForRanges(pool, n, kBatch, [&](std::size_t begin, std::size_t end, unsigned) {
        std::array<float, kCount> angle;
        std::array<float, kCount> local;
        std::vector<std::pair<std::uint32_t, float>> inBall;
        for (std::size_t i = begin; i < end; ++i) {
            if (points.isCrease(i)) continue; // its neighbours across the crease lie off its plane
            const glm::vec3 p = points.position[i];
            const TangentFrame frame(points.normal[i]);
            std::size_t count = 0;
            for (std::size_t k = 1; k < kCount; ++k)
                angle[count++] = frame.angleOf(points.position[nearest[i * kCount + k]] - p);
            std::sort(angle.begin(), angle.begin() + static_cast<std::ptrdiff_t>(count));
            const auto [gap, bisector] = widestGap({angle.data(), count});
            if (gap < kHoleRimAngle) continue;
            const glm::vec3 d = std::cos(bisector) * frame.u + std::sin(bisector) * frame.v;
            const float t = emptyBallRadius(surface, i, d, cap, inBall);
            for (std::size_t k = 0; k < kCount; ++k)
                local[k] = surface.nearest.spacing[nearest[i * kCount + k]];
            std::nth_element(local.begin(), local.begin() + kCount / 2, local.end());
            if (t <= kHoleEmptySpacings * local[kCount / 2]) continue;
            proposes[i] = 1;
            proposal[i] = {static_cast<std::uint32_t>(i), p + t * d, t};
        }
    });
    std::vector<Proposal> kept;
    for (std::size_t i = 0; i < n; ++i)
        if (proposes[i]) kept.push_back(proposal[i]);
    return kept;
}

// 2. Proposals whose balls overlap are one hole: the rim points of each, in point order, the
// groups in order of their first rim point (empty groups last).
std::vector<std::vector<std::uint32_t>> groupOverlapping(std::span<const Proposal> kept) {
    std::vector<std::uint32_t> parent(kept.size());
    std::iota(parent.begin(), parent.end(), 0u);
    for (std::uint32_t a = 0; a < kept.size(); ++a)
        for (std::uint32_t b = a + 1; b < kept.size(); ++b)
            if (glm::distance(kept[a].centre, kept[b].centre) < kept[a].radius + kept[b].radius)
                parent[findRoot(parent, a)] = findRoot(parent, b);
    std::vector<std::vector<std::uint32_t>> groups(kept.size());
    for (std::uint32_t a = 0; a < kept.size(); ++a) groups[findRoot(parent, a)].push_back(kept[a].point);
    // In order of their first rim point (a group's list is in point order).
    std::ranges::sort(groups, [](const auto& x, const auto& y) {
        return !x.empty() && (y.empty() || x.front() < y.front());
    });
    return groups;
}

// 3. The hole a rim surrounds, its ball and size, or nothing (too few points, not aligned, not
// closed, or input points near its centre).
std::optional<FoundHole> holeOf(std::span<const std::uint32_t> rim, const PointSet& points,
                                const KdTree& tree) {
    if (rim.size() < kHoleMinRimPoints) return std::nullopt;
    glm::dvec3 centroid(0.0), normal(0.0);
    for (const std::uint32_t i : rim) {
        centroid += glm::dvec3(points.position[i]);
        normal += glm::dvec3(points.normal[i]);
    }
    const glm::vec3 centre(centroid / static_cast<double>(rim.size()));
    if (glm::length(normal) < kHoleRimAlignment * static_cast<double>(rim.size())) return std::nullopt;
    const TangentFrame frame{glm::vec3(glm::normalize(normal))};
    std::vector<float> around;
    float rimRadius = 0.0f;
    for (const std::uint32_t i : rim) {
        const glm::vec3 e = points.position[i] - centre;
        around.push_back(frame.angleOf(e));
        rimRadius = std::max(rimRadius, glm::length(e));
    }
    std::ranges::sort(around);
    if (widestGap(around).first > kHoleSurroundAngle) return std::nullopt;
    std::uint32_t index = 0;
    float distance2 = 0.0f;
    tree.knnSearch(&centre.x, 1, &index, &distance2);
    // Just under the nearest point's distance: the ball holds no input point. A rim around a
    // fold or a tip has input points near its centroid: not a hole.
    const float radius = std::sqrt(distance2) * (1.0f - 1e-4f);
    if (!(radius > kHoleEmptyShare * rimRadius)) return std::nullopt;
    return FoundHole{{centre, radius}, 2.0f * rimRadius, rim.size()};
}

} // namespace

HoleSearch findHoles(const PointSet& points, float maxSize, bool relative, unsigned threads) {
    HoleSearch search;
    const std::size_t n = points.size();
    if (n < kHoleNearest + 1 || !points.hasNormal() || !(maxSize > 0.0f) || !std::isfinite(maxSize))
        return search;
    const KdCloud cloud{points.position};
    KdTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    tree.buildIndex();
    WorkerPool pool(threads);

    const Nearest nearest = findNearest(points, tree, pool);
    search.spacing = median(nearest.spacing);
    // No hole is wider than the model: a larger size asks for the same holes (and an empty ball of
    // radius far past the model's would be searched around a centre rounded past the spacing).
    const float size =
        std::min(relative ? maxSize * search.spacing : maxSize, boundsOf(points.position).diagonal());
    if (!(size > 0.0f) || !std::isfinite(size)) return search;
    search.maxSize = size;

    const std::vector<Proposal> kept = proposeBalls(Surface{points, tree, nearest}, 0.5f * size, pool);
    for (const std::vector<std::uint32_t>& rim : groupOverlapping(kept))
        if (const std::optional<FoundHole> hole = holeOf(rim, points, tree))
            (hole->size <= size ? search.holes : search.tooLarge).push_back(*hole);
    return search;
}

} // namespace pnsplat
