// Radii for inputs that come without them (SPEC.md section 9; not in the paper).
//
// The refinement needs r_i to reach at least the farthest neighbour of the natural first ring of
// p_i (SPEC 1). The estimate: take the points within twice the distance of the 6th nearest
// neighbour (at most kMaxCandidates), filter them with the fuzzy BSP rule (Nf, SPEC 3) like a
// refinement step would, and take the distance of the farthest survivor. Then make the relation
// symmetric: when p_j survives around p_i, r_j also reaches p_i.
//
// Thread use: runs on the given number of worker threads (0 = all); the result does not depend on
// the thread count. Positions and normals must be finite, normals unit length.
#pragma once

#include <cstddef>

#include <glm/vec3.hpp>

#include "pnsplat/refine/point_set.h"

namespace pnsplat {

inline constexpr unsigned kRadiusNearest = 6;
inline constexpr unsigned kMaxCandidates = 48;

// Fills points.radius (replacing any radii present). A single isolated point gets radius 0; the
// refinement rejects such input (validateForRefinement) because it has no neighbourhood.
void estimateRadii(PointSet& points, unsigned threads = 0);

// Hole filling (paper figure 9, SPEC 9): "the radii of the boundary points are adjusted such that
// they are greater than the hole", then the refinement is applied several times. The hole is given
// as a ball that holds no input point. Choice: the boundary points are those whose ball reaches
// the hole's (|p - c| < R + r_p), and each gets r_p = max(r_p, |p - c| + R), which reaches across
// the hole to its far rim, so that its neighbourhood spans it and its fan triangles cross it. Then
// refine with RefineOptions::maxNeighbours = kHoleFillingMaxNeighbours (refiner.h), evening out
// first (evenOut): only the rim and the points it inserts into the hole, whose radii stay far above
// their surroundings', are refined, level after level until they match them; uniform levels
// after that. Returns how many radii were enlarged.
struct Hole {
    glm::vec3 centre{0.0f};
    float radius = 0.0f;
};
std::size_t enlargeAroundHole(PointSet& points, const Hole& hole);

} // namespace pnsplat
