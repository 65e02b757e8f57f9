// A scan as the refinement takes it (ALGORITHM.md §9; what `pnsplat refine` and `render` do with a file):
// points that repeat an earlier position merged, normals estimated when there are none, radii
// estimated when there are none (or always, when asked). Not in the paper. Any thread may call it;
// the estimations run on the given number of worker threads (0 = all), with results that do not
// depend on it.
#pragma once

#include <cstddef>

#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/result.h"

namespace pnsplat {

struct InputCompletion {
    CoincidentRemoval repeats;        // points dropped for repeating an earlier position (removeCoincident)
    std::size_t normalComponents = 0; // normals estimated: the connected parts oriented (0: it had normals)
    bool radiiEstimated = false;
};

// Completes `points` in place. Fails with one line, for: fewer than 3 distinct positions; normals
// that cannot be estimated (estimateNormals); a point whose radius cannot be estimated (no
// neighbour but points along its normal, or distances beyond single precision). It does not
// validate the result: validateForRefinement (refiner.h) does.
Result<InputCompletion> completeInput(PointSet& points, unsigned threads, bool replaceRadii = false);

} // namespace pnsplat
