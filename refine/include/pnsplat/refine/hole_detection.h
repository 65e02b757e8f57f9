// Holes of an input found without being told where they are (ALGORITHM.md §9.8; not in the paper,
// whose figure 9 fills a hole the user marks; its section 6 finds boundaries by the angle a
// point's neighbours leave open). A hole is a region of the surface where the sampling leaves an
// empty ball several times its local spacing wide, surrounded by points on every side.
//
// 1. Rim points. A point is on a rim when its kHoleNearest nearest points, projected onto its
//    tangent plane, leave an angle of at least kHoleRimAngle open (the θb test of section 6 with
//    a looser angle: a rim point of a sparse random sampling sees neighbours along the rim). Its
//    empty ball is the largest ball through it whose centre lies along the open angle's bisector in
//    the tangent plane and holds no input point (at most half of maxSize wide); a rim point whose
//    empty ball is more than kHoleEmptySpacings times its local spacing (the median nearest-point
//    distance of it and its neighbours) proposes that ball. Random samplings leave empty balls up to
//    2–3 spacings wide; a hole, many more.
// 2. Holes. Proposals whose balls overlap belong to one hole. A hole needs kHoleMinRimPoints rim
//    points that surround the centroid of their positions: seen along their mean normal, no angle
//    of more than kHoleSurroundAngle around it is free of them. An open boundary (a scan's edge, a
//    statue's base) and the outside of a sharp tip are rims on one side only, and are not holes.
//    Nor is a rim whose normals spread round (a tube's end, a hemisphere's edge): the length of
//    the mean of its unit normals must reach kHoleRimAlignment (a hole in a surface has its
//    surroundings' normals, about one direction).
// 3. Its ball, for enlargeAroundHoles (refiner.h): centred at that centroid, of radius just under
//    the distance to the nearest input point, which must exceed kHoleEmptyShare times the rim's
//    radius (the largest distance from the centroid to a rim point): rims around a fold or a
//    concave crevice have input points near their centroid. Its size is the rim's diameter.
// Crease points (PointSet::crease) are never rim points: their neighbours across the crease lie
// off their tangent plane.
//
// Thread use: any thread; the per-point work runs on the given number of worker threads (0 = all),
// and the result does not depend on it. Cost: O(n log n) for the rims, plus a ball search of
// radius maxSize / 2 per rim point, plus O(P²) for P proposals (a few per hole: a clean scan has
// few).
#pragma once

#include <cstddef>
#include <vector>

#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/refiner.h"

namespace pnsplat {

inline constexpr unsigned kHoleNearest = 16;
inline constexpr float kHoleRimAngle = 1.5707964f; // π/2
inline constexpr float kHoleEmptySpacings = 3.0f;
inline constexpr std::size_t kHoleMinRimPoints = 6;
inline constexpr float kHoleSurroundAngle = 1.5707964f; // π/2
inline constexpr float kHoleEmptyShare = 0.25f;
inline constexpr double kHoleRimAlignment = 0.5;

struct FoundHole {
    Hole ball;                 // to fill (enlargeAroundHoles)
    float size = 0.0f;         // the rim's diameter, model units
    std::size_t rimPoints = 0; // the points that proposed it
};

struct HoleSearch {
    std::vector<FoundHole> holes;    // of size at most maxSize, in order of their first rim point
    std::vector<FoundHole> tooLarge; // closed rims wider than maxSize (left open)
    float spacing = 0.0f;            // the median nearest-point distance of the input
    // The size asked for, in model units, at most the model's diagonal (0: nothing searched).
    float maxSize = 0.0f;
};

// The holes of `points` (unit normals needed; distinct positions) up to `maxSize` wide, in model
// units, or, with `relative`, in multiples of the median nearest-point distance; a size past the
// diagonal of the points' bounding box is that diagonal. Fewer than
// kHoleNearest + 1 points or a maxSize that is not positive and finite: nothing found.
HoleSearch findHoles(const PointSet& points, float maxSize, bool relative = false, unsigned threads = 0);

} // namespace pnsplat
