// PN-triangle tools: paper section 3, ALGORITHM.md §2.
//
// Curved point-normal triangles after Vlachos, Peters, Boyd and Mitchell, "Curved PN Triangles"
// (I3D 2001), with the edge control points of Guennebaud, Barthe and Paulin (EG 2005, eq. 1-6):
// the point at a third of the edge is projected onto the tangent plane of its corner and then
// moved back to a distance of one third of the edge.
//
// Everything here is inline: these functions run several times per generated point. The three
// marked always_inline are called out of line from the refiner's x86-64-v3 clones otherwise (GCC's
// heuristics; 1.035x on the faster variants of `pnsplat bench refine` inlined, pinned A/B).
// Any thread may call them. Positions are in model units, angles in radians, normals unit length.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "pnsplat/refine/fast_math.h"

namespace pnsplat {

namespace detail {
// edgeControlPoint from third = (pb - pa)/3 and its squared length. Repeated in flat arrays by
// neighbourhood.cpp (controlFromThird, and controlPolygonLength in projectForFilter);
// FilterFuzzy.PerEntryTermsAreTheVectorFormulasBitForBit checks that they agree.
inline glm::vec3 edgeControlPointFromThird(glm::vec3 pa, glm::vec3 na, glm::vec3 third, float thirdLength2) {
    const glm::vec3 tangent = third - glm::dot(third, na) * na; // Q_a(pa + third) - pa
    const float tangentLength2 = glm::dot(tangent, tangent);
    if (tangentLength2 <= 1e-12f * thirdLength2 || tangentLength2 == 0.0f) return pa + third;
    return pa + tangent * std::sqrt(thirdLength2 / tangentLength2);
}
} // namespace detail

// Edge control point near `pa` on the edge pa→pb (ALGORITHM.md §2.2):
//   b_ab = pa + |pa pb|/3 · normalize(Q_a(pa + (pb - pa)/3) - pa),
// Q_a the orthogonal projection onto the tangent plane of pa. When pb - pa is parallel to na
// (the tangent direction is undefined; the validity cone of eq. 6 excludes such pairs) the
// unprojected third point is returned.
inline glm::vec3 edgeControlPoint(glm::vec3 pa, glm::vec3 na, glm::vec3 pb) {
    const glm::vec3 third = (pb - pa) * (1.0f / 3.0f);
    return detail::edgeControlPointFromThird(pa, na, third, glm::dot(third, third));
}

// Both control points of the edge pa pb: b_ab = edgeControlPoint(pa, na, pb) and
// b_ba = edgeControlPoint(pb, nb, pa), bit for bit. The edge's thirds in the two directions
// are exact negations of each other with the same squared length, computed once.
struct EdgeControls {
    glm::vec3 ab, ba; // near pa, near pb
};
[[gnu::always_inline]] inline EdgeControls edgeControlPoints(glm::vec3 pa, glm::vec3 na, glm::vec3 pb,
                                                             glm::vec3 nb) {
    const glm::vec3 third = (pb - pa) * (1.0f / 3.0f);
    const float thirdLength2 = glm::dot(third, third);
    return {detail::edgeControlPointFromThird(pa, na, third, thirdLength2),
            detail::edgeControlPointFromThird(pb, nb, -third, thirdLength2)};
}

// The ten control points of the PN triangle over (p0,n0), (p1,n1), (p2,n2).
// Index names follow the paper: b_ijk weights p0^i p1^j p2^k.
struct PnTriangle {
    glm::vec3 b300, b030, b003; // corners p0, p1, p2
    glm::vec3 b210, b120;       // edge p0 p1: near p0, near p1
    glm::vec3 b021, b012;       // edge p1 p2: near p1, near p2
    glm::vec3 b102, b201;       // edge p2 p0: near p2, near p0
};

inline PnTriangle makePnTriangle(glm::vec3 p0, glm::vec3 n0, glm::vec3 p1, glm::vec3 n1, glm::vec3 p2,
                                 glm::vec3 n2) {
    PnTriangle t;
    t.b300 = p0;
    t.b030 = p1;
    t.b003 = p2;
    const EdgeControls e01 = edgeControlPoints(p0, n0, p1, n1), e12 = edgeControlPoints(p1, n1, p2, n2),
                       e20 = edgeControlPoints(p2, n2, p0, n0);
    t.b210 = e01.ab;
    t.b120 = e01.ba;
    t.b021 = e12.ab;
    t.b012 = e12.ba;
    t.b102 = e20.ab;
    t.b201 = e20.ba;
    return t;
}

// Centre control point b111 = c + 3/2 (e - c), c the centroid of the corners, e the mean of the six
// edge control points (Vlachos et al.). Not needed by the refinement itself (its terms cancel in
// both the centre point and the centre derivatives) but part of the patch, used by evaluate().
inline glm::vec3 centreControlPoint(const PnTriangle& t) {
    const glm::vec3 c = (t.b300 + t.b030 + t.b003) * (1.0f / 3.0f);
    const glm::vec3 e = (t.b210 + t.b120 + t.b021 + t.b012 + t.b102 + t.b201) * (1.0f / 6.0f);
    return c + 1.5f * (e - c);
}

// B(u,v) of the cubic Bézier triangle with w = 1-u-v; u weighs p0 (b300), v weighs p1 (b030).
inline glm::vec3 evaluate(const PnTriangle& t, float u, float v) {
    const float w = 1.0f - u - v;
    const glm::vec3 b111 = centreControlPoint(t);
    return t.b300 * (u * u * u) + t.b030 * (v * v * v) + t.b003 * (w * w * w) +
           3.0f * (t.b210 * (u * u * v) + t.b120 * (u * v * v) + t.b021 * (v * v * w) + t.b012 * (v * w * w) +
                   t.b102 * (u * w * w) + t.b201 * (u * u * w)) +
           6.0f * b111 * (u * v * w);
}

// The smoothing operator (eq. 3): the displacement φ = 1/6 Σ t_i added to the centre of gravity of
// the three corners, t0 = b210-p0, t1 = b120-p1, t2 = b021-p1, t3 = b012-p2, t4 = b102-p2,
// t5 = b201-p0. cog + φ equals B(1/3,1/3), the mean of the six edge control points.
[[gnu::always_inline]] inline glm::vec3 smoothingDisplacement(const PnTriangle& t) {
    const glm::vec3 sum = (t.b210 - t.b300) + (t.b120 - t.b030) + (t.b021 - t.b030) + (t.b012 - t.b003) +
                          (t.b102 - t.b003) + (t.b201 - t.b300);
    return sum * (1.0f / 6.0f);
}

inline glm::vec3 centreOfGravity(glm::vec3 p0, glm::vec3 p1, glm::vec3 p2) {
    return (p0 + p1 + p2) * (1.0f / 3.0f);
}

// Normal of the new point: cross product of the exact partial derivatives of the patch at its
// centre (ALGORITHM.md §2.5; the tangents printed in paper section 3 are a scaled approximation that
// differs on curved triangles). With s the weight of p1 and t the weight of p2:
//   3 dB/ds = (p1-p0) + (b120-b210) + (b012-b102) + 2(b021-b201)
//   3 dB/dt = (p2-p0) + (b102-b201) + (b021-b120) + 2(b012-b210)
// oriented like n0+n1+n2. For a degenerate patch (tangents parallel within 0.5°: a sliver whose
// normal rounding decides), or one so small or so large that the squared length of its cross
// product leaves single precision's normal range (sides below about 1e-10 or above 1e9 of the
// unit; found by fuzz_refine, whose normals came out up to 15 % off unit length, or zero), the
// mean normal (meanNormal).
[[gnu::always_inline]] inline glm::vec3 meanNormal(glm::vec3 n0, glm::vec3 n1, glm::vec3 n2) {
    const glm::vec3 sum = n0 + n1 + n2;
    const float length2 = glm::dot(sum, sum);
    // Three normals that (nearly) cancel: the first one's.
    return length2 >= 1e-6f ? sum * (1.0f / std::sqrt(length2)) : n0;
}
[[gnu::always_inline]] inline glm::vec3 centreNormal(const PnTriangle& t, glm::vec3 n0, glm::vec3 n1,
                                                     glm::vec3 n2) {
    const glm::vec3 ds = (t.b030 - t.b300) + (t.b120 - t.b210) + (t.b012 - t.b102) + 2.0f * (t.b021 - t.b201);
    const glm::vec3 dt = (t.b003 - t.b300) + (t.b102 - t.b201) + (t.b021 - t.b120) + 2.0f * (t.b012 - t.b210);
    glm::vec3 n = glm::cross(ds, dt);
    const float length2 = glm::dot(n, n);
    constexpr float kMinSin2 = 7.6e-5f; // sin²(0.5°)
    if (!(length2 > kMinSin2 * glm::dot(ds, ds) * glm::dot(dt, dt)) ||
        !(length2 >= std::numeric_limits<float>::min()) || !(length2 <= std::numeric_limits<float>::max()))
        return meanNormal(n0, n1, n2);
    n *= 1.0f / std::sqrt(length2);
    return glm::dot(n, n0 + n1 + n2) < 0.0f ? -n : n;
}

// Geodesic distance (eq. 4): the length of the control polygon of the boundary curve
// between p0 and p1, G = 2/3 |p0 p1| + |b210 - b120|.
// The same from edge control points already at hand: b210 = b_01 near p0, b120 = b_10 near p1.
inline float controlPolygonLength(glm::vec3 p0, glm::vec3 p1, glm::vec3 b210, glm::vec3 b120) {
    return (2.0f / 3.0f) * glm::length(p1 - p0) + glm::length(b120 - b210);
}
inline float geodesicDistance(glm::vec3 p0, glm::vec3 n0, glm::vec3 p1, glm::vec3 n1) {
    const EdgeControls e = edgeControlPoints(p0, n0, p1, n1);
    return controlPolygonLength(p0, p1, e.ab, e.ba);
}

// Unsigned angle a-o-b in [0, π]; 0 when a or b coincides with o.
inline float angleAt(glm::vec3 o, glm::vec3 a, glm::vec3 b) {
    return angleBetween(a - o, b - o);
}

// Curved angle (eq. 5) of p0, p1 seen from p: the angles subtended by the three legs of the control
// polygon of the curve between p0 and p1, A = ∠(p0,p,b210) + ∠(b210,p,b120) + ∠(b120,p,p1).
inline float curvedAngle(glm::vec3 p, glm::vec3 p0, glm::vec3 n0, glm::vec3 p1, glm::vec3 n1) {
    const EdgeControls e = edgeControlPoints(p0, n0, p1, n1); // b210, b120
    return angleAt(p, p0, e.ab) + angleAt(p, e.ab, e.ba) + angleAt(p, e.ba, p1);
}

// For callers that only compare an angle with a right angle (θc) and rank those at or above: the
// angle, bit for bit, or 0 when it is surely below 89° (farther from π/2 than any rounding of the
// angle functions reaches), which is told from dot and cross products without arctangents.
inline constexpr float kSin2Of1Degree = 3.0459e-4f; // sin²(1°)

// angleAt(o, a, b) unless surely below 89°: cos ∠ > sin 1°.
inline float angleAtUnlessSmall(glm::vec3 o, glm::vec3 a, glm::vec3 b) {
    const glm::vec3 u = a - o, v = b - o;
    const float d = glm::dot(u, v);
    if (d > 0.0f && d * d > kSin2Of1Degree * glm::dot(u, u) * glm::dot(v, v)) return 0.0f;
    return detail::fastAtan2Upper(glm::length(glm::cross(u, v)), d);
}

// curvedAngle(p, p0, n0, p1, n1) unless surely below 89°. First without square roots: each of its
// three angles below 29° (their sum below 87°), as their squared cosines show. Then the cosine of
// the sum from the legs' dot products d and cross-product lengths x: with every angle below 90°
// the sum is below 270°, and cos(a+b+c) > sin 1° puts it below 89°. Scaled by the legs' lengths,
//   cos(a+b) ∝ d01·d12 - x01·x12,  sin(a+b) ∝ x01·d12 + d01·x12,
//   cos(a+b+c) ∝ cos(a+b)·d23 - sin(a+b)·x23 = cos(a+b+c) · |u1|²|u2|²|u0||u3|.
inline float curvedAngleUnlessSmall(glm::vec3 p, glm::vec3 p0, glm::vec3 n0, glm::vec3 p1, glm::vec3 n1) {
    const EdgeControls e = edgeControlPoints(p0, n0, p1, n1);
    const glm::vec3 u0 = p0 - p, u1 = e.ab - p, u2 = e.ba - p, u3 = p1 - p;
    const float l0 = glm::dot(u0, u0), l1 = glm::dot(u1, u1), l2 = glm::dot(u2, u2), l3 = glm::dot(u3, u3);
    const float d01 = glm::dot(u0, u1), d12 = glm::dot(u1, u2), d23 = glm::dot(u2, u3);
    constexpr float kCos2Of29Degrees = 0.764960f;
    const auto below29 = [&](float d, float la, float lb) {
        return d > 0.0f && d * d > kCos2Of29Degrees * la * lb;
    };
    if (below29(d01, l0, l1) && below29(d12, l1, l2) && below29(d23, l2, l3)) return 0.0f;
    const float x01 = glm::length(glm::cross(u0, u1)), x12 = glm::length(glm::cross(u1, u2));
    const float x23 = glm::length(glm::cross(u2, u3));
    if (d01 > 0.0f && d12 > 0.0f && d23 > 0.0f) {
        // In double precision: the sixth powers of lengths leave float's range for neighbours
        // closer than about 1e-6 (a small object measured in metres).
        const double c01 = d01, c12 = d12, c23 = d23, s01 = x01, s12 = x12, s23 = x23;
        const double cosSum2 = c01 * c12 - s01 * s12, sinSum2 = s01 * c12 + c01 * s12;
        const double cosSum3 = cosSum2 * c23 - sinSum2 * s23;
        const double scale2 = double{l1} * double{l2}, ends = double{l0} * double{l3};
        if (cosSum3 > 0.0 && cosSum3 * cosSum3 > double{kSin2Of1Degree} * scale2 * scale2 * ends) return 0.0f;
    }
    return detail::fastAtan2Upper(x01, d01) + detail::fastAtan2Upper(x12, d12) +
           detail::fastAtan2Upper(x23, d23);
}

// Neighbour validity (eq. 6, ALGORITHM.md §2.9): p1 may be a neighbour of p0 only when it lies outside the
// cone of apex p0, axis n0+n1 and half-angle γ/2 (γ the angle between the normals):
//   |(n0+n1) · normalize(p1-p0)| < 1 + n0·n1.
// The extracted paper text shows '>', which would reject coplanar points with equal normals; the
// geometric statement '<' is implemented. Symmetric in its two points. Coincident points fail.
inline bool validNeighbours(glm::vec3 p0, glm::vec3 n0, glm::vec3 p1, glm::vec3 n1) {
    const glm::vec3 d = p1 - p0;
    const float length2 = glm::dot(d, d);
    if (!(length2 > 0.0f)) return false;
    const float axial = std::abs(glm::dot(n0 + n1, d));
    return axial < (1.0f + glm::dot(n0, n1)) * std::sqrt(length2);
}

} // namespace pnsplat
