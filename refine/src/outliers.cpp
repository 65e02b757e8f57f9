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

// A sheet's points spread in two directions: the middle eigenvalue of their spread is above this
// share of the largest. Neighbours on a line leave it at 0 up to rounding (tiny, or negative: the
// eigenvalues of a rank-one spread), far below the sparse terrains' 0.058 (ALGORITHM.md §9.7).
constexpr double kSheetSpread = 0.01;

// What a pass measured of each point, by its index in the positions given: d_i (infinity where
// not measured), its offset from its neighbours' plane and that plane's flatness (the smallest
// eigenvalue of their spread over the middle one; both NaN where rule 2 does not measure them), its
// k + 1 nearest (indices into the positions given), and whether the next pass may keep all of it
// (`reusable`).
struct Measures {
    std::vector<double> distance, height, flatness;
    std::vector<std::uint32_t> nearest;
    std::vector<std::uint8_t> reusable;
};

Measures measuresFor(std::size_t n, unsigned k) {
    return {std::vector<double>(n), std::vector<double>(n), std::vector<double>(n),
            std::vector<std::uint32_t>(n * (k + 1)), std::vector<std::uint8_t>(n, 0)};
}

// Measures the points `which` (indices into `positions`) among the points `left` (the tree is over
// their positions, `leftPositions`, in that order), into `m`. A point's k + 2 nearest are found;
// where their distances rise strictly, its k + 1 nearest are the only k + 1 nearest and come in the
// only order, whatever the tree, and stay so in every later pass that keeps them all (the points
// left are a subset: none comes nearer than the (k + 2)-th). Such a point is `reusable`: a later pass
// that removed none of its k + 1 nearest measures the same d_i and plane. Elsewhere (a tie: a
// lattice, a repeated distance) its k + 1 nearest are searched as before, and it is measured again
// in every pass, so that ties resolve as the tree of that pass resolves them.
void measure(const KdTree& tree, std::span<const glm::vec3> positions, std::span<const std::uint32_t> left,
             std::span<const std::uint32_t> which, unsigned k, double offset, WorkerPool& pool, Measures& m) {
    const std::size_t wanted = std::min<std::size_t>(k + 2, left.size());
    parallelForRanges(pool, which.size(), kBatch, [&](std::size_t begin, std::size_t end, unsigned) {
        std::array<std::uint32_t, kOutlierMaxNearest + 2> index;
        std::array<float, kOutlierMaxNearest + 2> distance2;
        for (std::size_t w = begin; w < end; ++w) {
            const std::uint32_t i = which[w];
            const glm::vec3 x = positions[i];
            std::size_t found = tree.knnSearch(&x.x, wanted, index.data(), distance2.data());
            bool rising = found == k + 2;
            for (std::size_t j = 1; j < found && rising; ++j) rising = distance2[j - 1] < distance2[j];
            m.reusable[i] = rising ? 1 : 0;
            if (!rising) found = tree.knnSearch(&x.x, k + 1, index.data(), distance2.data());
            // The k + 1 nearest: the point itself (at 0) and its k nearest others. Their sum does
            // not depend on how the search orders ties, so neither does d_i. The search finds fewer
            // where squared distances overflow single precision (spacings above about 1e19): such
            // a point is not measured (infinity), and its `nearest` are not read.
            m.height[i] = m.flatness[i] = std::numeric_limits<double>::quiet_NaN();
            if (found < k + 1) {
                m.distance[i] = std::numeric_limits<double>::infinity();
                m.reusable[i] = 0;
                continue;
            }
            double sum = 0.0;
            for (std::size_t j = 0; j < k + 1; ++j) sum += std::sqrt(double{distance2[j]});
            m.distance[i] = sum / k;
            std::uint32_t* nearest = &m.nearest[std::size_t{i} * (k + 1)];
            for (std::size_t j = 0; j < k + 1; ++j) nearest[j] = left[index[j]];
            if (offset <= 0.0 || m.distance[i] <= 0.0) continue;
            // Rule 2, off the surface: the plane of the k nearest (their centroid and direction of
            // least variance, as the normal estimation's PCA, §9.2), the k + 1 nearest but i itself
            // (the first k, were i not among them).
            std::array<glm::dvec3, kOutlierMaxNearest> neighbour;
            std::size_t used = 0;
            for (std::size_t j = 0; j < k + 1 && used < k; ++j)
                if (nearest[j] != i) neighbour[used++] = glm::dvec3(positions[nearest[j]]);
            glm::dvec3 centre(0.0);
            for (std::size_t j = 0; j < used; ++j) centre += neighbour[j];
            centre /= static_cast<double>(used);
            double covariance[3][3] = {};
            for (std::size_t j = 0; j < used; ++j) {
                const glm::dvec3 e = neighbour[j] - centre;
                for (int r = 0; r < 3; ++r)
                    for (int c = r; c < 3; ++c) covariance[r][c] += e[r] * e[c];
            }
            const SmallestEigen plane = smallestEigenvector(covariance);
            m.height[i] = std::abs(glm::dot(glm::dvec3(x) - centre, plane.vector));
            // Neighbours on a line have no flatness to measure.
            m.flatness[i] = plane.values[1] > kSheetSpread * plane.values[2]
                                ? std::max(plane.values[0], 0.0) / plane.values[1]
                                : std::numeric_limits<double>::quiet_NaN();
        }
    });
}

// Whether point i, which rule 1 finds sparse against the whole set, lies in a sheet as sparse as
// itself: the upper median of its k nearest's own d_j is finite and at least d_i / localRatio,
// their plane is flat (flatness below `flatness`) and i lies on it (within `onPlane` · d_i). A
// scan's far field is such a sheet (a terrestrial scanner's density falls with the square of the
// range), where a stray point's nearest are surface points much nearer each other than to it. The
// neighbours are all among the points left (a removal among them has them measured again), so
// their d_j are this pass's. A NaN flatness (rule 2 off, neighbours on a line) spares nothing.
bool inSparseSheet(std::uint32_t i, const OutlierParams& params, const Measures& m) {
    const double d = m.distance[i];
    if (!(m.flatness[i] < params.flatness) || !(m.height[i] <= params.onPlane * d)) return false;
    const unsigned k = params.nearest;
    const std::uint32_t* nearest = &m.nearest[std::size_t{i} * (k + 1)];
    std::array<double, kOutlierMaxNearest + 1> theirs;
    std::size_t used = 0;
    for (std::size_t j = 0; j < k + 1 && used < k; ++j)
        if (nearest[j] != i) theirs[used++] = m.distance[nearest[j]];
    const auto middle = theirs.begin() + static_cast<std::ptrdiff_t>(used / 2);
    std::nth_element(theirs.begin(), middle, theirs.begin() + static_cast<std::ptrdiff_t>(used));
    return std::isfinite(*middle) && d <= params.localRatio * *middle;
}

// One pass of rules 1 and 2 over the points `left` (indices into `positions`), measuring again
// those whose measures the pass before cannot lend it: every point in the first pass (`first`),
// then those not reusable or with one of their k + 1 nearest removed since. Returns the outliers
// found (indices into `positions`, ascending) with the pass's median and threshold.
OutlierSearch searchOnce(std::span<const glm::vec3> positions, std::span<const std::uint32_t> left,
                         std::span<const std::uint8_t> removed, bool first, WorkerPool& pool,
                         const OutlierParams& params, Measures& m) {
    OutlierSearch search;
    const std::size_t count = left.size();
    const unsigned k = params.nearest;
    if (count <= params.minPoints || count <= k) return search;
    assert(k >= 1 && k <= kOutlierMaxNearest);
    std::vector<std::uint32_t> which;
    for (const std::uint32_t i : left) {
        const std::uint32_t* nearest = &m.nearest[std::size_t{i} * (k + 1)];
        if (first || !m.reusable[i] ||
            std::any_of(nearest, nearest + k + 1, [&](std::uint32_t j) { return removed[j] != 0; }))
            which.push_back(i);
    }
    if (!which.empty()) {
        std::vector<glm::vec3> leftPositions(count);
        for (std::size_t e = 0; e < count; ++e) leftPositions[e] = positions[left[e]];
        const KdCloud cloud{leftPositions};
        KdTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
        tree.buildIndex();
        measure(tree, positions, left, which, k, params.offset, pool, m);
    }
    // The statistics and both rules take the measured points only; the others are left to the
    // radius estimation, whose check names the spacing (completeInput).
    std::vector<double> scratch;
    scratch.reserve(count);
    for (const std::uint32_t i : left)
        if (std::isfinite(m.distance[i])) scratch.push_back(m.distance[i]);
    if (scratch.empty()) return search;
    search.median = median(scratch);
    for (double& d : scratch) d = std::abs(d - search.median);
    // 1.4826 · MAD estimates the standard deviation of a normal distribution.
    constexpr double kMadToDeviation = 1.4826;
    search.threshold = std::max(search.median + params.deviations * kMadToDeviation * median(scratch),
                                params.ratio * search.median);
    for (const std::uint32_t i : left) {
        const double d = m.distance[i];
        if (!std::isfinite(d)) continue;
        // Rule 1 but where the point is part of a sparse sheet, or rule 2 where it measured the
        // point (a NaN height fails the comparison).
        if ((d > search.threshold && !inSparseSheet(i, params, m)) ||
            m.height[i] > params.offset * std::max(d, search.median))
            search.outliers.push_back(i);
    }
    return search;
}

} // namespace

std::vector<double> outlierDistances(std::span<const glm::vec3> positions, unsigned k, unsigned threads) {
    assert(k >= 1 && k <= kOutlierMaxNearest);
    const std::size_t n = positions.size();
    if (n <= k) return std::vector<double>(n, 0.0);
    std::vector<std::uint32_t> all(n);
    std::iota(all.begin(), all.end(), 0u);
    Measures m = measuresFor(n, k);
    const KdCloud cloud{positions};
    KdTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    tree.buildIndex();
    WorkerPool pool(threads);
    measure(tree, positions, all, all, k, 0.0, pool, m);
    return std::move(m.distance);
}

OutlierSearch findOutliers(std::span<const glm::vec3> positions, unsigned threads,
                           const OutlierParams& params) {
    WorkerPool pool(threads);
    const std::size_t n = positions.size();
    const unsigned k = params.nearest;
    Measures m = measuresFor(n, k);
    std::vector<std::uint8_t> removed(n, 0);
    std::vector<std::uint32_t> left(n); // the points still in, ascending
    std::iota(left.begin(), left.end(), 0u);
    OutlierSearch search;
    for (unsigned pass = 0; pass == 0 || pass < params.passes; ++pass) {
        const OutlierSearch found = searchOnce(positions, left, removed, pass == 0, pool, params, m);
        if (pass == 0) {
            search.median = found.median;
            search.threshold = found.threshold;
        }
        if (found.outliers.empty()) break;
        for (const std::uint32_t i : found.outliers) removed[i] = 1;
        search.outliers.insert(search.outliers.end(), found.outliers.begin(), found.outliers.end());
        std::erase_if(left, [&](std::uint32_t i) { return removed[i] != 0; });
    }
    std::ranges::sort(search.outliers);
    return search;
}

} // namespace pnsplat
