// Tests of the `eval` metrics (quality.h): closest points on triangles and meshes against brute
// force, hand-made meshes with known offsets, analytic spheres with known displacements and normal
// rotations, holes, uniformity, bit-exact input preservation, thread-count independence, and the
// --reference syntax.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>
#include <numeric>
#include <random>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "pnsplat/refine/angles.h"
#include "pnsplat/refine/evaluation/quality.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/shapes/shapes.h"
#include "test_data.h"
#include "test_random.h"

namespace pnsplat {
namespace {

using test::randomUnit;
using test::uniform;
using test::uniform01;

glm::vec3 randomVec(std::mt19937_64& rng, float scale) {
    return scale * glm::vec3(static_cast<float>(2.0 * uniform01(rng) - 1.0),
                             static_cast<float>(2.0 * uniform01(rng) - 1.0),
                             static_cast<float>(2.0 * uniform01(rng) - 1.0));
}

// Rotates v by `degrees` about the unit axis (Rodrigues).
glm::vec3 rotate(glm::vec3 v, glm::vec3 axis, double degrees) {
    const glm::dvec3 dv(v), k(axis);
    const double a = radians(degrees);
    return glm::vec3(dv * std::cos(a) + glm::cross(k, dv) * std::sin(a) +
                     k * glm::dot(k, dv) * (1.0 - std::cos(a)));
}

// ---------------------------------------------------------------------------------------------

TEST(ClosestPointOnTriangle, MatchesBruteForceSampling) {
    std::mt19937_64 rng(2005);
    constexpr int kSteps = 300; // barycentric grid of the oracle
    for (int trial = 0; trial < 60; ++trial) {
        const glm::vec3 a = randomVec(rng, 1.0f), b = randomVec(rng, 1.0f);
        // Some triangles are thin (sine of an angle ~1e-3) or degenerate (collinear corners, or
        // two equal corners): there Ericson's face-region formulas lose their accuracy in floats.
        glm::vec3 c = randomVec(rng, 1.0f);
        if (trial % 5 == 2) c = a + 0.37f * (b - a) + randomVec(rng, 1e-3f);
        if (trial % 5 == 3) c = a + 0.37f * (b - a);
        if (trial % 5 == 4) c = b;
        const float maxEdge = std::max({glm::length(b - a), glm::length(c - a), glm::length(c - b)});
        for (int q = 0; q < 20; ++q) {
            const glm::vec3 p = randomVec(rng, 1.5f);
            double brute = 1e300;
            for (int i = 0; i <= kSteps; ++i)
                for (int j = 0; i + j <= kSteps; ++j) {
                    const float u = static_cast<float>(i) / kSteps, v = static_cast<float>(j) / kSteps;
                    const glm::vec3 s = (1.0f - u - v) * a + u * b + v * c;
                    brute = std::min(brute, static_cast<double>(glm::length(p - s)));
                }
            const glm::vec3 w = closestPointBarycentric(p, a, b, c);
            ASSERT_GE(std::min({w.x, w.y, w.z}), 0.0f);
            ASSERT_NEAR(w.x + w.y + w.z, 1.0f, 1e-5f);
            const double exact = glm::length(p - closestPointOnTriangle(p, a, b, c));
            EXPECT_LE(exact, brute + 1e-5) << "trial " << trial;
            EXPECT_GE(exact, brute - static_cast<double>(maxEdge) / kSteps) << "trial " << trial;
        }
    }
}

TEST(TriangleMeshIndex, MatchesBruteForceOverAllTriangles) {
    std::mt19937_64 rng(17);
    // A triangle soup: small triangles scattered in a box, plus a few large ones.
    std::vector<glm::vec3> positions;
    std::vector<glm::u32vec3> triangles;
    for (std::uint32_t t = 0; t < 3000; ++t) {
        const glm::vec3 centre = randomVec(rng, 1.0f);
        const float size = t % 500 == 0 ? 1.5f : 0.05f;
        for (int k = 0; k < 3; ++k) positions.push_back(centre + randomVec(rng, size));
        triangles.push_back({3 * t, 3 * t + 1, 3 * t + 2});
    }
    const TriangleMeshIndex index(positions, triangles);
    EXPECT_EQ(index.triangleCount(), triangles.size());
    for (int q = 0; q < 500; ++q) {
        const glm::vec3 p = randomVec(rng, 1.3f);
        float brute = INFINITY;
        for (const glm::u32vec3& t : triangles) {
            const glm::vec3 c = closestPointOnTriangle(p, positions[t.x], positions[t.y], positions[t.z]);
            brute = std::min(brute, glm::dot(p - c, p - c));
        }
        const TriangleMeshIndex::Hit hit = index.closest(p);
        // The same float computation per triangle: equal, not just close.
        ASSERT_EQ(hit.distanceSquared, brute);
        const glm::u32vec3 t = triangles[hit.triangle];
        const glm::vec3 fromBary = hit.barycentric.x * positions[t.x] + hit.barycentric.y * positions[t.y] +
                                   hit.barycentric.z * positions[t.z];
        EXPECT_LT(glm::length(fromBary - hit.point), 1e-6f);
    }
}

// A cube [-1,1]^3 with 4 vertices per face (24 vertices) carrying the face normal, so the
// interpolated true normal is exactly the face normal.
struct Cube {
    PointSet vertices;
    std::vector<glm::u32vec3> triangles;
    std::vector<glm::vec3> faceNormal, faceU, faceV;
};

Cube makeCube() {
    Cube cube;
    const glm::vec3 axes[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int axis = 0; axis < 3; ++axis)
        for (const float sign : {1.0f, -1.0f}) {
            const glm::vec3 n = sign * axes[axis];
            const glm::vec3 u = axes[(axis + 1) % 3];
            const glm::vec3 v = sign * axes[(axis + 2) % 3]; // u x v = n: counter-clockwise seen from outside
            const auto base = static_cast<std::uint32_t>(cube.vertices.size());
            for (const glm::vec2 c :
                 {glm::vec2(-1, -1), glm::vec2(1, -1), glm::vec2(1, 1), glm::vec2(-1, 1)}) {
                cube.vertices.position.push_back(n + c.x * u + c.y * v);
                cube.vertices.normal.push_back(n);
            }
            cube.triangles.push_back({base, base + 1, base + 2});
            cube.triangles.push_back({base, base + 2, base + 3});
            cube.faceNormal.push_back(n);
            cube.faceU.push_back(u);
            cube.faceV.push_back(v);
        }
    return cube;
}

// A cube of 8 shared corners, whose (area-weighted) vertex normals lie along its diagonals: over
// a face, interpolated vertex normals tilt away from the face's, flat normals are the face's.
TEST(MeshReference, FlatNormalsAreTheClosestTrianglesOwn) {
    PointSet corners;
    for (int k = 0; k < 8; ++k)
        corners.position.push_back(
            glm::vec3(k & 1 ? 1.0f : -1.0f, k & 2 ? 1.0f : -1.0f, k & 4 ? 1.0f : -1.0f));
    // Faces as corner quads, counter-clockwise seen from outside.
    const std::uint32_t quads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                       {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
    std::vector<glm::u32vec3> triangles;
    for (const auto& q : quads) {
        triangles.push_back({q[0], q[1], q[2]});
        triangles.push_back({q[0], q[2], q[3]});
    }
    const Reference ref = meshReference(corners, triangles, "shared-corner cube").value();
    for (std::size_t k = 0; k < 8; ++k)
        ASSERT_GT(glm::dot(ref.points.normal[k], ref.points.position[k]), 1.5f);
    PointSet refined;
    const glm::vec3 axes[3] = {glm::vec3(1, 0, 0), glm::vec3(0, 1, 0), glm::vec3(0, 0, 1)};
    for (const glm::vec3 axis : axes)
        for (const float side : {-1.0f, 1.0f})
            for (const float s : {-0.5f, 0.3f}) {
                const glm::vec3 u = axis.x != 0.0f ? axes[1] : axes[0], v = glm::cross(axis, u);
                refined.position.push_back(side * axis + s * u + 0.2f * v);
                refined.normal.push_back(side * axis);
            }
    const EvalOptions interpolated{.threads = 2};
    EvalOptions flat = interpolated;
    flat.flatNormals = true;
    const QualityReport smooth = evaluateQuality(refined, ref, nullptr, interpolated);
    const QualityReport faces = evaluateQuality(refined, ref, nullptr, flat);
    std::cout << "[shared-corner cube] normal error over the faces: interpolated "
              << smooth.normalErrorMeanDeg << " deg, flat " << faces.normalErrorMeanDeg << " deg\n";
    EXPECT_GT(smooth.normalErrorMeanDeg, 10.0);
    EXPECT_LT(faces.normalErrorMaxDeg, 1e-4);
    EXPECT_EQ(faces.distanceMax, smooth.distanceMax); // distances are the same either way

    // Every face wound the other way (cross products inward) under outward vertex normals given
    // with the mesh: the flat normals face like the vertex normals, outward.
    PointSet oriented = corners;
    for (const glm::vec3& x : corners.position) oriented.normal.push_back(glm::normalize(x));
    std::vector<glm::u32vec3> reversed = triangles;
    for (glm::u32vec3& t : reversed) std::swap(t.y, t.z);
    const Reference inward = meshReference(oriented, reversed, "cube wound inward").value();
    EXPECT_LT(evaluateQuality(refined, inward, nullptr, flat).normalErrorMaxDeg, 1e-4);
}

TEST(MeshReference, CubeDistancesReproduceKnownOffsets) {
    const Cube cube = makeCube();
    Reference ref = meshReference(cube.vertices, cube.triangles, "cube").value();
    ASSERT_TRUE(ref.isMesh());
    const TriangleMeshIndex index(ref.points.position, ref.triangles);

    // Points over the middle of each face, pushed along the face normal by known offsets (in and
    // out, never past 0.5 so that face stays the closest).
    const float offsets[] = {0.0f, 0.01f, -0.02f, 0.1f, -0.3f, 0.45f};
    PointSet refined;
    std::vector<float> expected;
    for (std::size_t f = 0; f < cube.faceNormal.size(); ++f)
        for (const float s : {-0.4f, 0.0f, 0.3f})
            for (const float t : {-0.25f, 0.2f})
                for (const float offset : offsets) {
                    const glm::vec3 p =
                        cube.faceNormal[f] * (1.0f + offset) + s * cube.faceU[f] + t * cube.faceV[f];
                    refined.position.push_back(p);
                    refined.normal.push_back(cube.faceNormal[f]);
                    expected.push_back(std::abs(offset));
                    const TriangleMeshIndex::Hit hit = index.closest(p);
                    EXPECT_NEAR(std::sqrt(hit.distanceSquared), std::abs(offset), 1e-6f);
                    EXPECT_EQ(glm::dot(ref.points.normal[ref.triangles[hit.triangle].x], cube.faceNormal[f]),
                              1.0f);
                }
    double sum = 0.0, sum2 = 0.0, max = 0.0;
    for (const float e : expected) {
        sum += static_cast<double>(e);
        sum2 += static_cast<double>(e) * static_cast<double>(e);
        max = std::max(max, static_cast<double>(e));
    }
    const double n = static_cast<double>(expected.size());
    const QualityReport report = evaluateQuality(refined, ref, nullptr, {.threads = 2});
    EXPECT_NEAR(report.distanceMean, sum / n, 1e-6);
    EXPECT_NEAR(report.distanceRms, std::sqrt(sum2 / n), 1e-6);
    EXPECT_NEAR(report.distanceMax, max, 1e-6);
    EXPECT_NEAR(report.diagonal, 2.0 * std::sqrt(3.0), 1e-5); // the box [-1,1]^3
    EXPECT_NEAR(report.distanceMaxRel, max / (2.0 * std::sqrt(3.0)), 1e-6);
    EXPECT_LT(report.normalErrorMeanDeg, 1e-3);
    EXPECT_EQ(report.referenceTriangles, 12u);
}

TEST(MeshReference, ComputesAreaWeightedNormalsWhenAbsent) {
    // A regular tetrahedron: every vertex normal is the direction from the centre to the vertex.
    PointSet vertices;
    vertices.position = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
    const std::vector<glm::u32vec3> triangles = {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}};
    const Reference ref = meshReference(vertices, triangles, "tetra").value();
    ASSERT_EQ(ref.points.normal.size(), 4u);
    for (std::size_t i = 0; i < 4; ++i)
        EXPECT_LT(glm::length(ref.points.normal[i] - glm::normalize(vertices.position[i])), 1e-6f);

    // Points displaced along the face normals by known offsets.
    const TriangleMeshIndex index(ref.points.position, ref.triangles);
    for (const glm::u32vec3& t : triangles) {
        const glm::vec3 a = vertices.position[t.x], b = vertices.position[t.y], c = vertices.position[t.z];
        const glm::vec3 n = glm::normalize(glm::cross(b - a, c - a));
        EXPECT_GT(glm::dot(n, a), 0.0f); // outward
        for (const float offset : {0.05f, 0.2f, -0.1f}) {
            const glm::vec3 p = (a + b + c) / 3.0f + offset * n;
            EXPECT_NEAR(std::sqrt(index.closest(p).distanceSquared), std::abs(offset), 1e-6f);
        }
    }

    // Bad input: an index out of range; points-only without normals.
    EXPECT_FALSE(meshReference(vertices, {{0, 1, 4}}, "bad").ok());
    EXPECT_FALSE(meshReference(vertices, {}, "bad").ok());
}

// ---------------------------------------------------------------------------------------------

// The 99th percentile is the nearest rank: of 1,000 points at k/1000 of the radius off the sphere
// (k = 1..1000, shuffled), the 990th smallest distance, between the mean and the largest.
TEST(SphereEval, NinetyNinthPercentileDistanceIsTheNearestRank) {
    const double R = 1.0;
    const PointSet sphere = sampleSphereUniform(1000, 1.0f);
    std::vector<std::size_t> order(sphere.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::mt19937 rng(99);
    std::ranges::shuffle(order, rng);
    PointSet refined = sphere;
    for (std::size_t i = 0; i < order.size(); ++i)
        refined.position[i] = sphere.position[i] * (1.0f + 0.001f * static_cast<float>(order[i] + 1));
    const Reference ref = parseReference("sphere:1").value();
    const QualityReport report =
        evaluateQuality(refined, ref, nullptr, {.threads = 2, .analyticSamples = 5000});
    EXPECT_NEAR(report.distanceP99, 0.990 * R, 1e-5);
    EXPECT_NEAR(report.distanceMax, 1.000 * R, 1e-5);
    EXPECT_NEAR(report.distanceP99Rel, 0.990 / (2.0 * std::sqrt(3.0)), 1e-5);
}

TEST(SphereEval, PushedOutByOnePercentGivesRmsOnePercent) {
    const double R = 2.0;
    PointSet refined = sampleSphereUniform(20000, 2.0f);
    for (glm::vec3& p : refined.position) p *= 1.01f;
    const Reference ref = parseReference("sphere:2").value();
    const QualityReport report =
        evaluateQuality(refined, ref, nullptr, {.threads = 2, .analyticSamples = 50000});
    EXPECT_NEAR(report.distanceRms, 0.01 * R, 1e-5);
    EXPECT_NEAR(report.distanceMean, 0.01 * R, 1e-5);
    EXPECT_NEAR(report.distanceMax, 0.01 * R, 1e-5);
    EXPECT_NEAR(report.distanceRmsRel, 0.01 * R / (2.0 * R * std::sqrt(3.0)), 1e-6);
    EXPECT_LT(report.normalErrorP95Deg, 1e-3);
    EXPECT_EQ(report.holes, 0.0);
    EXPECT_EQ(report.referencePoints, 50000u);
}

TEST(SphereEval, NormalsRotatedByTenDegreesGiveTenDegrees) {
    PointSet refined = sampleSphereRandom(5000, 1.0f, 99);
    std::mt19937_64 rng(3);
    for (std::size_t i = 0; i < refined.size(); ++i) {
        // Rotate about a random tangent axis.
        const glm::vec3 n = refined.normal[i];
        const glm::vec3 axis = glm::normalize(glm::cross(n, glm::normalize(randomVec(rng, 1.0f))));
        refined.normal[i] = rotate(n, axis, 10.0);
    }
    const QualityReport report = evaluateQuality(refined, parseReference("sphere:1").value(), nullptr,
                                                 {.threads = 2, .analyticSamples = 20000});
    EXPECT_NEAR(report.normalErrorMeanDeg, 10.0, 1e-3);
    EXPECT_NEAR(report.normalErrorP95Deg, 10.0, 1e-3);
    EXPECT_LT(report.distanceMax, 1e-6);

    // Flipped normals count as 180 degrees: orientation matters.
    for (glm::vec3& n : refined.normal) n = -n;
    const QualityReport flipped = evaluateQuality(refined, parseReference("sphere:1").value(), nullptr,
                                                  {.threads = 2, .analyticSamples = 20000});
    EXPECT_NEAR(flipped.normalErrorMeanDeg, 170.0, 1e-3);

    // A crease point is measured by the closer of its two normals: with the exact normal as its
    // second one, every point's error is 0.
    const PointSet exact = sampleSphereRandom(5000, 1.0f, 99);
    refined.crease = exact.normal;
    const QualityReport creased = evaluateQuality(refined, parseReference("sphere:1").value(), nullptr,
                                                  {.threads = 2, .analyticSamples = 20000});
    EXPECT_LT(creased.normalErrorMaxDeg, 1e-2);
}

TEST(SphereEval, RemovedPatchReportsHoles) {
    const PointSet full = sampleSphereUniform(20000, 1.0f);
    const Reference ref = parseReference("sphere:1").value();
    const QualityReport fullReport = evaluateQuality(full, ref, nullptr, {.threads = 2});
    EXPECT_EQ(fullReport.holes, 0.0);
    EXPECT_EQ(fullReport.holeReferencePoints, 0u);
    EXPECT_EQ(fullReport.referencePoints, 200000u);

    // Remove the cap z > 0.8: 10 % of the area. Reference samples within twice the spacing of
    // the cap's rim stay covered, so the share is a little under 10 %.
    PointSet holed;
    for (std::size_t i = 0; i < full.size(); ++i)
        if (full.position[i].z <= 0.8f) holed.appendFrom(full, i);
    const QualityReport report = evaluateQuality(holed, ref, nullptr, {.threads = 2});
    EXPECT_GT(report.holes, 0.07);
    EXPECT_LT(report.holes, 0.1);
    EXPECT_NEAR(report.uniformityCv, fullReport.uniformityCv, 0.01);
    // The holes are the samples of the cap, and gaps each (the points lie on the sphere, their own
    // projections).
    ASSERT_EQ(report.holePoints.size(), report.holeReferencePoints);
    EXPECT_TRUE(fullReport.holePoints.empty());
    for (std::size_t i = 0; i < report.holePoints.size(); ++i) {
        const glm::vec3 q = report.holePoints.position[i];
        EXPECT_GT(q.z, 0.8f) << "hole " << i;
        EXPECT_NEAR(glm::length(q), 1.0f, 1e-5f);
        EXPECT_GT(glm::dot(report.holePoints.normal[i], q), 0.999f);
        EXPECT_EQ(report.holePoints.colour[i], kGapColour) << "hole " << i;
    }
    EXPECT_EQ(report.gaps, report.holes);
}

// A sampling lifted off the true surface by more than twice its spacing covers it in the tangent
// plane and projected onto it: every sample is a hole in space, and each is marked off-surface,
// none a gap.
TEST(SphereEval, LiftedSurfaceHolesAreOffSurfaceNotGaps) {
    PointSet lifted = sampleSphereUniform(20000, 1.0f);
    for (glm::vec3& p : lifted.position) p *= 1.08f;
    const QualityReport report = evaluateQuality(lifted, parseReference("sphere:1").value(), nullptr,
                                                 {.threads = 2, .analyticSamples = 20000});
    ASSERT_LT(2.0 * report.spacingMean, 0.08); // the lift is beyond the hole distance
    EXPECT_EQ(report.holeReferencePoints, 20000u);
    EXPECT_EQ(report.holesTangential, 0.0);
    EXPECT_EQ(report.gaps, 0.0);
    ASSERT_EQ(report.holePoints.size(), 20000u);
    for (const glm::u8vec3& colour : report.holePoints.colour) EXPECT_EQ(colour, kOffSurfaceColour);
}

// Gaps measure the true surface uncovered by the refined points projected onto it, wherever the
// refined surface lies: a plane of 41 x 41 vertices, and a sampling of it lifted far above (holes
// everywhere in space) with a square cut out. The gaps are the vertices that brute force finds
// farther than twice the spacing from every projected point: the cut square less a rim.
TEST(MeshReference, GapsAreTheSurfaceUncoveredByTheProjectedPoints) {
    PointSet plane;
    std::vector<glm::u32vec3> triangles;
    constexpr std::uint32_t kSide = 41;
    for (std::uint32_t j = 0; j < kSide; ++j)
        for (std::uint32_t i = 0; i < kSide; ++i) {
            plane.position.emplace_back(static_cast<float>(i) / 40.0f, static_cast<float>(j) / 40.0f, 0.0f);
            plane.normal.emplace_back(0.0f, 0.0f, 1.0f);
            if (i + 1 < kSide && j + 1 < kSide) {
                const std::uint32_t v = j * kSide + i;
                triangles.push_back({v, v + 1, v + kSide + 1});
                triangles.push_back({v, v + kSide + 1, v + kSide});
            }
        }
    const Reference ref = meshReference(plane, triangles, "plane").value();
    PointSet lifted;
    for (int j = 0; j <= 80; ++j)
        for (int i = 0; i <= 80; ++i) {
            const glm::vec2 xy(static_cast<float>(i) / 80.0f, static_cast<float>(j) / 80.0f);
            if (xy.x > 0.3f && xy.x < 0.7f && xy.y > 0.3f && xy.y < 0.7f) continue;
            lifted.position.emplace_back(xy, 0.5f);
            lifted.normal.emplace_back(0.0f, 0.0f, 1.0f);
        }
    const QualityReport report = evaluateQuality(lifted, ref, nullptr, {.threads = 2});
    EXPECT_EQ(report.holes, 1.0);
    const float reach = static_cast<float>(2.0 * report.spacingMean);
    std::size_t gaps = 0;
    for (const glm::vec3& v : plane.position) {
        float nearest = std::numeric_limits<float>::infinity();
        for (const glm::vec3& p : lifted.position)
            nearest = std::min(nearest, glm::length(glm::vec3(p.x, p.y, 0.0f) - v));
        gaps += nearest > reach ? 1 : 0;
    }
    std::cout << "[lifted plane with a square cut out] " << gaps << " gaps of " << plane.size()
              << " vertices\n";
    EXPECT_GT(gaps, 100u);
    EXPECT_EQ(report.gaps, static_cast<double>(gaps) / static_cast<double>(plane.size()));
    std::size_t red = 0;
    for (const glm::u8vec3& colour : report.holePoints.colour) red += colour == kGapColour ? 1 : 0;
    EXPECT_EQ(red, gaps);
}

TEST(Uniformity, PerfectGridHasZeroVariation) {
    // A 40 x 40 grid with a power-of-two step: every nearest-neighbour distance is exactly 0.125.
    PointSet grid;
    for (int i = 0; i < 40; ++i)
        for (int j = 0; j < 40; ++j) {
            grid.position.emplace_back(0.125f * static_cast<float>(i), 0.125f * static_cast<float>(j), 0.0f);
            grid.normal.emplace_back(0.0f, 0.0f, 1.0f);
        }
    const Reference ref = meshReference(grid, {}, "grid").value();
    ASSERT_FALSE(ref.isMesh());
    const QualityReport report = evaluateQuality(grid, ref, nullptr, {.threads = 2});
    EXPECT_EQ(report.uniformityCv, 0.0);
    EXPECT_EQ(report.spacingMean, 0.125);
    EXPECT_EQ(report.distanceMax, 0.0);
    EXPECT_EQ(report.normalErrorMaxDeg, 0.0);
    EXPECT_EQ(report.holes, 0.0);

    // Jittered in the plane, the variation shows; lifted off it, the tangent-plane distance shows.
    PointSet jittered = grid;
    std::mt19937_64 rng(5);
    for (glm::vec3& p : jittered.position) {
        p.x += 0.03f * static_cast<float>(uniform01(rng) - 0.5);
        p.z += 0.01f;
    }
    const QualityReport jitterReport = evaluateQuality(jittered, ref, nullptr, {.threads = 2});
    EXPECT_GT(jitterReport.uniformityCv, 0.05);
    EXPECT_NEAR(jitterReport.distanceMean, 0.01, 1e-6);
}

TEST(InputPreservation, BitExactComparison) {
    const PointSet input = sampleSphereRandom(300, 1.0f, 1);
    PointSet refined = sampleSphereRandom(3000, 1.0f, 2);
    for (std::size_t i = 0; i < input.size(); ++i) refined.appendFrom(input, i);
    const Reference ref = parseReference("sphere:1").value();
    const EvalOptions options{.threads = 2, .analyticSamples = 1000};

    const QualityReport kept = evaluateQuality(refined, ref, &input, options);
    EXPECT_TRUE(kept.hasInput);
    EXPECT_TRUE(kept.inputPreserved);
    EXPECT_EQ(kept.inputMissing, 0u);
    EXPECT_EQ(kept.inputPoints, 300u);

    // One ulp in one coordinate of one point.
    PointSet nudged = refined;
    glm::vec3& p = nudged.position[3000 + 17];
    p.y = std::nextafter(p.y, 2.0f);
    const QualityReport moved = evaluateQuality(nudged, ref, &input, options);
    EXPECT_FALSE(moved.inputPreserved);
    EXPECT_EQ(moved.inputMissing, 1u);

    // One ulp in one normal component.
    PointSet turned = refined;
    glm::vec3& n = turned.normal[3000 + 200];
    n.x = std::nextafter(n.x, -2.0f);
    const QualityReport bent = evaluateQuality(turned, ref, &input, options);
    EXPECT_FALSE(bent.inputPreserved);
    EXPECT_EQ(bent.inputMissing, 1u);

    // An input of positions only (normals estimated when it was refined): by position alone, so
    // the turned normal is no loss, the nudged position still is.
    PointSet positions = input;
    positions.normal.clear();
    EXPECT_TRUE(evaluateQuality(turned, ref, &positions, options).inputPreserved);
    const QualityReport movedPosition = evaluateQuality(nudged, ref, &positions, options);
    EXPECT_FALSE(movedPosition.inputPreserved);
    EXPECT_EQ(movedPosition.inputMissing, 1u);

    // Without an input the fields are null in JSON.
    const QualityReport none = evaluateQuality(refined, ref, nullptr, options);
    EXPECT_FALSE(none.hasInput);
    EXPECT_NE(toJson(none).find("\"input_preserved\": null"), std::string::npos);
    EXPECT_NE(toJson(moved).find("\"input_preserved\": false"), std::string::npos);
    EXPECT_NE(toJson(kept).find("\"input_missing\": 0"), std::string::npos);
}

TEST(Threads, ReportDoesNotDependOnThreadCount) {
    PointSet refined = sampleTorusRandom(30000, 1.0f, 0.3f, 8);
    std::mt19937_64 rng(9);
    for (std::size_t i = 100; i < refined.size(); ++i) { // the first 100 are the input
        refined.position[i] += randomVec(rng, 0.003f);
        refined.normal[i] = glm::normalize(refined.normal[i] + randomVec(rng, 0.05f));
    }
    const PointSet input = sampleTorusRandom(100, 1.0f, 0.3f, 8);
    const Reference ref = parseReference("torus:1,0.3").value();
    const std::string one = toJson(evaluateQuality(refined, ref, &input, {.threads = 1}));
    const std::string four = toJson(evaluateQuality(refined, ref, &input, {.threads = 4}));
    EXPECT_EQ(one, four);
    const QualityReport report = evaluateQuality(refined, ref, &input, {.threads = 3});
    EXPECT_GT(report.distanceMean, 0.0);
    EXPECT_LT(report.distanceMax, 0.003 * std::sqrt(3.0) + 1e-6);
    EXPECT_TRUE(report.inputPreserved); // the first 100 points of the same seed

    // The same with a mesh reference (a triangulated torus from its uniform sampling grid is
    // awkward; use the cube instead).
    const Cube cube = makeCube();
    const Reference cubeRef = meshReference(cube.vertices, cube.triangles, "cube").value();
    PointSet cloud;
    for (int i = 0; i < 20000; ++i) {
        cloud.position.push_back(randomVec(rng, 1.2f));
        cloud.normal.push_back(glm::normalize(randomVec(rng, 1.0f) + glm::vec3(0.0f, 0.0f, 0.01f)));
    }
    EXPECT_EQ(toJson(evaluateQuality(cloud, cubeRef, nullptr, {.threads = 1})),
              toJson(evaluateQuality(cloud, cubeRef, nullptr, {.threads = 4})));
}

TEST(ParseReference, AnalyticSyntaxAndErrors) {
    const Result<Reference> sphere = parseReference("sphere:2.5");
    ASSERT_TRUE(sphere.ok());
    ASSERT_TRUE(sphere->isAnalytic());
    EXPECT_EQ(sphere->surface->kind, AnalyticSurface::Kind::Sphere);
    EXPECT_EQ(sphere->surface->R, 2.5f);
    EXPECT_EQ(sphere->name, "sphere:2.5");

    const Result<Reference> torus = parseReference("torus:1,0.25");
    ASSERT_TRUE(torus.ok());
    EXPECT_EQ(torus->surface->kind, AnalyticSurface::Kind::Torus);
    EXPECT_EQ(torus->surface->R, 1.0f);
    EXPECT_EQ(torus->surface->r, 0.25f);

    for (const char* bad : {"sphere:", "sphere:0", "sphere:-1", "sphere:abc", "sphere:1x", "sphere:inf",
                            "sphere:nan", "torus:", "torus:1", "torus:1,", "torus:0.2,0.5", "torus:1,1",
                            "torus:1,0", "torus:1,0.2,3", "spehre:1", "no-such-file.ply"}) {
        const Result<Reference> r = parseReference(bad);
        ASSERT_FALSE(r.ok()) << bad;
        EXPECT_FALSE(r.error().message.empty());
        EXPECT_EQ(r.error().message.find('\n'), std::string::npos) << bad;
    }
    EXPECT_NE(parseReference("torus:0.2,0.5").error().message.find("R > r > 0"), std::string::npos);
}

TEST(Json, StableKeysAndEscaping) {
    QualityReport report;
    report.reference = "dir\\with \"quotes\".ply";
    report.points = 12;
    report.distanceRms = 0.5;
    report.uniformityCv = std::numeric_limits<double>::quiet_NaN();
    const std::string json = toJson(report);
    for (const char* key :
         {"\"points\": 12", "\"reference\": \"dir\\\\with \\\"quotes\\\".ply\"", "\"distance\": {",
          "\"mean\":", "\"rms\": 0.5", "\"max\":", "\"mean_rel\":", "\"rms_rel\":", "\"max_rel\":",
          "\"p99\":", "\"p99_rel\":", "\"normal_error_deg\": {", "\"p95\":", "\"uniformity_cv\": null",
          "\"holes\":", "\"gaps\":", "\"input_preserved\": null", "\"input_missing\": null"})
        EXPECT_NE(json.find(key), std::string::npos) << key << " in " << json;
    EXPECT_EQ(json.front(), '{');
    EXPECT_EQ(json.back(), '}');
}

// ---------------------------------------------------------------------------------------------
// Real data (../shared/data).

TEST(RealData, BunnyVerticesLieOnTheMeshWithTheReferenceNormals) {
    PNSPLAT_REQUIRE_DATA("bunny-mesh.ply");
    PNSPLAT_REQUIRE_DATA("bunny-reference.ply");
    PNSPLAT_REQUIRE_DATA("bunny-3500-random.ply");
    const std::string meshPath = (test::dataDir() / "bunny-mesh.ply").string();
    const Result<Reference> ref = parseReference(meshPath);
    ASSERT_TRUE(ref.ok()) << ref.error().message;
    ASSERT_TRUE(ref->isMesh());
    EXPECT_EQ(ref->points.size(), 34834u);
    EXPECT_EQ(ref->triangles.size(), 69451u);

    const Result<PlyData> reference = readPly(test::dataDir() / "bunny-reference.ply");
    const Result<PlyData> input = readPly(test::dataDir() / "bunny-3500-random.ply");
    ASSERT_TRUE(reference.ok() && input.ok());
    const QualityReport report = evaluateQuality(reference->points, *ref, &input->points, {});
    // Vertices are on the mesh exactly; the data's normals are area-weighted vertex normals, as
    // recomputed here from the faces.
    EXPECT_EQ(report.distanceMax, 0.0);
    EXPECT_LT(report.normalErrorMaxDeg, 0.01);
    EXPECT_EQ(report.holes, 0.0);
    EXPECT_TRUE(report.inputPreserved);

    // The sparse input against the points-only reference: its points are reference points.
    const Result<Reference> points = parseReference((test::dataDir() / "bunny-reference.ply").string());
    ASSERT_TRUE(points.ok());
    EXPECT_FALSE(points->isMesh());
    const QualityReport sparse = evaluateQuality(input->points, *points, nullptr, {});
    EXPECT_EQ(sparse.distanceMax, 0.0);
    EXPECT_EQ(sparse.normalErrorMaxDeg, 0.0);
    EXPECT_GT(sparse.holes, 0.01); // 3,500 of 34,834 points: coverage gaps in random sampling
}

} // namespace
} // namespace pnsplat
