// Level-by-level refinement with a progress bar, shared by `refine` and `render --refine-levels`.
#pragma once

#include <cstddef>
#include <string>

#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/refiner.h"

namespace pnsplat::tools {

struct RefineRun {
    PointSet points;
    unsigned levels = 0;       // levels run (fewer than asked when nothing more was inserted)
    unsigned evenOutLevels = 0; // adaptive levels of evenOut after them (part of `levels`)
    double seconds = 0.0;      // time spent refining (not estimating radii)
    std::size_t cappedNeighbourhoods = 0; // over all levels (LevelStats), a sign of radii too large
};

// Replaces the radii of `points` by estimated ones (SPEC 9); a point without any (no neighbour but
// coincident points or points along its normal, or distances beyond single precision) is a
// CommandError naming `inputName`.
void estimateRadiiOrFail(PointSet& points, unsigned threads, const std::string& inputName);

// Estimates radii when `points` has none (or when `estimateRadii`), checks the input
// (CommandError naming `inputName`), then refines up to `levels` levels, stopping early once
// `targetPoints` (0: no target) is reached or a level inserts nothing; then evens out (evenOut)
// the points above `evenOutFactor` times the median radius (0: not at all).
RefineRun refineWithProgress(PointSet points, const RefineOptions& options, unsigned levels, std::size_t targetPoints,
                             float evenOutFactor, bool estimateRadii, const std::string& inputName);

} // namespace pnsplat::tools
