// Radii for inputs that come without them (ALGORITHM.md §9.3; not in the paper).
//
// The refinement needs r_i to reach at least the farthest neighbour of the natural first ring of
// p_i (ALGORITHM.md §1.2). The estimate: take the points within twice the distance of the 6th nearest
// neighbour (at most kMaxCandidates), filter them with the fuzzy BSP rule (Nf, ALGORITHM.md §3.2) like a
// refinement step would, and take the distance of the farthest survivor. Then make the relation
// symmetric: when p_j survives around p_i, r_j also reaches p_i. A point with no valid neighbour
// (eq. 6) reaches its kRadiusNearest nearest points instead (a choice; radius_estimation.cpp).
//
// Thread use: runs on the given number of worker threads (0 = all); the result does not depend on
// the thread count. Positions and normals must be finite, normals unit length.
#pragma once

#include "pnsplat/refine/point_set.h"

namespace pnsplat {

inline constexpr unsigned kRadiusNearest = 6;
inline constexpr unsigned kMaxCandidates = 48;

// Fills points.radius (replacing any radii present). Every radius is positive where the squared
// distances to the nearest points neither underflow nor overflow in single precision (spacings
// from about 1.1e-19 to 1.8e19); outside that, and for a set of one point, a radius is 0 or
// infinite (completeInput, input.h, refuses such sets).
void estimateRadii(PointSet& points, unsigned threads = 0);

} // namespace pnsplat
