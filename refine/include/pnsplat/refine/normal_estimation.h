// Normals for inputs that come without them (ALGORITHM.md §9.2; not in the paper), after Hoppe,
// DeRose, Duchamp, McDonald and Stuetzle, "Surface reconstruction from unorganized points"
// (SIGGRAPH 1992).
//
// Direction: local PCA. The normal of p is the eigenvector of the smallest eigenvalue of the
// covariance of p and its kNormalNearest nearest points (about their centroid). Coincident points
// count as one, in the fit and in the orientation, and share its normal.
//
// Orientation: propagated along a minimum spanning tree of the symmetric k-nearest-neighbour
// graph (i ~ j when either is among the other's nearest), edge weight Hoppe's 1 - |n_i · n_j| plus
// |d · n_i| + |d · n_j| for the unit direction d between them (a choice beyond Hoppe: an edge
// across a thin wall or a sharp crease is crossed last; see orientationWeight). Each point takes
// the sign that agrees with the point it was reached from.
// Choice (ALGORITHM.md §9.2; MST propagation, or outward for closed shapes, are the usual ones): each
// connected component starts at its point of largest z (ties: largest y, then x), whose normal is turned
// towards +z. At the top of a closed shape that is outward, so closed shapes come out outward-facing.
//
// Thread use: the PCA runs on the given number of worker threads (0 = all), the propagation on
// the calling thread; the result does not depend on the thread count.
#pragma once

#include <cstddef>

#include <glm/vec3.hpp>

#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/result.h"

namespace pnsplat {

// The neighbours of each point's plane fit (distinct positions), and its edges in the
// orientation's graph.
inline constexpr unsigned kNormalNearest = 10;

// The unit eigenvector of the smallest eigenvalue of the symmetric 3×3 matrix m (m[r][c]; only
// the upper triangle is read), by cyclic Jacobi rotations in double precision, and the three
// eigenvalues in increasing order. The vector's sign is unspecified. A pure function; any thread.
struct SmallestEigen {
    glm::dvec3 vector;
    double values[3];
};
SmallestEigen smallestEigenvector(const double (&m)[3][3]);

struct NormalEstimate {
    std::size_t components = 0; // connected components of the neighbour graph (one start each)
};

// Fills points.normal (replacing any normals present) and clears points.crease. Fails with a
// one-line message, changing nothing, for: fewer than 3 points or distinct positions; a
// non-finite position; an extent e with 4e² beyond single precision, or e² below it (the k-d
// tree's squared distances); points whose nearest distinct points lie on one line within the
// rounding of their coordinates (no plane to fit), naming how many and the first. Any thread may
// call it (it runs its own workers).
Result<NormalEstimate> estimateNormals(PointSet& points, unsigned threads = 0);

} // namespace pnsplat
