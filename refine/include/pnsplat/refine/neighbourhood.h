// One-ring neighbourhoods: paper section 4, ALGORITHM.md §3.
//
// The Euclidean neighbourhood Nε_p (points of the current level closer than r, passing the
// validity cone of eq. 6) is filtered by the fuzzy BSP rule into Nf_p, or into Ng_p when the
// badness is measured on geodesic projections. The survivors are sorted by angle around n_p and
// form the implicit triangle fan of the local refinement.
//
// Thread use: a NeighbourSet is scratch memory owned by one thread; the functions are pure.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>
#include <span>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "pnsplat/refine/fast_math.h"

namespace pnsplat {

// A tangent frame (u, v, n) of a unit normal n, continuous except where n = (0,0,-1)
// (Duff et al., "Building an orthonormal basis, revisited", JCGT 2017).
struct TangentFrame {
    glm::vec3 u, v, n;
    explicit TangentFrame(glm::vec3 normal);
    // Angle of d's projection onto the tangent plane, in (-π, π] (within 2e-5 rad).
    float angleOf(glm::vec3 d) const { return fastAtan2(glm::dot(d, v), glm::dot(d, u)); }
};

// The widest angle that `angles` (radians in [-π, π], sorted) leave free around the circle, and
// its bisector (the whole circle when there is none).
std::pair<float, float> widestGap(std::span<const float> angles);

// Neighbours of one point as flat arrays. `index` is opaque to this module (the caller's id).
struct NeighbourSet {
    std::vector<std::uint32_t> index;
    std::vector<glm::vec3> position;
    std::vector<glm::vec3> normal;
    // Filled by sortFan/filterFuzzy: the angle around n_p in (-π, π], and the two edge control
    // points of the PN curve between p and the neighbour (ALGORITHM.md §2.2): nearControl = b_{p,i} (a third
    // of the way from p), farControl = b_{i,p}; the triangles of the fan reuse them. The control
    // points are left empty by a filterFuzzy that neither uses nor was asked for them.
    std::vector<float> angle;
    std::vector<glm::vec3> nearControl, farControl;

    std::size_t size() const { return index.size(); }
    void clear();
    void push(std::uint32_t i, glm::vec3 p, glm::vec3 n) {
        index.push_back(i);
        position.push_back(p);
        normal.push_back(n);
    }
};

struct FuzzyParams {
    float thetaF = std::numbers::pi_v<float> / 6.0f; // tolerance θf of the fuzzy plane
    // Ng instead of Nf: badness measured on the geodesic projections q'_i = p + G(p,p_i)·q̂_i.
    bool geodesicProjection = true;
    // ALGORITHM.md §10, variant (1): G(p,p_i) ≈ |p p_i| (only with geodesicProjection).
    bool euclideanGeodesic = false;
    // Fill NeighbourSet::nearControl/farControl even when the filter itself does not need them.
    bool edgeControls = true;
};

// Badness w_ij of p_i against p_j seen from p (ALGORITHM.md §3.2): with sin α =
// normalize(p_j-p)·normalize(p_i-p_j), 0 when α < -θf, else (sin α / sin θf + 1) / 2. This form takes the
// unit direction of p_j - p and the vector p_i - p_j (the filter computes the direction once per neighbour).
inline float fuzzyBadness(glm::vec3 directionJ, glm::vec3 jToI, float sinThetaF) {
    const float length2 = glm::dot(jToI, jToI);
    if (!(length2 > 0.0f)) return 0.0f;
    const float sinAlpha = glm::dot(directionJ, jToI) / std::sqrt(length2);
    if (sinAlpha < -sinThetaF) return 0.0f;
    return 0.5f * (sinAlpha / sinThetaF + 1.0f);
}
inline float fuzzyBadness(glm::vec3 p, glm::vec3 pi, glm::vec3 pj, float sinThetaF) {
    const glm::vec3 a = pj - p;
    const float length2 = glm::dot(a, a);
    if (!(length2 > 0.0f)) return 0.0f;
    return fuzzyBadness(a / std::sqrt(length2), pi - pj, sinThetaF);
}

// Vectors as flat arrays, x, y and z apart, for loops in SIMD lanes.
struct FlatVec3 {
    std::vector<float> x, y, z;
};

// Scratch buffers reused across calls (no allocation per point once warm). The float arrays keep
// their largest size; entries [0, k) belong to the last set of k entries filtered or sorted (the
// control points only where they were computed for it), and the pair loop reads up to k rounded up
// to its SIMD width.
struct NeighbourhoodScratch {
    std::vector<float> px, py, pz;    // the positions the badness is measured on
    std::vector<float> dx, dy, dz;    // their unit directions from p
    std::vector<float> su, sv;        // tangent-plane coordinates of the neighbours
    FlatVec3 position, normal;        // the set's positions and normals, split
    FlatVec3 nearControl, farControl; // their edge control points from p
    std::vector<std::uint32_t> order;
    NeighbourSet sorted;
    // Sets larger than the filter's block (sortedByDistance): the entries by distance from p, and
    // the filter's arrays in that order.
    std::vector<std::uint32_t> byDistance;
    std::vector<float> distance2;
    std::vector<float> byDistanceArrays;
};

// Filters `set` (the Euclidean neighbourhood of (p, n), validity already checked) into Nf_p or
// Ng_p and sorts the survivors by angle around n, filling set.angle.
//
// Ambiguity (ALGORITHM.md §3.2), choice made: every w_i is computed against the whole Euclidean
// neighbourhood, and all points with w_i > 1 are removed at once. The rule is then a pure function
// of the set (no dependence on the order of the neighbours), and a point strongly behind a point
// that is itself removed is still behind it. The resulting symmetry rate is measured in
// tests/neighbourhood_test.cpp.
void filterFuzzy(glm::vec3 p, glm::vec3 n, const FuzzyParams& params, NeighbourSet& set,
                 NeighbourhoodScratch& scratch);

// Sorts `set` by angle around n (fills set.angle) without filtering.
void sortFan(glm::vec3 p, glm::vec3 n, NeighbourSet& set, NeighbourhoodScratch& scratch);

} // namespace pnsplat
