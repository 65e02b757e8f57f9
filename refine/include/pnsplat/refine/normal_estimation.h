// Normals for inputs that come without them, and flipped normals of inputs that come with them
// (ALGORITHM.md §9.2; not in the paper), after Hoppe, DeRose, Duchamp, McDonald and Stuetzle,
// "Surface reconstruction from unorganized points" (SIGGRAPH 1992).
//
// Direction: local PCA. The normal of p is the eigenvector of the smallest eigenvalue of the
// covariance of p and its kNormalNearest nearest points (about their centroid). Coincident points
// count as one, in the fit and in the orientation, and share its normal.
//
// Orientation, in three phases (ALGORITHM.md §9.2 has the measurements):
// 1. Propagation along a minimum spanning tree of the symmetric k-nearest-neighbour graph (i ~ j
//    when either is among the other's nearest), edge weight Hoppe's 1 - |n_i · n_j| plus
//    |d · n_i| + |d · n_j| for the unit direction d between them (a choice beyond Hoppe: an edge
//    across a thin wall or a sharp crease is crossed last; see orientationWeight). Each point takes
//    the sign that agrees with the point it was reached from, or the opposite one across two
//    parallel sheets (an edge along both normals: the faces of a part thinner than the spacing,
//    or of a narrow gap, face away from each other; acrossSheets). Each connected component
//    starts at its point of largest z (ties: largest y, then x), turned towards +z.
// 2. Visibility (a choice beyond Hoppe: the start alone decides a whole component, and a thin
//    part or a close sheet crossed the wrong way turns a whole region; measured, the share of
//    inward normals on ../shared/data's random 3,500-point subsets reached 98 % on the lion and
//    100 % on the fandisk once the models were turned over). The tree is cut into regions at its
//    edges of weight 0.5 or more; the points' disks are put in a bounding-volume hierarchy, and
//    each point casts 5 rays along its normal and 5 against it. A ray that leaves every disk
//    votes for its side (outward rays leave a closed surface, inward ones meet its other side);
//    a region with enough votes takes their side, and the rest of its component is propagated
//    again from the decided regions. A component with no decided region keeps its start's sign.
// 3. Agreement: a normal that its neighbours outvote (weighted by how flat the edge lies in the
//    neighbour's plane) is turned; where they hardly agree, at the tip of a thin part, the point
//    faces away from its neighbours' centroid.
// The start alone no longer decides: turning ../shared/data's models over (90° and 180° about
// x) leaves every share of inward normals as it was. Limits: through an open surface (a hollow
// plinth open below) inward rays escape too, which is why regions need a clear majority; a sheet
// thinner than the spacing still mixes its two faces in the fit.
//
// Flipped normals of inputs that come with normals (a choice beyond the paper and ALGORITHM.md §9: a scan's
// normals are at times flipped one by one, and a point whose normal opposes its neighbours' has no
// valid neighbour, eq. 6, so neither a radius nor a one-ring). A point is suspect when its normal
// is valid (validNeighbours) with at most kFlippedFits of its kNormalNearest nearest points, and
// turned around with more. The suspects are then reached by the same propagation from all the
// other points at once, each taking the sign that agrees with the point it is reached from; those
// that come out turned are the flipped ones. Repeated (at most kFlipRounds times) while it turns
// any: turning a cluster's first points leaves the others suspect. Up to kFlippedFits + 1 flipped
// neighbours are found together; a larger patch fits itself, and is taken as it is.
// Choice of kFlippedFits: a normal that is correct can oppose most of its nearest points where a
// thin part is sampled more coarsely than its thickness (../shared/data's nefertiti has its ears
// so: points there fit 3 to 7 of their 10 nearest, and the propagation turned 4 of them when all
// such points were suspects); a flipped normal mostly fits none, or the few flipped beside it.
// With 2 % of the normals of ../shared/data's sparse inputs flipped at random, 91 to 100 % of them
// are found (79 % among the fandisk's crease points, whose neighbours across the crease fit a
// flipped normal too), and no correct one is turned (input_test.cpp); the rest fit 3 or more of
// their nearest, so they keep a one-ring.
// Thread use: the PCA, the nearest points and the rays run on the given number of worker threads
// (0 = all), the rest on the calling thread; the result does not depend on the thread count.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/result.h"

namespace pnsplat {

// The neighbours of each point's plane fit (distinct positions), and its edges in the
// orientation's graph.
inline constexpr unsigned kNormalNearest = 10;
// A flipped normal fits at most this many of its kNormalNearest nearest points (findFlippedNormals).
inline constexpr unsigned kFlippedFits = 2;
inline constexpr unsigned kFlipRounds = 4;

// The unit eigenvector of the smallest eigenvalue of the symmetric 3×3 matrix m (m[r][c]; only
// the upper triangle is read), by cyclic Jacobi rotations in double precision, the three
// eigenvalues in increasing order, and the unit eigenvector of the largest. The vectors' signs are
// unspecified. A pure function; any thread.
struct SmallestEigen {
    glm::dvec3 vector;
    double values[3];
    glm::dvec3 largest;
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

// The points whose normal is flipped: the indices, in increasing order, that the propagation from
// the unsuspected points turns around (see above); empty when there are none. `points` is left
// unchanged: negate points.normal[i] (and a crease point's second normal) to repair them.
// Preconditions: finite positions, unit normals (points.normal.size() == points.size()).
// Coincident points are no one's valid neighbour. Any thread may call it (it runs its own workers,
// `threads` of them, 0 = all); the result does not depend on the thread count.
std::vector<std::uint32_t> findFlippedNormals(const PointSet& points, unsigned threads = 0);

} // namespace pnsplat
