// Normal estimation (ALGORITHM.md §9.2): the eigen solver against its definition, PCA against analytic
// surfaces, orientation against known outward normals, determinism, and bad input.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <iostream>
#include <numeric>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>
#include <gtest/gtest.h>

#include "pnsplat/refine/angles.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/normal_estimation.h"
#include "pnsplat/refine/shapes/shapes.h"
#include "test_data.h"
#include "test_random.h"

namespace pnsplat {
namespace {

// Random symmetric matrices (and ones with repeated eigenvalues): the vector is a unit eigenvector
// of the smallest eigenvalue, the values are sorted and sum to the trace.
TEST(SmallestEigen, SatisfiesItsDefinition) {
    std::mt19937_64 rng(11);
    for (int trial = 0; trial < 2000; ++trial) {
        double m[3][3];
        if (trial % 4 == 0) {
            // Q diag(a, a, b) Qᵀ: a repeated eigenvalue.
            const glm::dvec3 u = glm::dvec3(test::randomUnit(rng));
            const double a = test::uniform01(rng), b = 3.0 * test::uniform01(rng) - 1.0;
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c) m[r][c] = (r == c ? a : 0.0) + (b - a) * u[r] * u[c];
        } else {
            for (int r = 0; r < 3; ++r)
                for (int c = r; c < 3; ++c) m[r][c] = m[c][r] = 2.0 * test::uniform01(rng) - 1.0;
        }
        const SmallestEigen e = smallestEigenvector(m);
        ASSERT_NEAR(glm::length(e.vector), 1.0, 1e-12);
        ASSERT_LE(e.values[0], e.values[1]);
        ASSERT_LE(e.values[1], e.values[2]);
        ASSERT_NEAR(e.values[0] + e.values[1] + e.values[2], m[0][0] + m[1][1] + m[2][2], 1e-12);
        for (int r = 0; r < 3; ++r) {
            const double mv = m[r][0] * e.vector[0] + m[r][1] * e.vector[1] + m[r][2] * e.vector[2];
            ASSERT_NEAR(mv, e.values[0] * e.vector[r], 1e-10) << "trial " << trial;
        }
        // No unit vector has a smaller Rayleigh quotient.
        for (int probe = 0; probe < 4; ++probe) {
            const glm::dvec3 w = glm::normalize(glm::dvec3(test::randomUnit(rng))); // unit in double
            double q = 0.0;
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c) q += w[r] * m[r][c] * w[c];
            ASSERT_GE(q, e.values[0] - 1e-12);
        }
    }
}

// Only the upper triangle is read.
TEST(SmallestEigen, ReadsTheUpperTriangle) {
    const double upper[3][3] = {{2, 0, 0}, {99, 3, 0}, {99, 99, 1}};
    const SmallestEigen e = smallestEigenvector(upper);
    EXPECT_DOUBLE_EQ(e.values[0], 1.0);
    EXPECT_DOUBLE_EQ(std::abs(e.vector.z), 1.0);
}

PointSet withoutNormals(PointSet points) {
    points.normal.clear();
    points.radius.clear();
    return points;
}

// A tilted plane: every normal is the plane's, and the sign is the one facing +z.
TEST(NormalEstimation, PlaneGetsItsNormalFacingUp) {
    const glm::vec3 n = glm::normalize(glm::vec3(0.3f, -0.4f, 0.8f));
    const glm::vec3 u = glm::normalize(glm::cross(n, glm::vec3(1, 0, 0))), v = glm::cross(n, u);
    std::mt19937_64 rng(5);
    PointSet points;
    for (int k = 0; k < 500; ++k)
        points.position.push_back(u * test::uniform(rng, -1, 1) + v * test::uniform(rng, -1, 1) +
                                  glm::vec3(2, 3, 4));
    const auto estimate = estimateNormals(points, 1);
    ASSERT_TRUE(estimate.ok()) << estimate.error().message;
    EXPECT_EQ(estimate->components, 1u);
    for (const glm::vec3& m : points.normal) ASSERT_GT(glm::dot(m, n), 1.0f - 1e-5f);
}

struct Agreement {
    std::size_t flipped = 0; // estimated normals facing against the true ones
    double meanDegrees = 0;  // unsigned angle to the true normal
};
Agreement compare(const PointSet& points, const HugePageVector<glm::vec3>& truth) {
    Agreement a;
    for (std::size_t i = 0; i < points.size(); ++i) {
        const float d = glm::dot(points.normal[i], truth[i]);
        a.flipped += d < 0.0f ? 1 : 0;
        a.meanDegrees += degrees(std::acos(std::min(1.0, static_cast<double>(std::abs(d)))));
    }
    a.meanDegrees /= static_cast<double>(points.size());
    return a;
}

// Closed analytic surfaces, sampled at random: outward everywhere, close to the true normals.
TEST(NormalEstimation, ClosedSurfacesFaceOutward) {
    const struct {
        const char* name;
        PointSet points;
        double maxMeanDegrees;
    } cases[] = {
        {"sphere 2000 random", sampleSphereRandom(2000, 1.0f, 3), 1.5},
        {"torus 3500 random", sampleTorusRandom(3500, 1.0f, 0.4f, 7), 3.0},
    };
    for (const auto& c : cases) {
        PointSet points = withoutNormals(c.points);
        const auto estimate = estimateNormals(points, 2);
        ASSERT_TRUE(estimate.ok()) << estimate.error().message;
        const Agreement a = compare(points, c.points.normal);
        std::cout << "[" << c.name << "] flipped " << a.flipped << ", mean error " << a.meanDegrees
                  << " deg\n";
        EXPECT_EQ(estimate->components, 1u) << c.name;
        EXPECT_EQ(a.flipped, 0u) << c.name;
        EXPECT_LT(a.meanDegrees, c.maxMeanDegrees) << c.name;
    }
}

// Two spheres far apart: two components, each started at its own top and outward.
TEST(NormalEstimation, SeparatePartsAreEachOriented) {
    const PointSet sphere = sampleSphereRandom(800, 1.0f, 9);
    PointSet both = withoutNormals(sphere);
    HugePageVector<glm::vec3> truth = sphere.normal;
    for (std::size_t i = 0; i < sphere.size(); ++i) {
        both.position.push_back(sphere.position[i] * 0.5f + glm::vec3(10, 0, -3));
        truth.push_back(sphere.normal[i]);
    }
    const auto estimate = estimateNormals(both, 2);
    ASSERT_TRUE(estimate.ok()) << estimate.error().message;
    EXPECT_EQ(estimate->components, 2u);
    EXPECT_EQ(compare(both, truth).flipped, 0u);
}

// Fewer points than kNormalNearest + 1: a square's four corners all face +z.
TEST(NormalEstimation, FewPointsFitTheirPlane) {
    PointSet square;
    square.position = {glm::vec3(0, 0, 1), glm::vec3(1, 0, 1), glm::vec3(1, 1, 1), glm::vec3(0, 1, 1)};
    const auto estimate = estimateNormals(square, 1);
    ASSERT_TRUE(estimate.ok()) << estimate.error().message;
    for (const glm::vec3& n : square.normal) EXPECT_EQ(n, glm::vec3(0, 0, 1));
}

// Every point six times over, and one point 20,000 times: coincident points count as one in the
// fit and the orientation (20,000 copies once crowded a search for distinct neighbours into
// quadratic time), and every copy gets the outward normal of its point.
TEST(NormalEstimation, CoincidentPointsCountOnceAndShareTheirNormal) {
    const PointSet sphere = sampleSphereRandom(1000, 1.0f, 13);
    PointSet copies;
    HugePageVector<glm::vec3> truth;
    for (int copy = 0; copy < 6; ++copy)
        for (std::size_t i = 0; i < sphere.size(); ++i) {
            copies.position.push_back(sphere.position[i]);
            truth.push_back(sphere.normal[i]);
        }
    for (int copy = 0; copy < 20000; ++copy) {
        copies.position.push_back(sphere.position[17]);
        truth.push_back(sphere.normal[17]);
    }
    const auto estimate = estimateNormals(copies, 2);
    ASSERT_TRUE(estimate.ok()) << estimate.error().message;
    const Agreement a = compare(copies, truth);
    std::cout << "[sphere 1000 random, 6 copies, one point 20,000 times] flipped " << a.flipped
              << ", mean error " << a.meanDegrees << " deg\n";
    EXPECT_EQ(a.flipped, 0u);
    EXPECT_LT(a.meanDegrees, 2.0);
    for (std::size_t i = 0; i < sphere.size(); ++i)
        ASSERT_EQ(copies.normal[i], copies.normal[5 * sphere.size() + i]);
    EXPECT_EQ(copies.normal.back(), copies.normal[17]);
}

TEST(NormalEstimation, ThreadCountDoesNotChangeTheNormals) {
    PointSet one = withoutNormals(sampleTorusRandom(3500, 1.0f, 0.4f, 7)), two = one;
    ASSERT_TRUE(estimateNormals(one, 1).ok());
    ASSERT_TRUE(estimateNormals(two, 2).ok());
    ASSERT_EQ(one.normal.size(), two.normal.size());
    EXPECT_TRUE(std::equal(one.normal.begin(), one.normal.end(), two.normal.begin()));
}

// Random points on the surface of the box [lo, hi] (each face as likely as its area), with their
// outward normals, those inside `skip` left out.
template <typename Skip>
void sampleBoxSurface(PointSet& points, glm::vec3 lo, glm::vec3 hi, int count, std::mt19937_64& rng,
                      const Skip& skip) {
    const glm::vec3 e = hi - lo;
    const double area[3] = {e.y * e.z, e.x * e.z, e.x * e.y}, total = 2.0 * (area[0] + area[1] + area[2]);
    for (int k = 0; k < count; ++k) {
        double pick = test::uniform01(rng) * total;
        int face = 0;
        while (face < 5 && pick >= area[face % 3]) pick -= area[face++ % 3];
        const int axis = face % 3;
        const bool high = face >= 3;
        glm::vec3 x =
            lo + glm::vec3(test::uniform(rng, 0, 1), test::uniform(rng, 0, 1), test::uniform(rng, 0, 1)) * e;
        x[axis] = high ? hi[axis] : lo[axis];
        if (skip(x)) continue;
        glm::vec3 n(0.0f);
        n[axis] = high ? 1.0f : -1.0f;
        points.position.push_back(x);
        points.normal.push_back(n);
    }
}

// Estimates the normals of `given`'s positions and counts those facing against `given`'s: of its
// first `part` points, and of the rest (the sphere). Prints both.
std::pair<std::size_t, std::size_t> inwardOfPartAndRest(const PointSet& given, std::size_t part,
                                                        const char* shape, const char* partName,
                                                        std::uint64_t seed) {
    PointSet points = withoutNormals(given);
    const auto estimate = estimateNormals(points, 2);
    if (!estimate.ok()) {
        ADD_FAILURE() << estimate.error().message;
        return {part, points.size() - part}; // every one counted inward
    }
    std::size_t partInward = 0, restInward = 0;
    for (std::size_t i = 0; i < points.size(); ++i)
        if (glm::dot(points.normal[i], given.normal[i]) < 0.0f) ++(i < part ? partInward : restInward);
    std::cout << "[" << shape << ", seed " << seed << "] inward: sphere " << restInward << " of "
              << points.size() - part << ", " << partName << " " << partInward << " of " << part << "\n";
    return {partInward, restInward};
}

// A unit sphere with a fin thinner than the spacing standing on its top: a box 0.06 thick and 1
// wide up to z = 1.8 (about 1,500 points on each). The fin's top, where the propagation starts,
// has a horizontal normal and its two faces mix in every neighbourhood, so the start's +z said
// nothing: the old orientation turned the whole sphere inside out for 3 of these 5 seeds, and 32
// to 58 % of the fin's normals faced inward. Visibility decides the sphere now: at most 1 % of its
// normals face inward (the few where the fin meets it). The fin's faces come out right for most
// of their points (2 to 22 % inward): a sheet thinner than the spacing is where the estimate
// stays weakest.
TEST(NormalEstimation, AThinFinDoesNotTurnItsBodyInsideOut) {
    const glm::vec3 lo(-0.03f, -0.5f, 0.5f), hi(0.03f, 0.5f, 1.8f);
    const auto inFin = [&](glm::vec3 x) {
        return glm::all(glm::greaterThan(x, lo)) && glm::all(glm::lessThan(x, hi));
    };
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
        std::mt19937_64 rng(seed);
        PointSet given;
        sampleBoxSurface(given, lo, hi, 1500, rng, [](glm::vec3 x) { return glm::length(x) <= 1.0f; });
        const std::size_t fin = given.size();
        while (given.size() < fin + 1500) {
            const glm::vec3 x = test::randomUnit(rng);
            if (inFin(x)) continue;
            given.position.push_back(x);
            given.normal.push_back(x);
        }
        const auto [finInward, sphereInward] = inwardOfPartAndRest(given, fin, "finned sphere", "fin", seed);
        EXPECT_LE(sphereInward, 15u) << "seed " << seed;
        EXPECT_LT(finInward, fin / 4) << "seed " << seed;
    }
}

// A unit sphere with a tail: a tube of radius 0.03 along z from the sphere's top, 60 points
// about twice its radius apart, so that each tail point's 10 nearest lie all around the tube and fit no
// plane (normalOf): its normal is the direction across the tube from their centroid, facing out.
// Over 5 seeds, with the direction of least variance instead, 11 to 28 of the tail's 60 normals
// faced inward; now 3 to 9.
TEST(NormalEstimation, AThinTailFacesOutward) {
    constexpr float kRadius = 0.03f, kLength = 1.2f;
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
        std::mt19937_64 rng(seed);
        std::uniform_real_distribution<float> unit(0.0f, 1.0f);
        PointSet given;
        for (int i = 0; i < 60; ++i) {
            const float angle = 2.0f * glm::pi<float>() * unit(rng), z = 1.0f + kLength * unit(rng);
            const glm::vec3 across(std::cos(angle), std::sin(angle), 0.0f);
            given.position.push_back(kRadius * across + glm::vec3(0.0f, 0.0f, z));
            given.normal.push_back(across);
        }
        const std::size_t tail = given.size();
        while (given.size() < tail + 1500) {
            const glm::vec3 x = test::randomUnit(rng);
            if (x.z > 0.99f) continue;
            given.position.push_back(x);
            given.normal.push_back(x);
        }
        const auto [tailInward, sphereInward] =
            inwardOfPartAndRest(given, tail, "sphere with a tail", "tail", seed);
        EXPECT_LE(sphereInward, 15u) << "seed " << seed;
        EXPECT_LE(tailInward, tail / 6) << "seed " << seed;
    }
}

// A unit sphere with six narrow wells, one along each axis: radius 0.1 (about 1.5 spacings of the
// sphere's 2,674 points) and 0.3 deep, 40 points on each wall and 6 on each floor, whose outward
// normals face into the well. A wall point's neighbours curve round it and lie outward of it, so
// the tip rule (agreeWithNeighbours), where their vote is weak, turned it to face into the wall.
// Over these 12 seeds, 667 of the wells' 3,312 normals faced inward (16 to 108 a seed) when the
// rule applied everywhere; with it only where the point looks out on that side or fits no plane,
// 281 (3 to 50). Wells this narrow stay hard: their opposite walls are 3 spacings apart.
TEST(NormalEstimation, NarrowWellsFaceOutward) {
    constexpr float kRadius = 0.1f, kDepth = 0.3f;
    const float rim = std::sqrt(1.0f - kRadius * kRadius), bottom = rim - kDepth;
    const glm::vec3 axes[] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    std::size_t inward = 0, all = 0;
    for (std::uint64_t seed = 1; seed <= 12; ++seed) {
        std::mt19937_64 rng(seed);
        PointSet given;
        for (const glm::vec3& a : axes) {
            const glm::vec3 b1 =
                glm::normalize(glm::cross(a, std::abs(a.x) < 0.5f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0)));
            const glm::vec3 b2 = glm::cross(a, b1);
            const auto across = [&](float angle) { return std::cos(angle) * b1 + std::sin(angle) * b2; };
            for (int k = 0; k < 40; ++k) {
                const glm::vec3 c = across(test::uniform(rng, 0.0, 2.0 * glm::pi<double>()));
                given.position.push_back(test::uniform(rng, bottom, rim) * a + kRadius * c);
                given.normal.push_back(-c);
            }
            for (int k = 0; k < 6; ++k) {
                const float r = kRadius * std::sqrt(test::uniform(rng, 0.0, 1.0));
                given.position.push_back(bottom * a +
                                         r * across(test::uniform(rng, 0.0, 2.0 * glm::pi<double>())));
                given.normal.push_back(a);
            }
        }
        const std::size_t wells = given.size();
        while (given.size() < wells + 2674) {
            const glm::vec3 x = test::randomUnit(rng);
            const auto inOpening = [&](const glm::vec3& a) {
                const float h = glm::dot(x, a);
                return h > 0.0f && glm::dot(x, x) - h * h < kRadius * kRadius;
            };
            if (std::any_of(std::begin(axes), std::end(axes), inOpening)) continue;
            given.position.push_back(x);
            given.normal.push_back(x);
        }
        const auto [wellInward, sphereInward] =
            inwardOfPartAndRest(given, wells, "sphere with wells", "wells", seed);
        EXPECT_LE(sphereInward, 5u) << "seed " << seed;
        inward += wellInward;
        all += wells;
    }
    EXPECT_LE(inward, all * 12 / 100);
}

// The same shape on 1 and 2 threads: the rays run on the workers.
TEST(NormalEstimation, ThreadCountDoesNotChangeTheVisibilityVote) {
    std::mt19937_64 rng(3);
    PointSet one;
    sampleBoxSurface(one, glm::vec3(-0.03f, -0.5f, 0.5f), glm::vec3(0.03f, 0.5f, 1.8f), 1500, rng,
                     [](glm::vec3 x) { return glm::length(x) <= 1.0f; });
    for (const glm::vec3& x : sampleSphereRandom(1500, 1.0f, 3).position)
        if (!(std::abs(x.x) < 0.03f && std::abs(x.y) < 0.5f && x.z > 0.5f)) one.position.push_back(x);
    one = withoutNormals(one);
    PointSet two = one;
    ASSERT_TRUE(estimateNormals(one, 1).ok());
    ASSERT_TRUE(estimateNormals(two, 2).ok());
    EXPECT_TRUE(std::equal(one.normal.begin(), one.normal.end(), two.normal.begin()));
}

// Every reference of ../shared/data with positions only, and 3 random 3,500-point subsets of each
// (seeds 1 to 3; compared with the subset's own reference normals), as given and turned over
// (180 degrees about x, exact in floating point): at most 1 % of the estimated normals face
// inward (issue 27). Before the visibility vote, the turned-over lion and fandisk subsets came out
// 98 and 100 % inward, and 5 of the 21 subsets as given above 1 %. Prints the share and the mean
// angle to the reference normal, unsigned (of the line) and signed.
TEST(NormalEstimation, ReferenceModelsAndTheirSubsetsFaceOutward) {
    const char* models[] = {"igea", "nefertiti", "bunny", "lion", "fandisk", "rockerarm", "banana"};
    for (const char* model : models) {
        const std::string file = std::string(model) + "-reference.ply";
        PNSPLAT_REQUIRE_DATA(file);
        auto data = readPly(test::dataDir() / file);
        ASSERT_TRUE(data.ok()) << data.error().message;
        const PointSet reference = std::move(data).value().points;
        for (const bool turned : {false, true}) {
            for (std::uint64_t seed = 0; seed <= 3; ++seed) {
                if (seed == 0 && turned) continue; // the whole reference once: it takes seconds
                PointSet given;
                std::vector<std::uint32_t> pick(reference.size());
                std::iota(pick.begin(), pick.end(), 0u);
                if (seed > 0) {
                    std::mt19937_64 rng(seed);
                    for (std::size_t i = 0; i < 3500; ++i)
                        std::swap(pick[i], pick[i + rng() % (pick.size() - i)]);
                    pick.resize(3500);
                    std::sort(pick.begin(), pick.end());
                }
                for (const std::uint32_t i : pick) {
                    const glm::vec3 x = reference.position[i], n = reference.normal[i];
                    given.position.push_back(turned ? glm::vec3(x.x, -x.y, -x.z) : x);
                    given.normal.push_back(turned ? glm::vec3(n.x, -n.y, -n.z) : n);
                }
                PointSet points = withoutNormals(given);
                const auto estimate = estimateNormals(points, 2);
                ASSERT_TRUE(estimate.ok()) << estimate.error().message;
                const Agreement a = compare(points, given.normal);
                double signedDegrees = 0.0;
                for (std::size_t i = 0; i < points.size(); ++i)
                    signedDegrees += degrees(std::acos(std::clamp(
                        static_cast<double>(glm::dot(points.normal[i], given.normal[i])), -1.0, 1.0)));
                signedDegrees /= static_cast<double>(points.size());
                const double share = static_cast<double>(a.flipped) / static_cast<double>(points.size());
                const std::string name = std::string(model) +
                                         (seed == 0 ? " reference" : " 3500 seed " + std::to_string(seed)) +
                                         (turned ? ", turned over" : "");
                std::cout << "[" << name << "] inward " << a.flipped << " of " << points.size() << " ("
                          << share * 100.0 << " %), mean error " << a.meanDegrees << " deg (line), "
                          << signedDegrees << " deg (signed)\n";
                EXPECT_LE(share, 0.01) << name;
            }
        }
    }
}

// Sparse real models against their given (mesh) normals. The rockerarm's thin walls and the
// fandisk's sharp creases are where Hoppe's weight alone crosses early: 18 % and 42 % of the
// normals came out flipped; with the tangent-plane term of orientationWeight, 0 and 0.13 %. With
// the visibility vote and the neighbours' agreement: 0 and 0.4 % (6 points); the bunny 0.26 % (was
// 0.54 %) and the lion 0.54 % (was 1.2 %).
TEST(NormalEstimation, DataModelsAgreeWithTheirNormals) {
    const struct {
        const char* file;
        double maxFlippedShare;
    } cases[] = {
        {"rockerarm-2000-uniform.ply", 0.0}, {"fandisk-1500-uniform.ply", 0.005},
        {"bunny-3500-random.ply", 0.01},     {"igea-600-uniform.ply", 0.0},
        {"lion-3500-random.ply", 0.01},
    };
    for (const auto& c : cases) {
        PNSPLAT_REQUIRE_DATA(c.file);
        auto data = readPly(test::dataDir() / c.file);
        ASSERT_TRUE(data.ok()) << data.error().message;
        const PointSet given = std::move(data).value().points;
        PointSet points = withoutNormals(given);
        const auto estimate = estimateNormals(points, 2);
        ASSERT_TRUE(estimate.ok()) << estimate.error().message;
        const Agreement a = compare(points, given.normal);
        const double share = static_cast<double>(a.flipped) / static_cast<double>(points.size());
        std::cout << "[" << c.file << "] flipped " << a.flipped << " of " << points.size() << " ("
                  << share * 100.0 << " %), mean unsigned error " << a.meanDegrees << " deg\n";
        EXPECT_LE(share, c.maxFlippedShare) << c.file;
    }
}

// No plane to fit, too few points, a non-finite position, an extent too large or too small: an
// error, and nothing changes (positions, normals given before, radii).
TEST(NormalEstimation, BadInputIsAnErrorAndChangesNothing) {
    const auto withAttributes = [](PointSet points) {
        points.normal.assign(points.size(), glm::vec3(0, 0, 1));
        points.radius.assign(points.size(), 0.25f);
        return points;
    };
    PointSet line, diagonal, coincident, few;
    for (int k = 0; k < 20; ++k) line.position.push_back(glm::vec3(0.1f * static_cast<float>(k), 1, 2));
    // Along (1, 1, 1.3) away from the origin: off the line by the rounding of the coordinates only.
    for (int k = 0; k < 50; ++k) {
        const float t = 0.37f * static_cast<float>(k);
        diagonal.position.push_back(glm::vec3(10.0f + t, 10.0f + t, 10.0f + 1.3f * t));
    }
    for (int k = 0; k < 20; ++k) coincident.position.push_back(glm::vec3(1, 2, 3));
    few.position = {glm::vec3(0), glm::vec3(1, 0, 0)};
    PointSet twoPlaces;
    twoPlaces.position = {glm::vec3(0), glm::vec3(0), glm::vec3(1, 0, 0), glm::vec3(1, 0, 0), glm::vec3(0)};
    PointSet notFinite = sampleSphereUniform(100, 1.0f), huge = notFinite, tiny = notFinite;
    notFinite.position[37].y = std::nanf("");
    for (glm::vec3& x : huge.position) x *= 1e20f;
    for (glm::vec3& x : tiny.position) x *= 1e-23f;
    const struct {
        const char* name;
        PointSet points;
        const char* says;
    } cases[] = {
        {"points on a line", withAttributes(line), "no normal can be estimated for 20 point(s)"},
        {"a diagonal line off the origin", withAttributes(diagonal),
         "no normal can be estimated for 50 point(s)"},
        {"coincident points", withAttributes(coincident), "all 20 points coincide"},
        {"two points", withAttributes(few), "at least 3 points"},
        {"two distinct positions", withAttributes(twoPlaces), "2 distinct positions among 5 points"},
        {"NaN position", withAttributes(notFinite), "point 37 has a non-finite position"},
        {"extent 2e20", withAttributes(huge), "too large to estimate normals"},
        {"extent 2e-23", withAttributes(tiny), "too small to estimate normals"},
    };
    for (const auto& c : cases) {
        PointSet points = c.points;
        const auto estimate = estimateNormals(points, 2);
        ASSERT_FALSE(estimate.ok()) << c.name;
        std::cout << "[" << c.name << "] " << estimate.error().message << "\n";
        EXPECT_NE(estimate.error().message.find(c.says), std::string::npos) << estimate.error().message;
        const auto same = [](glm::vec3 a, glm::vec3 b) { return a == b || (a != a && b != b); }; // NaN too
        EXPECT_TRUE(
            std::equal(points.position.begin(), points.position.end(), c.points.position.begin(), same))
            << c.name;
        EXPECT_TRUE(points.normal == c.points.normal) << c.name;
        EXPECT_TRUE(points.radius == c.points.radius) << c.name;
    }
}

} // namespace
} // namespace pnsplat
