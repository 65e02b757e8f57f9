#include "pnsplat/refine/input.h"

#include <cmath>

#include <fmt/format.h>

#include "pnsplat/refine/normal_estimation.h"
#include "pnsplat/refine/radius_estimation.h"

namespace pnsplat {

Result<InputCompletion> completeInput(PointSet& points, unsigned threads, bool replaceRadii) {
    InputCompletion done;
    const std::size_t given = points.size();
    done.repeats = removeCoincident(points);
    if (points.size() < 3)
        return Error{fmt::format("{} points but {} distinct position(s); at least 3 are needed", given,
                                 points.size())};
    if (!points.hasNormal()) {
        const Result<NormalEstimate> estimate = estimateNormals(points, threads);
        if (!estimate) return estimate.error();
        done.normalComponents = estimate->components;
    }
    if (points.hasRadius() && !replaceRadii) return done;
    estimateRadii(points, threads);
    done.radiiEstimated = true;
    for (std::size_t i = 0; i < points.size(); ++i)
        if (!(points.radius[i] > 0.0f) || !std::isfinite(points.radius[i]))
            return Error{fmt::format(
                "no radius can be estimated for point {}: it has no neighbour but points along its "
                "normal, or its distances overflow single precision",
                i)};
    return done;
}

} // namespace pnsplat
