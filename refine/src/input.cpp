#include "pnsplat/refine/input.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include "pnsplat/refine/normal_estimation.h"
#include "pnsplat/refine/outliers.h"
#include "pnsplat/refine/radius_estimation.h"

namespace pnsplat {

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
    // Before the estimations: an outlier's normal and radius would be measured across the gap
    // around it, and its neighbours' would reach it.
    step(1);
    if (!options.keepOutliers && !options.asWritten) {
        const OutlierSearch search = findOutliers(points.position, threads);
        done.outlierMedian = search.median;
        done.outlierThreshold = search.threshold;
        if (!search.outliers.empty()) {
            done.outliers = search.outliers.size();
            done.firstOutlier = points.position[search.outliers[0]];
            removePoints(points, search.outliers);
        }
    }
    step(2);
    if (!points.hasNormal()) {
        const Result<NormalEstimate> estimate = estimateNormals(points, threads);
        if (!estimate) return estimate.error();
        done.normalComponents = estimate->components;
    } else if (!options.asWritten) {
        const std::vector<std::uint32_t> flipped = findFlippedNormals(points, threads);
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
            done.turnedNormals = flipped.size();
            done.firstTurned = flipped[0];
        }
    }
    step(3);
    if (points.hasRadius() && !options.replaceRadii) {
        step(kCompletionSteps);
        return done;
    }
    estimateRadii(points, threads);
    done.radiiEstimated = true;
    for (std::size_t i = 0; i < points.size(); ++i) {
        const float r = points.radius[i];
        if (r > 0.0f && std::isfinite(r)) continue;
        // The k-d tree's squared distances under- or overflowed: say which, measuring in double.
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
    step(kCompletionSteps);
    return done;
}

} // namespace pnsplat
