// Statistical outlier removal with robust statistics (ALGORITHM.md §9.7; PCL's
// StatisticalOutlierRemoval, Open3D's remove_statistical_outlier; not in the paper).
#include "pnsplat/refine/outliers.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>
#include <numeric>

#include <glm/geometric.hpp>

#include "kd_tree.h"
#include "pnsplat/refine/normal_estimation.h"
#include "pnsplat/refine/worker_pool.h"

namespace pnsplat {
namespace {

// The median of `values` (the mean of the two middle ones for an even count); reorders them.
double median(std::vector<double>& values) {
    assert(!values.empty());
    const std::size_t half = values.size() / 2;
    const auto middle = values.begin() + static_cast<std::ptrdiff_t>(half);
    std::nth_element(values.begin(), middle, values.end());
    const double upper = *middle;
    if (values.size() % 2 == 1) return upper;
    return 0.5 * (*std::max_element(values.begin(), middle) + upper);
}

constexpr std::size_t kBatch = 256; // points per task

// d_i for every point (outlierDistances), with the tree over the positions and a pool; with
// `nearest` (k + 1 entries a point), also the indices of the k + 1 nearest, nearest first.
std::vector<double> meanDistances(const KdTree& tree, std::span<const glm::vec3> positions, unsigned k,
                                  WorkerPool& pool, std::span<std::uint32_t> nearest = {}) {
    assert(nearest.empty() || nearest.size() == positions.size() * (k + 1));
    std::vector<double> distance(positions.size(), 0.0);
    parallelForRanges(pool, positions.size(), kBatch, [&](std::size_t begin, std::size_t end, unsigned) {
        std::array<std::uint32_t, kOutlierMaxNearest + 1> index;
        std::array<float, kOutlierMaxNearest + 1> distance2;
        for (std::size_t i = begin; i < end; ++i) {
            // The k + 1 nearest: the point itself (at 0) and its k nearest others. Their sum does
            // not depend on how the search orders ties, so neither does the result. The search
            // finds fewer where squared distances overflow single precision (spacings above about
            // 1e19): such a point is not measured (infinity), and its `nearest` are not read.
            const std::size_t found = tree.knnSearch(&positions[i].x, k + 1, index.data(), distance2.data());
            if (found < k + 1) {
                distance[i] = std::numeric_limits<double>::infinity();
                continue;
            }
            double sum = 0.0;
            for (std::size_t j = 0; j < found; ++j) sum += std::sqrt(double{distance2[j]});
            distance[i] = sum / k;
            if (!nearest.empty()) std::copy_n(index.begin(), k + 1, nearest.begin() + i * (k + 1));
        }
    });
    return distance;
}

} // namespace

std::vector<double> outlierDistances(std::span<const glm::vec3> positions, unsigned k, unsigned threads) {
    assert(k >= 1 && k <= kOutlierMaxNearest);
    if (positions.size() <= k) return std::vector<double>(positions.size(), 0.0);
    const KdCloud cloud{positions};
    KdTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    tree.buildIndex();
    WorkerPool pool(threads);
    return meanDistances(tree, positions, k, pool);
}

namespace {

// One pass of rules 1 and 2 over `positions`.
OutlierSearch searchOnce(std::span<const glm::vec3> positions, WorkerPool& pool,
                         const OutlierParams& params) {
    OutlierSearch search;
    const std::size_t count = positions.size();
    const unsigned k = params.nearest;
    if (count <= params.minPoints || count <= k) return search;
    assert(k >= 1 && k <= kOutlierMaxNearest);
    const KdCloud cloud{positions};
    KdTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    tree.buildIndex();
    std::vector<std::uint32_t> nearest(count * (k + 1));
    const std::vector<double> distance = meanDistances(tree, positions, k, pool, nearest);
    // The statistics and both rules take the measured points only; the others are left to the
    // radius estimation, whose check names the spacing (completeInput).
    std::vector<double> scratch;
    scratch.reserve(count);
    for (const double d : distance)
        if (std::isfinite(d)) scratch.push_back(d);
    if (scratch.empty()) return search;
    search.median = median(scratch);
    for (double& d : scratch) d = std::abs(d - search.median);
    // 1.4826 · MAD estimates the standard deviation of a normal distribution.
    constexpr double kMadToDeviation = 1.4826;
    search.threshold = std::max(search.median + params.deviations * kMadToDeviation * median(scratch),
                                params.ratio * search.median);

    // Rule 2, off the surface: the plane of the k nearest (their centroid and direction of least
    // variance, as the normal estimation's PCA, §9.2) against the point's own mean distance to them.
    std::vector<std::uint8_t> outlier(count, 0);
    parallelForRanges(pool, count, kBatch, [&](std::size_t begin, std::size_t end, unsigned) {
        for (std::size_t i = begin; i < end; ++i) {
            if (!std::isfinite(distance[i])) continue;
            if (distance[i] > search.threshold) {
                outlier[i] = 1;
                continue;
            }
            if (params.offset <= 0.0 || distance[i] <= 0.0) continue;
            // The neighbours: the k + 1 nearest but i itself (the first k, were i not among them).
            std::array<glm::dvec3, kOutlierMaxNearest> neighbour;
            std::size_t used = 0;
            for (std::size_t j = i * (k + 1); j < (i + 1) * (k + 1) && used < k; ++j)
                if (nearest[j] != i) neighbour[used++] = glm::dvec3(positions[nearest[j]]);
            glm::dvec3 centre(0.0);
            for (std::size_t j = 0; j < used; ++j) centre += neighbour[j];
            centre /= static_cast<double>(used);
            double m[3][3] = {};
            for (std::size_t j = 0; j < used; ++j) {
                const glm::dvec3 e = neighbour[j] - centre;
                for (int r = 0; r < 3; ++r)
                    for (int c = r; c < 3; ++c) m[r][c] += e[r] * e[c];
            }
            const glm::dvec3 normal = smallestEigenvector(m).vector;
            const double height = std::abs(glm::dot(glm::dvec3(positions[i]) - centre, normal));
            if (height > params.offset * std::max(distance[i], search.median)) outlier[i] = 1;
        }
    });
    for (std::size_t i = 0; i < count; ++i)
        if (outlier[i]) search.outliers.push_back(static_cast<std::uint32_t>(i));
    return search;
}

} // namespace

OutlierSearch findOutliers(std::span<const glm::vec3> positions, unsigned threads,
                           const OutlierParams& params) {
    WorkerPool pool(threads);
    // The points still in (their indices in `positions`, and their positions), compacted after
    // each pass.
    std::vector<std::uint32_t> left(positions.size());
    std::iota(left.begin(), left.end(), 0u);
    std::vector<glm::vec3> leftPositions(positions.begin(), positions.end());
    OutlierSearch search;
    for (unsigned pass = 0; pass == 0 || pass < params.passes; ++pass) {
        const OutlierSearch found = searchOnce(leftPositions, pool, params);
        if (pass == 0) {
            search.median = found.median;
            search.threshold = found.threshold;
        }
        if (found.outliers.empty()) break;
        std::size_t kept = 0;
        for (std::size_t i = 0, f = 0; i < left.size(); ++i) {
            if (f < found.outliers.size() && found.outliers[f] == i) {
                search.outliers.push_back(left[i]);
                ++f;
                continue;
            }
            left[kept] = left[i];
            leftPositions[kept++] = leftPositions[i];
        }
        left.resize(kept);
        leftPositions.resize(kept);
    }
    std::ranges::sort(search.outliers);
    return search;
}

} // namespace pnsplat
