// Radius estimation from the natural first ring (ALGORITHM.md §9.3).
#include "pnsplat/refine/radius_estimation.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>

#include <glm/geometric.hpp>

#include "kd_tree.h"
#include "pnsplat/refine/neighbourhood.h"
#include "pnsplat/refine/pn_triangle.h"
#include "pnsplat/refine/worker_pool.h"

namespace pnsplat {

void estimateRadii(PointSet& points, unsigned threads) {
    const std::size_t count = points.size();
    points.radius.assign(count, 0.0f);
    if (count < 2) return;
    const KdCloud cloud{points.position};
    KdTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    tree.buildIndex();

    // Survivors for the symmetric pass, of each range of kBatch points in a row: at most
    // kMaxCandidates a point, about six (a slot for every candidate took 192 bytes a point).
    constexpr std::size_t kBatch = 256;
    std::vector<std::vector<std::uint32_t>> survivors((count + kBatch - 1) / kBatch);
    std::vector<std::uint8_t> survivorCount(count);
    WorkerPool pool(threads);
    struct Scratch {
        NeighbourSet set;
        NeighbourhoodScratch neighbourhood;
    };
    std::vector<Scratch> scratch(pool.size());
    parallelForRanges(pool, count, kBatch, [&](std::size_t begin, std::size_t end, unsigned worker) {
        Scratch& s = scratch[worker];
        std::vector<std::uint32_t>& kept = survivors[begin / kBatch];
        std::array<std::uint32_t, kMaxCandidates + 1> index;
        std::array<float, kMaxCandidates + 1> distance2;
        for (std::size_t i = begin; i < end; ++i) {
            const glm::vec3 x = points.position[i], n = points.normal[i];
            // The candidates: the kMaxCandidates + 1 nearest, up to twice the distance of the
            // kRadiusNearest-th nearest other position. That distance comes from a search of the
            // few nearest first; the candidates' search then takes only points within the limit
            // (its result set starts full at the limit), which prunes most of the tree and keeps
            // the same points in the same order: it walks the same nodes in the same order and
            // skips only nodes whose points are all beyond the limit, or beyond what it holds.
            // (Where a coincident position is among the few, the candidates are searched unbounded.)
            std::size_t found = tree.knnSearch(&x.x, kRadiusNearest + 1, index.data(), distance2.data());
            const bool few = found == kRadiusNearest + 1 && distance2[1] > 0.0f;
            if (few) {
                const float limit2 = 4.0f * distance2[kRadiusNearest];
                nanoflann::KNNResultSet<float, std::uint32_t> within(kMaxCandidates + 1);
                within.init(index.data(), distance2.data());
                distance2[kMaxCandidates] = std::nextafter(limit2, std::numeric_limits<float>::infinity());
                tree.findNeighbors(within, &x.x, nanoflann::SearchParams());
                found = within.size();
            } else {
                found = tree.knnSearch(&x.x, kMaxCandidates + 1, index.data(), distance2.data());
            }
            // Skip the point itself and coincident duplicates.
            std::size_t first = 0;
            while (first < found && distance2[first] <= 0.0f) ++first;
            if (first >= found) continue;
            const std::size_t nth = std::min(found - 1, first + kRadiusNearest - 1);
            const float limit2 = 4.0f * distance2[nth];
            s.set.clear();
            for (std::size_t k = first; k < found && distance2[k] <= limit2; ++k) {
                const std::uint32_t j = index[k];
                if (validNeighbours(x, n, points.position[j], points.normal[j]))
                    s.set.push(j, points.position[j], points.normal[j]);
            }
            FuzzyParams params;
            params.geodesicProjection = false;
            filterFuzzy(x, n, params, s.set, s.neighbourhood);
            float radius = 0.0f;
            for (std::size_t k = 0; k < s.set.size(); ++k) {
                radius = std::max(radius, glm::length(s.set.position[k] - x));
                kept.push_back(s.set.index[k]);
            }
            survivorCount[i] = static_cast<std::uint8_t>(s.set.size());
            // Choice: a point with no valid neighbour (its normal fits none of theirs, eq. 6; one
            // not flipped back by findFlippedNormals) has no one-ring to measure. It reaches its
            // kRadiusNearest nearest points, as far as a one-ring of that many would: its splat
            // covers its share of the surface, and a refinement finds no valid neighbour within
            // it, so the point is kept and inserts nothing. (A radius of 0, or of the smallest
            // float, would be refused, or too small to square.)
            if (s.set.size() == 0) radius = glm::length(points.position[index[nth]] - x);
            // Neighbourhoods are open balls (|p - p_i| < r): reach the farthest survivor strictly.
            points.radius[i] = std::nextafter(radius, std::numeric_limits<float>::max());
        }
    });
    // Symmetric pass, sequential so that the result is independent of the threads.
    for (std::size_t range = 0; range < survivors.size(); ++range) {
        const std::vector<std::uint32_t>& kept = survivors[range];
        std::size_t next = 0;
        for (std::size_t i = range * kBatch; i < std::min(count, (range + 1) * kBatch); ++i)
            for (std::size_t k = 0; k < survivorCount[i]; ++k) {
                const std::uint32_t j = kept[next++];
                const float reach = std::nextafter(glm::length(points.position[i] - points.position[j]),
                                                   std::numeric_limits<float>::max());
                points.radius[j] = std::max(points.radius[j], reach);
            }
        assert(next == kept.size()); // each list read whole
    }
}

} // namespace pnsplat
