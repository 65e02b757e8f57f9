// Tests of the PN-triangle tools (pn_triangle.h, ALGORITHM.md §2) and the fast angle functions
// (fast_math.h). Oracles: the geometric definition of each construction (tangent plane, third of the
// edge), finite differences of the Bézier patch for the normals, closed forms on circles, spheres and
// planes, std::atan2 / std::acos in double for the angle functions.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "pnsplat/refine/angles.h"
#include "pnsplat/refine/fast_math.h"
#include "pnsplat/refine/pn_triangle.h"
#include "test_random.h"

namespace pnsplat {
namespace {

using test::randomUnit;
using test::uniform;
using test::uniform01;

constexpr double kPi = std::numbers::pi;

// An orthonormal pair (u, v) perpendicular to the unit vector n (double Gram-Schmidt).
void tangents(glm::vec3 n, glm::vec3& u, glm::vec3& v) {
    const glm::dvec3 dn(n);
    const glm::dvec3 seed = std::abs(dn.x) < 0.6 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
    const glm::dvec3 du = glm::normalize(seed - glm::dot(seed, dn) * dn);
    u = glm::vec3(du);
    v = glm::vec3(glm::cross(dn, du));
}

struct Triangle {
    glm::vec3 p[3], n[3];
    PnTriangle pn() const { return makePnTriangle(p[0], n[0], p[1], n[1], p[2], n[2]); }
};

// Three points of the unit sphere at angular distance [minDeg, maxDeg] from a random centre
// direction, roughly 120° apart around it, with radial normals: a curved PN triangle.
Triangle sphereTriangle(std::mt19937_64& rng, double minDeg, double maxDeg) {
    const glm::vec3 c = randomUnit(rng);
    glm::vec3 u, v;
    tangents(c, u, v);
    const double phase = 2.0 * kPi * uniform01(rng);
    Triangle t;
    for (int k = 0; k < 3; ++k) {
        const double theta = radians(minDeg + (maxDeg - minDeg) * uniform01(rng));
        const double phi = phase + 2.0 * kPi * k / 3.0 + 0.3 * (uniform01(rng) - 0.5);
        const glm::dvec3 dir =
            glm::dvec3(c) * std::cos(theta) +
            (glm::dvec3(u) * std::cos(phi) + glm::dvec3(v) * std::sin(phi)) * std::sin(theta);
        t.p[k] = glm::vec3(glm::normalize(dir));
        t.n[k] = t.p[k];
    }
    return t;
}

// Central finite-difference normal of evaluate() at barycentric (u0 = weight of p0, s0 = weight
// of p1, t0 = weight of p2), derivatives along the weights s of p1 and t of p2 (u = 1 - s - t).
glm::vec3 finiteDifferenceNormal(const PnTriangle& t, float s0, float t0, float h) {
    const auto at = [&](float s, float tt) { return glm::dvec3(evaluate(t, 1.0f - s - tt, s)); };
    const glm::dvec3 ds = (at(s0 + h, t0) - at(s0 - h, t0)) / (2.0 * static_cast<double>(h));
    const glm::dvec3 dt = (at(s0, t0 + h) - at(s0, t0 - h)) / (2.0 * static_cast<double>(h));
    return glm::vec3(glm::normalize(glm::cross(ds, dt)));
}

// The tangents printed in paper section 3 (ALGORITHM.md §2.5), which are not the patch's derivatives.
glm::vec3 paperNormal(const PnTriangle& t, glm::vec3 orientation) {
    const glm::vec3 p0 = t.b300, p1 = t.b030, p2 = t.b003;
    const glm::vec3 bu = 7.0f * (p1 - p0) + t.b120 - t.b102 + t.b012 - t.b210 + 2.0f * (t.b021 - t.b201);
    const glm::vec3 bv = 7.0f * (p2 - p0) + t.b102 - t.b120 + t.b021 - t.b201 + 2.0f * (t.b012 - t.b210);
    const glm::vec3 n = glm::normalize(glm::cross(bu, bv));
    return glm::dot(n, orientation) < 0.0f ? -n : n;
}

// ---------------------------------------------------------------------------------------------
// edgeControlPoint

TEST(EdgeControlPoint, InTangentPlaneAtOneThirdAlongProjectedEdge) {
    std::mt19937_64 rng(101);
    int tested = 0;
    for (int trial = 0; trial < 2000; ++trial) {
        const glm::vec3 pa(uniform(rng, -2, 2), uniform(rng, -2, 2), uniform(rng, -2, 2));
        const glm::vec3 pb(uniform(rng, -2, 2), uniform(rng, -2, 2), uniform(rng, -2, 2));
        const glm::vec3 na = randomUnit(rng);
        const glm::dvec3 d = glm::dvec3(pb) - glm::dvec3(pa);
        const glm::dvec3 projected = d - glm::dot(d, glm::dvec3(na)) * glm::dvec3(na);
        if (glm::length(projected) < 0.05 * glm::length(d)) continue; // nearly along the normal
        ++tested;
        const glm::vec3 b = edgeControlPoint(pa, na, pb);
        const glm::dvec3 offset = glm::dvec3(b) - glm::dvec3(pa);
        const double edge = glm::length(d);
        EXPECT_NEAR(glm::dot(offset, glm::dvec3(na)), 0.0, 2e-6 * (1.0 + edge)) << trial;
        EXPECT_NEAR(glm::length(offset), edge / 3.0, 2e-6 * (1.0 + edge)) << trial;
        EXPECT_LT(angleInDegrees(glm::vec3(offset), glm::vec3(projected)), 1e-3) << trial;
    }
    EXPECT_GT(tested, 1800);
}

TEST(EdgeControlPoint, FlatCaseIsOneThirdOfTheEdge) {
    const glm::vec3 n(0.0f, 0.0f, 1.0f);
    const glm::vec3 pa(0.5f, -1.25f, 3.0f), pb(2.0f, 1.75f, 3.0f);
    const glm::vec3 b = edgeControlPoint(pa, n, pb);
    const glm::vec3 expected = pa + (pb - pa) / 3.0f;
    EXPECT_NEAR(b.x, expected.x, 1e-6f);
    EXPECT_NEAR(b.y, expected.y, 1e-6f);
    EXPECT_EQ(b.z, 3.0f);
    // A tilted plane, both normals equal and perpendicular to the edge.
    const glm::vec3 tilted = glm::normalize(glm::vec3(1.0f, 2.0f, 2.0f));
    const glm::vec3 qa(1.0f, 1.0f, 1.0f);
    const glm::vec3 qb = qa + glm::cross(tilted, glm::vec3(0.0f, 0.0f, 1.0f)) * 3.0f;
    const glm::vec3 c = edgeControlPoint(qa, tilted, qb);
    const glm::vec3 expectedC = qa + (qb - qa) / 3.0f;
    EXPECT_LT(glm::length(c - expectedC), 1e-6f);
}

TEST(EdgeControlPoint, EdgeAlongTheNormalReturnsTheUnprojectedThird) {
    // Documented fallback: the tangent direction is undefined.
    const glm::vec3 pa(1.0f, 2.0f, 3.0f), n(0.0f, 1.0f, 0.0f);
    const glm::vec3 pb = pa + 3.0f * n;
    const glm::vec3 b = edgeControlPoint(pa, n, pb);
    EXPECT_EQ(b, pa + (pb - pa) * (1.0f / 3.0f));
    EXPECT_EQ(edgeControlPoint(pa, n, pa), pa); // zero-length edge: no NaN
}

// ---------------------------------------------------------------------------------------------
// makePnTriangle / evaluate

TEST(PnTriangle, ControlPointNamingFollowsThePaper) {
    std::mt19937_64 rng(7);
    const Triangle t = sphereTriangle(rng, 15.0, 30.0);
    const PnTriangle pn = t.pn();
    EXPECT_EQ(pn.b300, t.p[0]);
    EXPECT_EQ(pn.b030, t.p[1]);
    EXPECT_EQ(pn.b003, t.p[2]);
    // b_ijk weighs p0^i p1^j p2^k: b210 is on edge p0p1 near p0, etc.
    EXPECT_EQ(pn.b210, edgeControlPoint(t.p[0], t.n[0], t.p[1]));
    EXPECT_EQ(pn.b120, edgeControlPoint(t.p[1], t.n[1], t.p[0]));
    EXPECT_EQ(pn.b021, edgeControlPoint(t.p[1], t.n[1], t.p[2]));
    EXPECT_EQ(pn.b012, edgeControlPoint(t.p[2], t.n[2], t.p[1]));
    EXPECT_EQ(pn.b102, edgeControlPoint(t.p[2], t.n[2], t.p[0]));
    EXPECT_EQ(pn.b201, edgeControlPoint(t.p[0], t.n[0], t.p[2]));
    // Each is nearer the corner it belongs to (a geometric check independent of the above).
    const auto nearer = [](glm::vec3 b, glm::vec3 own, glm::vec3 other) {
        return glm::length(b - own) < glm::length(b - other);
    };
    EXPECT_TRUE(nearer(pn.b210, t.p[0], t.p[1]));
    EXPECT_TRUE(nearer(pn.b120, t.p[1], t.p[0]));
    EXPECT_TRUE(nearer(pn.b021, t.p[1], t.p[2]));
    EXPECT_TRUE(nearer(pn.b012, t.p[2], t.p[1]));
    EXPECT_TRUE(nearer(pn.b102, t.p[2], t.p[0]));
    EXPECT_TRUE(nearer(pn.b201, t.p[0], t.p[2]));
}

TEST(PnTriangle, EvaluateInterpolatesCornersBitForBit) {
    std::mt19937_64 rng(8);
    for (int trial = 0; trial < 50; ++trial) {
        const Triangle t = sphereTriangle(rng, 5.0, 30.0);
        const PnTriangle pn = t.pn();
        EXPECT_EQ(evaluate(pn, 1.0f, 0.0f), t.p[0]);
        EXPECT_EQ(evaluate(pn, 0.0f, 1.0f), t.p[1]);
        EXPECT_EQ(evaluate(pn, 0.0f, 0.0f), t.p[2]);
    }
}

TEST(PnTriangle, PatchNormalInterpolatesCornerNormals) {
    std::mt19937_64 rng(9);
    const float h = 1e-3f;
    double worst = 0.0, flatFaceDeviation = 1e9;
    for (int trial = 0; trial < 50; ++trial) {
        const Triangle t = sphereTriangle(rng, 15.0, 30.0);
        const PnTriangle pn = t.pn();
        const glm::vec3 face = glm::normalize(glm::cross(t.p[1] - t.p[0], t.p[2] - t.p[0]));
        // One-sided differences from each corner along its two edges (barycentric (u, v)).
        struct CornerCase {
            float u, v;     // the corner
            float du1, dv1; // towards the next corner
            float du2, dv2; // towards the previous corner
        };
        const CornerCase cases[3] = {{1, 0, -h, h, -h, 0}, {0, 1, 0, -h, h, -h}, {0, 0, 0, h, h, 0}};
        for (int k = 0; k < 3; ++k) {
            const CornerCase& c = cases[k];
            const glm::dvec3 at(evaluate(pn, c.u, c.v));
            const glm::dvec3 e1 = glm::dvec3(evaluate(pn, c.u + c.du1, c.v + c.dv1)) - at;
            const glm::dvec3 e2 = glm::dvec3(evaluate(pn, c.u + c.du2, c.v + c.dv2)) - at;
            glm::vec3 n(glm::normalize(glm::cross(e1, e2)));
            if (glm::dot(n, t.n[k]) < 0.0f) n = -n;
            worst = std::max(worst, angleInDegrees(n, t.n[k]));
            flatFaceDeviation = std::min(
                flatFaceDeviation, std::min(angleInDegrees(face, t.n[k]), angleInDegrees(-face, t.n[k])));
        }
    }
    EXPECT_LT(worst, 0.2);
    // The corner normals are far from the flat face normal, so the check above is meaningful.
    EXPECT_GT(flatFaceDeviation, 3.0);
}

// ---------------------------------------------------------------------------------------------
// Smoothing operator and centre normal

TEST(SmoothingOperator, EqualsPatchCentreAndMeanOfEdgeControlPoints) {
    std::mt19937_64 rng(10);
    double worstSmoothingVsCentroid = 0.0;
    for (int trial = 0; trial < 200; ++trial) {
        const Triangle t = sphereTriangle(rng, 5.0, 35.0);
        const PnTriangle pn = t.pn();
        const glm::vec3 cog = centreOfGravity(t.p[0], t.p[1], t.p[2]);
        EXPECT_LT(glm::length(cog - (t.p[0] + t.p[1] + t.p[2]) / 3.0f), 1e-6f);
        const glm::vec3 pNew = cog + smoothingDisplacement(pn);
        const glm::vec3 centre = evaluate(pn, 1.0f / 3.0f, 1.0f / 3.0f);
        const glm::vec3 mean = (pn.b210 + pn.b120 + pn.b021 + pn.b012 + pn.b102 + pn.b201) / 6.0f;
        EXPECT_LT(glm::length(pNew - centre), 2e-6f) << trial;
        EXPECT_LT(glm::length(pNew - mean), 2e-6f) << trial;
        worstSmoothingVsCentroid =
            std::max(worstSmoothingVsCentroid, static_cast<double>(glm::length(pNew - cog)));
        // On the unit sphere the new point is pushed outwards from the flat centroid.
        EXPECT_GT(glm::length(pNew), glm::length(cog)) << trial;
    }
    EXPECT_GT(worstSmoothingVsCentroid, 1e-2); // the displacement is not trivially zero
}

TEST(CentreNormal, MatchesFiniteDifferencesOfThePatch) {
    std::mt19937_64 rng(11);
    double worst = 0.0, worstPaper = 0.0;
    for (int trial = 0; trial < 40; ++trial) {
        const Triangle t = sphereTriangle(rng, 15.0, 30.0);
        const PnTriangle pn = t.pn();
        const glm::vec3 orientation = t.n[0] + t.n[1] + t.n[2];
        const glm::vec3 n = centreNormal(pn, t.n[0], t.n[1], t.n[2]);
        EXPECT_NEAR(glm::length(n), 1.0f, 1e-6f);
        EXPECT_GT(glm::dot(n, orientation), 0.0f);
        glm::vec3 fd = finiteDifferenceNormal(pn, 1.0f / 3.0f, 1.0f / 3.0f, 1e-2f);
        if (glm::dot(fd, orientation) < 0.0f) fd = -fd;
        worst = std::max(worst, angleInDegrees(n, fd));
        worstPaper = std::max(worstPaper, angleInDegrees(paperNormal(pn, orientation), fd));
    }
    std::cout << "centre normal vs finite differences: exact " << worst << " deg, paper's printed tangents "
              << worstPaper << " deg\n";
    EXPECT_LT(worst, 0.01);
    // The printed tangents are measurably off on curved triangles: the exact ones are in use.
    EXPECT_GT(worstPaper, 0.1);
}

TEST(CentreNormal, PaperTangentsAgreeOnFlatTriangles) {
    std::mt19937_64 rng(12);
    for (int trial = 0; trial < 50; ++trial) {
        const glm::vec3 normal = randomUnit(rng);
        glm::vec3 u, v;
        tangents(normal, u, v);
        const glm::vec3 origin(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
        Triangle t;
        for (int k = 0; k < 3; ++k) {
            const double phi = 2.0 * kPi * k / 3.0 + 0.5 * uniform01(rng);
            const float r = uniform(rng, 0.5, 1.5);
            t.p[k] =
                origin + r * (static_cast<float>(std::cos(phi)) * u + static_cast<float>(std::sin(phi)) * v);
            t.n[k] = normal;
        }
        const PnTriangle pn = t.pn();
        const glm::vec3 exact = centreNormal(pn, t.n[0], t.n[1], t.n[2]);
        EXPECT_LT(angleInDegrees(exact, normal), 1e-3) << trial;
        EXPECT_LT(angleInDegrees(paperNormal(pn, normal), exact), 1e-3) << trial;
        // The new point stays in the plane, at the centroid.
        const glm::vec3 cog = centreOfGravity(t.p[0], t.p[1], t.p[2]);
        EXPECT_LT(glm::length(smoothingDisplacement(pn)), 1e-5f) << trial;
        EXPECT_LT(glm::length(evaluate(pn, 1.0f / 3.0f, 1.0f / 3.0f) - cog), 1e-5f) << trial;
    }
}

TEST(CentreNormal, SphereTriangleGivesRadialNormalNearTheSphere) {
    std::mt19937_64 rng(13);
    double worstAngle = 0.0, worstDistance = 0.0;
    for (int trial = 0; trial < 200; ++trial) {
        const Triangle t = sphereTriangle(rng, 5.0, 15.0);
        const PnTriangle pn = t.pn();
        const glm::vec3 pNew = centreOfGravity(t.p[0], t.p[1], t.p[2]) + smoothingDisplacement(pn);
        const glm::vec3 n = centreNormal(pn, t.n[0], t.n[1], t.n[2]);
        const double edge = std::max(
            {glm::length(t.p[1] - t.p[0]), glm::length(t.p[2] - t.p[1]), glm::length(t.p[0] - t.p[2])});
        worstAngle = std::max(worstAngle, angleInDegrees(n, pNew));
        worstDistance =
            std::max(worstDistance, std::abs(static_cast<double>(glm::length(pNew)) - 1.0) / edge);
    }
    std::cout << "sphere triangles (5-15 deg): worst normal error " << worstAngle << " deg, worst distance "
              << worstDistance << " edge lengths\n";
    EXPECT_LT(worstAngle, 0.1);
    EXPECT_LT(worstDistance, 0.01);
}

TEST(CentreNormal, CollinearSliverFallsBackToMeanNormal) {
    // Corners on the x axis, normals all perpendicular to it but different: every control point lies
    // on the axis, the patch degenerates to a segment.
    const glm::vec3 p0(0.0f, 0.0f, 0.0f), p1(1.0f, 0.0f, 0.0f), p2(2.5f, 0.0f, 0.0f);
    const glm::vec3 n0(0.0f, 0.0f, 1.0f);
    const glm::vec3 n1 = glm::normalize(glm::vec3(0.0f, 0.3f, 1.0f));
    const glm::vec3 n2 = glm::normalize(glm::vec3(0.0f, -0.2f, 1.0f));
    const PnTriangle pn = makePnTriangle(p0, n0, p1, n1, p2, n2);
    const glm::vec3 n = centreNormal(pn, n0, n1, n2);
    const glm::vec3 expected = glm::normalize(n0 + n1 + n2);
    EXPECT_LT(glm::length(n - expected), 1e-6f);
    EXPECT_TRUE(std::isfinite(n.x) && std::isfinite(n.y) && std::isfinite(n.z));
    // Fully coincident corners: same fallback, no NaN.
    const PnTriangle point = makePnTriangle(p1, n0, p1, n1, p1, n2);
    EXPECT_LT(glm::length(centreNormal(point, n0, n1, n2) - expected), 1e-6f);
}

// A patch so small or so large that its cross product's squared length is no normal float (found
// by fuzz_refine): the mean normal, of unit length, where the division by a denormal length gave
// normals up to 15 % off, and by an infinite one zero. Normals that cancel: the first corner's.
TEST(CentreNormal, TinyPatchGivesAUnitNormal) {
    const glm::vec3 n0 = glm::normalize(glm::vec3(0.1f, 0.0f, 1.0f)),
                    n1 = glm::normalize(glm::vec3(0.0f, 0.2f, 1.0f));
    const glm::vec3 n2 = glm::normalize(glm::vec3(-0.1f, -0.1f, 1.0f));
    for (const float side : {1e-8f, 1e-10f, 1e-12f, 1e-20f, 1e9f, 1e10f, 1e15f}) {
        const PnTriangle pn = makePnTriangle(glm::vec3(0.0f), n0, glm::vec3(side, 0.0f, 0.0f), n1,
                                             glm::vec3(0.0f, side, 0.0f), n2);
        const glm::vec3 n = centreNormal(pn, n0, n1, n2);
        EXPECT_NEAR(glm::length(n), 1.0f, 1e-6f) << side;
        EXPECT_GT(n.z, 0.9f) << side;
    }
    const glm::vec3 up(0.0f, 0.0f, 1.0f), a = glm::normalize(glm::vec3(0.0f, 0.866025f, -0.5f));
    const glm::vec3 b = glm::normalize(glm::vec3(0.0f, -0.866025f, -0.5f)); // up + a + b ≈ 0
    EXPECT_EQ(meanNormal(up, a, b), up);
}

// ---------------------------------------------------------------------------------------------
// Geodesic distance, curved angle

TEST(GeodesicDistance, FlatEqualsEuclidean) {
    const glm::vec3 n(0.0f, 0.0f, 1.0f);
    const glm::vec3 p0(0.25f, 1.0f, -2.0f), p1(3.25f, -3.0f, -2.0f); // |d| = 5
    EXPECT_NEAR(geodesicDistance(p0, n, p1, n), 5.0f, 2e-6f);
}

TEST(GeodesicDistance, CircularArcClosedForm) {
    // Two points of the unit circle at angle θ with radial normals: the legs are chord/3 at the
    // circle's tangents, so G = chord (5/3 - 2/3 cos(θ/2)); chord < G ≈ θ (1 + θ²/24).
    const double startDeg[] = {0.0, 37.0, 200.0};
    for (double start : startDeg) {
        for (double deg : {5.0, 10.0, 30.0, 60.0, 90.0}) {
            const double a = radians(start), b = radians(start + deg), theta = radians(deg);
            const glm::vec3 p0(static_cast<float>(std::cos(a)), static_cast<float>(std::sin(a)), 0.0f);
            const glm::vec3 p1(static_cast<float>(std::cos(b)), static_cast<float>(std::sin(b)), 0.0f);
            const double g = geodesicDistance(p0, p0, p1, p1);
            const double chord = 2.0 * std::sin(theta / 2.0);
            EXPECT_NEAR(g, chord * (5.0 / 3.0 - 2.0 / 3.0 * std::cos(theta / 2.0)), 2e-6) << deg;
            EXPECT_GT(g, chord * (1.0 + theta * theta / 48.0)) << deg;
            EXPECT_LT(std::abs(g / theta - 1.0), theta * theta / 12.0) << deg;
        }
    }
}

TEST(GeodesicDistance, SymmetricAndEqualToControlPolygonLength) {
    std::mt19937_64 rng(14);
    for (int trial = 0; trial < 1000; ++trial) {
        const glm::vec3 p0(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
        const glm::vec3 p1(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
        const glm::vec3 n0 = randomUnit(rng), n1 = randomUnit(rng);
        const float g = geodesicDistance(p0, n0, p1, n1);
        EXPECT_FLOAT_EQ(g, geodesicDistance(p1, n1, p0, n0)) << trial;
        const PnTriangle pn = makePnTriangle(p0, n0, p1, n1, p1 + glm::vec3(0.1f), n1);
        EXPECT_FLOAT_EQ(controlPolygonLength(p0, p1, pn.b210, pn.b120), g) << trial;
        // The literal polygon p0 -> b210 -> b120 -> p1.
        const double polygon = glm::length(glm::dvec3(pn.b210) - glm::dvec3(p0)) +
                               glm::length(glm::dvec3(pn.b120) - glm::dvec3(pn.b210)) +
                               glm::length(glm::dvec3(p1) - glm::dvec3(pn.b120));
        EXPECT_NEAR(g, polygon, 1e-5 * (1.0 + polygon)) << trial;
        EXPECT_GE(g, glm::length(p1 - p0) * (1.0f - 1e-6f)) << trial;
    }
}

TEST(CurvedAngle, FlatCaseEqualsPlainAngle) {
    std::mt19937_64 rng(15);
    const glm::vec3 n(0.0f, 0.0f, 1.0f);
    for (int trial = 0; trial < 500; ++trial) {
        const glm::vec3 p(uniform(rng, -1, 1), uniform(rng, -1, 1), 0.5f);
        const glm::vec3 p0(uniform(rng, -1, 1), uniform(rng, -1, 1), 0.5f);
        const glm::vec3 p1(uniform(rng, -1, 1), uniform(rng, -1, 1), 0.5f);
        const double plain = std::acos(std::clamp(
            glm::dot(glm::normalize(glm::dvec3(p0 - p)), glm::normalize(glm::dvec3(p1 - p))), -1.0, 1.0));
        EXPECT_NEAR(curvedAngle(p, p0, n, p1, n), plain, 1e-4) << trial;
    }
}

// Eq. 5 in double precision from the definitions of ALGORITHM.md §2.2 alone: b_ab = p_a + |p_a p_b|/3 ·
// normalize(Q_a(p_a + (p_b - p_a)/3) - p_a), then the three angles at p by acos. A swapped or
// misplaced control point (∠(p0,p,b120), b_ab from the wrong end) moves the sum by far more.
TEST(CurvedAngle, MatchesEquationFiveInDoublePrecision) {
    const auto control = [](glm::dvec3 a, glm::dvec3 na, glm::dvec3 b) {
        const glm::dvec3 third = a + (b - a) / 3.0;
        const glm::dvec3 projected = third + glm::dot(a - third, na) * na; // Q_a
        return a + glm::length(b - a) / 3.0 * glm::normalize(projected - a);
    };
    const auto angle = [](glm::dvec3 o, glm::dvec3 a, glm::dvec3 b) {
        return std::acos(std::clamp(glm::dot(glm::normalize(a - o), glm::normalize(b - o)), -1.0, 1.0));
    };
    std::mt19937_64 rng(18);
    double worst = 0.0;
    for (int trial = 0; trial < 1000; ++trial) {
        Triangle t = sphereTriangle(rng, 10.0, 45.0);
        // Tilted normals for half of the trials: the control points then leave the sphere's planes.
        if (trial % 2 == 1)
            for (glm::vec3& n : t.n) n = glm::normalize(n + 0.3f * randomUnit(rng));
        const glm::dvec3 p(t.p[0]), p0(t.p[1]), p1(t.p[2]), n0(t.n[1]), n1(t.n[2]);
        const glm::dvec3 b210 = control(p0, n0, p1), b120 = control(p1, n1, p0);
        const double expected = angle(p, p0, b210) + angle(p, b210, b120) + angle(p, b120, p1);
        const double error =
            std::abs(static_cast<double>(curvedAngle(t.p[0], t.p[1], t.n[1], t.p[2], t.n[2])) - expected);
        worst = std::max(worst, error);
        EXPECT_LT(error, 1e-4) << trial;
    }
    std::cout << "curved angle against eq. 5 in double: largest difference " << worst << " rad\n";
}

TEST(CurvedAngle, CurvedCaseIsAtLeastThePlainAngle) {
    std::mt19937_64 rng(16);
    double largestExcess = 0.0;
    for (int trial = 0; trial < 1000; ++trial) {
        const Triangle t = sphereTriangle(rng, 10.0, 40.0);
        const float curved = curvedAngle(t.p[0], t.p[1], t.n[1], t.p[2], t.n[2]);
        const float plain = angleAt(t.p[0], t.p[1], t.p[2]);
        EXPECT_GE(curved, plain - 1e-4f) << trial;
        largestExcess = std::max(largestExcess, static_cast<double>(curved - plain));
    }
    // A hand-made curved case: p at the pole, p0 and p1 at 40° latitude distance, 90° apart.
    const auto onSphere = [](double polar, double azimuth) {
        return glm::vec3(static_cast<float>(std::sin(polar) * std::cos(azimuth)),
                         static_cast<float>(std::sin(polar) * std::sin(azimuth)),
                         static_cast<float>(std::cos(polar)));
    };
    const glm::vec3 p = onSphere(0.0, 0.0);
    const glm::vec3 p0 = onSphere(radians(40.0), -kPi / 4.0), p1 = onSphere(radians(40.0), kPi / 4.0);
    const float curved = curvedAngle(p, p0, p0, p1, p1);
    const float plain = angleAt(p, p0, p1);
    std::cout << "curved angle, pole case: curved " << curved << " plain " << plain
              << " rad; random max excess " << largestExcess << " rad\n";
    EXPECT_GT(curved, plain + 0.01f);
    EXPECT_GT(largestExcess, 0.01);
}

// The shortcuts for gaps of N'_p: either the angle bit for bit, or 0 for an angle surely below θc
// (measured in double precision, below 89°), and both occur; the curved angle's second test (the
// cosine of the sum) takes sums from 87° on. Also at the scale of a small object in metres, where
// the sixth powers of the legs' lengths leave float's range.
TEST(CurvedAngle, UnlessSmallIsExactOrZeroOnlyBelowARightAngle) {
    std::mt19937_64 rng(17);
    const auto around = [&](glm::vec3 centre, double polarDeg) {
        glm::vec3 u, v;
        tangents(centre, u, v);
        const double theta = radians(polarDeg), phi = 2.0 * kPi * uniform01(rng);
        return glm::vec3(glm::normalize(glm::dvec3(centre) * std::cos(theta) +
                                        (glm::dvec3(u) * std::cos(phi) + glm::dvec3(v) * std::sin(phi)) *
                                            std::sin(theta)));
    };
    const auto referenceAngle = [](glm::vec3 o, glm::vec3 a, glm::vec3 b) {
        const glm::dvec3 u = glm::normalize(glm::dvec3(a - o)), v = glm::normalize(glm::dvec3(b - o));
        return std::acos(std::clamp(glm::dot(u, v), -1.0, 1.0));
    };
    for (const float scale : {1.0f, 1e-5f}) {
        int skipped = 0, skippedAbove87 = 0, exact = 0, plainSkipped = 0, plainExact = 0;
        for (int trial = 0; trial < 4000; ++trial) {
            const glm::vec3 p = randomUnit(rng);
            const glm::vec3 p0 = around(p, uniform(rng, 2, 50)), p1 = around(p, uniform(rng, 2, 50));
            // Normals of the sphere, tilted by up to 20° for half of the trials.
            const float tilt = trial % 2 == 0 ? 0.0f : uniform(rng, 0, 20);
            const glm::vec3 n0 = around(p0, tilt), n1 = around(p1, tilt);
            // A sphere of radius `scale` around the origin: p, p0 and p1 on it.
            const glm::vec3 sp = p * scale, sp0 = p0 * scale, sp1 = p1 * scale;

            const float plainValue = angleAtUnlessSmall(sp, sp0, sp1);
            if (plainValue != 0.0f) {
                EXPECT_EQ(plainValue, angleAt(sp, sp0, sp1)) << trial;
                ++plainExact;
            } else {
                EXPECT_LT(referenceAngle(sp, sp0, sp1), radians(89.001)) << trial;
                ++plainSkipped;
            }

            const float value = curvedAngleUnlessSmall(sp, sp0, n0, sp1, n1);
            const float curved = curvedAngle(sp, sp0, n0, sp1, n1);
            if (value != 0.0f) {
                EXPECT_EQ(value, curved) << trial;
                ++exact;
                continue;
            }
            ++skipped;
            const EdgeControls e = edgeControlPoints(sp0, n0, sp1, n1);
            const double reference = referenceAngle(sp, sp0, e.ab) + referenceAngle(sp, e.ab, e.ba) +
                                     referenceAngle(sp, e.ba, sp1);
            EXPECT_LT(reference, radians(89.001)) << trial;
            EXPECT_LT(curved, kPi / 2.0) << trial;
            if (reference > radians(87.0)) ++skippedAbove87;
        }
        std::cout << "scale " << scale << ": curved angle shortcut: " << skipped
                  << " surely below a right angle (" << skippedAbove87 << " from 87°), " << exact
                  << " measured; plain angle: " << plainSkipped << " and " << plainExact << "\n";
        EXPECT_GT(skipped, 400);
        EXPECT_GT(skippedAbove87, 20);
        EXPECT_GT(exact, 400);
        EXPECT_GT(plainSkipped, 400);
        EXPECT_GT(plainExact, 400);
    }
}

// ---------------------------------------------------------------------------------------------
// Neighbour validity (eq. 6 with '<')

TEST(ValidNeighbours, HandMadeCases) {
    const glm::vec3 z(0.0f, 0.0f, 1.0f);
    const glm::vec3 p0(0.0f, 0.0f, 0.0f);
    // Coplanar, equal normals: valid (the printed '>' would reject this).
    EXPECT_TRUE(validNeighbours(p0, z, glm::vec3(1.0f, 0.5f, 0.0f), z));
    // Straight along the normal axis: invalid.
    EXPECT_FALSE(validNeighbours(p0, z, glm::vec3(0.0f, 0.0f, 0.3f), z));
    EXPECT_FALSE(validNeighbours(p0, z, glm::vec3(0.0f, 0.0f, -0.3f), z));
    // Exactly zero distance: invalid.
    EXPECT_FALSE(validNeighbours(p0, z, p0, z));
    EXPECT_FALSE(validNeighbours(glm::vec3(0.3f, -2.0f, 7.0f), z, glm::vec3(0.3f, -2.0f, 7.0f), z));
    // Thin wall: opposite normals, separated along the normal, with or without lateral offset.
    const glm::vec3 minusZ(0.0f, 0.0f, -1.0f);
    EXPECT_FALSE(validNeighbours(p0, z, glm::vec3(0.0f, 0.0f, -0.01f), minusZ));
    EXPECT_FALSE(validNeighbours(p0, z, glm::vec3(0.001f, 0.0f, -0.01f), minusZ));
    EXPECT_FALSE(validNeighbours(p0, z, glm::vec3(0.5f, 0.2f, -0.01f), minusZ));
    EXPECT_FALSE(validNeighbours(p0, z, glm::vec3(0.001f, 0.0f, -0.01f),
                                 glm::normalize(glm::vec3(0.05f, 0.0f, -1.0f))));
}

TEST(ValidNeighbours, ConeOfHalfAngleHalfTheNormalAngle) {
    // n0 = z, n1 rotated by γ about x: the cone axis is the bisector, half-angle γ/2. A direction at
    // ψ from the axis is valid iff ψ > γ/2 (and < π - γ/2 on the other nappe).
    for (double gammaDeg : {0.0, 20.0, 60.0, 120.0}) {
        const double g = radians(gammaDeg);
        const glm::vec3 n0(0.0f, 0.0f, 1.0f);
        const glm::vec3 n1(0.0f, static_cast<float>(-std::sin(g)), static_cast<float>(std::cos(g)));
        const glm::dvec3 axis = glm::normalize(glm::dvec3(n0 + n1));
        const glm::dvec3 side(1.0, 0.0, 0.0);
        const glm::vec3 p0(0.5f, 0.5f, 0.5f);
        const auto direction = [&](double psiDeg) {
            const double psi = radians(psiDeg);
            return glm::vec3(axis * std::cos(psi) + side * std::sin(psi));
        };
        const double half = gammaDeg / 2.0;
        for (double scale : {0.01, 1.0, 100.0}) {
            const float s = static_cast<float>(scale);
            EXPECT_TRUE(validNeighbours(p0, n0, p0 + s * direction(half + 1.0), n1))
                << gammaDeg << " " << scale;
            EXPECT_TRUE(validNeighbours(p0, n0, p0 + s * direction(180.0 - half - 1.0), n1)) << gammaDeg;
            EXPECT_TRUE(validNeighbours(p0, n0, p0 + s * direction(90.0), n1)) << gammaDeg;
            if (half >= 1.0) {
                EXPECT_FALSE(validNeighbours(p0, n0, p0 + s * direction(half - 1.0), n1))
                    << gammaDeg << " " << scale;
                EXPECT_FALSE(validNeighbours(p0, n0, p0 + s * direction(180.0 - half + 1.0), n1)) << gammaDeg;
            }
        }
    }
}

TEST(ValidNeighbours, SymmetricOverRandomPairs) {
    std::mt19937_64 rng(17);
    int valid = 0;
    for (int trial = 0; trial < 10000; ++trial) {
        const glm::vec3 p0(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
        const glm::vec3 p1(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
        const glm::vec3 n0 = randomUnit(rng), n1 = randomUnit(rng);
        const bool v01 = validNeighbours(p0, n0, p1, n1);
        EXPECT_EQ(v01, validNeighbours(p1, n1, p0, n0)) << trial;
        valid += v01;
    }
    // Both outcomes occur often, so the symmetry check is not vacuous.
    EXPECT_GT(valid, 1000);
    EXPECT_LT(valid, 9000);
}

// ---------------------------------------------------------------------------------------------
// fast_math.h

TEST(FastAtan2, WithinToleranceOfStdAtan2) {
    double worst = 0.0;
    const auto check = [&](float y, float x) {
        const double expected = std::atan2(static_cast<double>(y), static_cast<double>(x));
        const float got = fastAtan2(y, x);
        const double error = std::abs(static_cast<double>(got) - expected);
        worst = std::max(worst, error);
        EXPECT_LT(error, 2e-5) << "y=" << y << " x=" << x;
        EXPECT_GT(got, -std::numbers::pi_v<float> - 1e-6f);
        EXPECT_LE(got, std::numbers::pi_v<float>);
    };
    // Dense grid including both axes.
    constexpr int kGrid = 400;
    for (int i = -kGrid; i <= kGrid; ++i)
        for (int j = -kGrid; j <= kGrid; ++j)
            if (i != 0 || j != 0) check(static_cast<float>(i) / kGrid, static_cast<float>(j) / kGrid);
    // Dense angular sweep at several scales.
    for (int k = 0; k < 100000; ++k) {
        const double a = -kPi + 2.0 * kPi * k / 100000.0;
        for (double scale : {1e-30, 1e-3, 1.0, 1e20})
            check(static_cast<float>(scale * std::sin(a)), static_cast<float>(scale * std::cos(a)));
    }
    // Axes and signed zeros (atan2 conventions): ±0 with x > 0 keeps the sign of zero, ±0 with x < 0
    // gives ±π.
    check(0.0f, 1.0f);
    check(-0.0f, 1.0f);
    check(0.0f, -1.0f);
    check(-0.0f, -1.0f);
    check(1.0f, 0.0f);
    check(-1.0f, 0.0f);
    check(1.0f, -0.0f);
    check(-1.0f, -0.0f);
    EXPECT_TRUE(std::signbit(fastAtan2(-0.0f, 2.0f)));
    EXPECT_FALSE(std::signbit(fastAtan2(0.0f, 2.0f)));
    EXPECT_EQ(fastAtan2(-0.0f, -2.0f), -std::numbers::pi_v<float>);
    EXPECT_EQ(fastAtan2(0.0f, -2.0f), std::numbers::pi_v<float>);
    // Documented: fastAtan2(0, 0) = 0 for every sign of zero (std::atan2 gives ±π for x = -0; the
    // library's angleBetween relies on 0 for zero vectors).
    EXPECT_EQ(fastAtan2(0.0f, 0.0f), 0.0f);
    EXPECT_EQ(fastAtan2(-0.0f, 0.0f), 0.0f);
    EXPECT_EQ(fastAtan2(0.0f, -0.0f), 0.0f);
    EXPECT_EQ(fastAtan2(-0.0f, -0.0f), 0.0f);
    std::cout << "fastAtan2 worst error " << worst << " rad\n";
    EXPECT_GT(worst, 1e-7); // a polynomial, not libm: the sweep does see its error
}

TEST(AngleBetween, WithinToleranceOfAcos) {
    std::mt19937_64 rng(18);
    for (int trial = 0; trial < 20000; ++trial) {
        const glm::vec3 u = uniform(rng, 1e-3, 10.0) * randomUnit(rng);
        glm::vec3 v = uniform(rng, 1e-3, 10.0) * randomUnit(rng);
        if (trial % 4 == 1) v = u * 3.0f + 1e-3f * randomUnit(rng) * glm::length(u);  // near parallel
        if (trial % 4 == 2) v = -u * 0.5f + 1e-3f * randomUnit(rng) * glm::length(u); // near antiparallel
        const glm::dvec3 du(u), dv(v);
        const double expected =
            std::acos(std::clamp(glm::dot(du, dv) / (glm::length(du) * glm::length(dv)), -1.0, 1.0));
        EXPECT_NEAR(angleBetween(u, v), expected, 2e-5) << trial;
    }
    EXPECT_EQ(angleBetween(glm::vec3(0.0f), glm::vec3(1.0f, 0.0f, 0.0f)), 0.0f);
    EXPECT_NEAR(angleBetween(glm::vec3(1.0f, 0.0f, 0.0f), glm::vec3(-1.0f, 0.0f, 0.0f)), kPi, 2e-6);
    EXPECT_NEAR(angleBetween(glm::vec3(0.0f, 2.0f, 0.0f), glm::vec3(0.0f, 0.0f, 0.5f)), kPi / 2.0, 2e-6);
}

} // namespace
} // namespace pnsplat
