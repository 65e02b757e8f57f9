// A scan as the refinement takes it (ALGORITHM.md §9; what `pnsplat refine` and `render` do with a file):
// points that repeat an earlier position merged, outliers left out (outliers.h), normals estimated
// when there are none, flipped
// normals turned back (or refused) when there are, radii estimated when there are none (or always,
// when asked). Not in the paper. Any thread may call it; the estimations run on the given number
// of worker threads (0 = all), with results that do not depend on it.
#pragma once

#include <cstddef>
#include <functional>

#include <glm/vec3.hpp>

#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/result.h"

namespace pnsplat {

struct InputOptions {
    bool replaceRadii = false; // estimate radii even when the set has them
    bool keepNormals = false;  // refuse flipped normals (findFlippedNormals) instead of turning them
    bool keepOutliers = false; // keep the points findOutliers finds isolated instead of removing them
    // A set completed before, such as pnsplat's own output (writtenByPnsplat, ply.h): every point and
    // normal kept as given, neither searched (findOutliers, findFlippedNormals). On the 14.2 million
    // points of the nefertiti refined to level 8 those searches took about a minute each and found
    // 4,467 "outliers" and 35 flipped normals in the refinement's own folds.
    bool asWritten = false;
};

struct InputCompletion {
    CoincidentRemoval repeats;        // points dropped for repeating an earlier position (removeCoincident)
    std::size_t outliers = 0;         // points left out as isolated (findOutliers; 0 with keepOutliers)
    glm::vec3 firstOutlier{0.0f};     // the position of the first of them, in input order
    double outlierMedian = 0.0;       // the median and the threshold of the mean distance to the
    double outlierThreshold = 0.0;    // kOutlierNearest nearest (OutlierSearch; 0: not searched)
    std::size_t normalComponents = 0; // normals estimated: the connected parts oriented (0: it had normals)
    std::size_t turnedNormals = 0;    // given normals that were flipped, turned back (findFlippedNormals)
    std::size_t firstTurned = 0;      // the first of them, an index into the completed set
    bool radiiEstimated = false;
};

// The steps of completeInput, in order: repeats merged, outliers, normals (estimated or checked),
// radii. On millions of points each of the middle two takes tens of seconds.
inline constexpr std::size_t kCompletionSteps = 4;
using CompletionProgress = std::function<void(std::size_t step, std::size_t steps)>;

// Completes `points` in place. Fails with one line, for: fewer than 3 distinct positions; normals
// that cannot be estimated (estimateNormals); flipped normals with options.keepNormals (naming
// how many and the first, with its position); points too close together or too far apart for
// their radii to be measured (estimateRadii). It does not validate the result:
// validateForRefinement (refiner.h) does. `progress`, when given, is called as each step starts
// (step 0 to kCompletionSteps - 1) and at the end (kCompletionSteps).
Result<InputCompletion> completeInput(PointSet& points, unsigned threads, const InputOptions& options = {},
                                      const CompletionProgress& progress = {});

} // namespace pnsplat
