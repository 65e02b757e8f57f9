#include "pnsplat/refine/input.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include "pnsplat/refine/normal_estimation.h"
#include "pnsplat/refine/outliers.h"
#include "pnsplat/refine/radius_estimation.h"

namespace pnsplat {

namespace {

// The points that the estimations read and write, along a Morton curve (mortonOrder), and where
// each lies in the input. Choice (ALGORITHM.md §9.4): the estimations' k-d tree searches, the rays'
// hierarchy and the spanning tree then read memory close by, where a file in random order made
// every search read memory far apart. The results are those of the input's order wherever the
// order decides nothing: it only breaks ties between equal distances or weights.
struct SpatialCopy {
    PointSet points; // positions, and normals where the input has them (the estimations read no more)
    std::vector<std::uint32_t> of;

    explicit SpatialCopy(const PointSet& input) : of(mortonOrder(input.position)) {
        const std::size_t n = of.size();
        points.position.resize(n);
        if (input.hasNormal()) points.normal.resize(n);
        for (std::size_t k = 0; k < n; ++k) {
            points.position[k] = input.position[of[k]];
            if (input.hasNormal()) points.normal[k] = input.normal[of[k]];
        }
    }

    // The input's indices of the copy's points `indices`, ascending.
    std::vector<std::uint32_t> inputIndices(std::span<const std::uint32_t> indices) const {
        std::vector<std::uint32_t> in(indices.size());
        for (std::size_t k = 0; k < indices.size(); ++k) in[k] = of[indices[k]];
        std::sort(in.begin(), in.end());
        return in;
    }

    // Removes the copy's points `drop` (ascending) from the copy and, as `inputDrop`
    // (inputIndices(drop)), from `input`.
    void remove(PointSet& input, std::span<const std::uint32_t> drop,
                std::span<const std::uint32_t> inputDrop) {
        removePoints(points, drop);
        removePoints(input, inputDrop);
        std::size_t kept = 0, next = 0;
        for (std::size_t k = 0; k < of.size(); ++k) {
            if (next < drop.size() && drop[next] == k) {
                ++next;
                continue;
            }
            const std::uint32_t i = of[k]; // less the input's points dropped before it
            of[kept++] = i - static_cast<std::uint32_t>(
                                 std::lower_bound(inputDrop.begin(), inputDrop.end(), i) - inputDrop.begin());
        }
        of.resize(kept);
    }
};

// The error for the first point whose estimated radius is not a positive finite float: the k-d
// tree's squared distances under- or overflowed. It says which, measuring in double.
std::optional<Error> unmeasuredRadius(const PointSet& points) {
    for (std::size_t i = 0; i < points.size(); ++i) {
        const float r = points.radius[i];
        if (r > 0.0f && std::isfinite(r)) continue;
        const glm::dvec3 x(points.position[i]);
        double nearest = std::numeric_limits<double>::infinity();
        for (std::size_t j = 0; j < points.size(); ++j)
            if (j != i) nearest = std::min(nearest, glm::distance(x, glm::dvec3(points.position[j])));
        const bool far = nearest > 1.0; // (the failures lie below 1e-19 or above 1e19)
        return Error{fmt::format("point {} (at {:.6g} {:.6g} {:.6g}) lies {:.3g} from its nearest point, too "
                                 "{} to measure its radius (spacings from about 1e-19 to 1e19 can be): "
                                 "scale the model {}",
                                 i, x.x, x.y, x.z, nearest, far ? "far" : "close", far ? "down" : "up")};
    }
    return std::nullopt;
}

} // namespace

Result<InputCompletion> completeInput(PointSet& points, unsigned threads, const InputOptions& options,
                                      const CompletionProgress& progress) {
    const auto step = [&](std::size_t k) {
        if (progress) progress(k, kCompletionSteps);
    };
    InputCompletion done;
    const std::size_t given = points.size();
    step(0);
    done.repeats = removeCoincident(points);
    if (points.size() < 3)
        return Error{fmt::format("{} points but {} distinct position(s); at least 3 are needed", given,
                                 points.size())};
    const bool searchOutliers = !options.keepOutliers && !options.asWritten;
    const bool checkNormals = !points.hasNormal() || !options.asWritten;
    const bool measureRadii = !points.hasRadius() || options.replaceRadii;
    if (!searchOutliers && !checkNormals && !measureRadii) { // every step a given set's
        for (std::size_t k = 1; k <= kCompletionSteps; ++k) step(k);
        return done;
    }
    SpatialCopy copy(points);
    // Before the estimations: an outlier's normal and radius would be measured across the gap
    // around it, and its neighbours' would reach it.
    step(1);
    if (searchOutliers) {
        const OutlierSearch search = findOutliers(copy.points.position, threads);
        done.outlierMedian = search.median;
        done.outlierThreshold = search.threshold;
        if (!search.outliers.empty()) {
            const std::vector<std::uint32_t> inputDrop = copy.inputIndices(search.outliers);
            done.outliers = inputDrop.size();
            done.firstOutlier = points.position[inputDrop[0]];
            copy.remove(points, search.outliers, inputDrop);
        }
    }
    step(2);
    const std::size_t n = points.size();
    if (!points.hasNormal()) {
        const Result<NormalEstimate> estimate = estimateNormals(copy.points, threads);
        if (!estimate) {
            // Its errors name a point by its index: the same failure on the input names it there.
            const Result<NormalEstimate> named = estimateNormals(points, threads);
            return named ? estimate.error() : named.error();
        }
        done.normalComponents = estimate->components;
        points.normal.resize(n);
        for (std::size_t k = 0; k < n; ++k) points.normal[copy.of[k]] = copy.points.normal[k];
        points.crease.clear();
    } else if (checkNormals) {
        const std::vector<std::uint32_t> found = findFlippedNormals(copy.points, threads);
        const std::vector<std::uint32_t> flipped = copy.inputIndices(found);
        if (!flipped.empty()) {
            const glm::vec3 x = points.position[flipped[0]];
            if (options.keepNormals)
                return Error{fmt::format("{} normal(s) point against their neighbours' (the first: point {}, "
                                         "at {:.6g} {:.6g} {:.6g}) and are to be kept as given: fix them in "
                                         "the file, or let them be turned",
                                         flipped.size(), flipped[0], x.x, x.y, x.z)};
            for (const std::uint32_t i : flipped) {
                points.normal[i] = -points.normal[i];
                if (points.isCrease(i)) points.crease[i] = -points.crease[i];
            }
            for (const std::uint32_t k : found) copy.points.normal[k] = -copy.points.normal[k];
            done.turnedNormals = flipped.size();
            done.firstTurned = flipped[0];
        }
    }
    step(3);
    if (!measureRadii) {
        step(kCompletionSteps);
        return done;
    }
    estimateRadii(copy.points, threads);
    points.radius.resize(n);
    for (std::size_t k = 0; k < n; ++k) points.radius[copy.of[k]] = copy.points.radius[k];
    done.radiiEstimated = true;
    if (std::optional<Error> error = unmeasuredRadius(points)) return *error;
    step(kCompletionSteps);
    return done;
}

} // namespace pnsplat
