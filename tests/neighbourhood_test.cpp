// Tests of the one-ring neighbourhoods (neighbourhood.h, ALGORITHM.md §3) and of the radius
// estimation built on them (radius_estimation.h, ALGORITHM.md §9.3). Oracles: the badness formula
// on hand-made configurations with exact values, a planar hexagonal grid whose first ring is known,
// the paper's Figure 6 on a cylinder, brute-force Euclidean neighbourhoods for the symmetry rates,
// and invariants (orthonormal frames, sorted fans, thread-count independence).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "pnsplat/refine/angles.h"
#include "pnsplat/refine/neighbourhood.h"
#include "pnsplat/refine/pn_triangle.h"
#include "pnsplat/refine/radius_estimation.h"
#include "pnsplat/refine/shapes/shapes.h"
#include "test_random.h"

namespace pnsplat {
namespace {

using test::randomUnit;
using test::uniform;
using test::uniform01;

constexpr double kPi = std::numbers::pi;
constexpr float kPiF = std::numbers::pi_v<float>;

glm::vec3 polar(double radius, double degrees, float z = 0.0f) {
    const double a = radians(degrees);
    return glm::vec3(static_cast<float>(radius * std::cos(a)), static_cast<float>(radius * std::sin(a)), z);
}

std::vector<std::uint32_t> indices(const NeighbourSet& set) {
    return set.index;
}

// The position filterFuzzy measured the badness on for input entry k (the geodesic projection q'_k
// for Ng, p_k itself for Nf), read back from the public scratch buffers.
glm::vec3 projected(const NeighbourhoodScratch& scratch, std::size_t k) {
    return glm::vec3(scratch.px[k], scratch.py[k], scratch.pz[k]);
}

// ---------------------------------------------------------------------------------------------
// fuzzyBadness

TEST(FuzzyBadness, HandMadeValues) {
    const float sinThetaF = std::sin(kPiF / 6.0f);
    const glm::vec3 p(0.0f), pj(1.0f, 0.0f, 0.0f);
    // Directly behind (collinear beyond p_j): sin α = 1, w = (1/sin θf + 1)/2 = 1.5.
    EXPECT_NEAR(fuzzyBadness(p, glm::vec3(2.0f, 0.0f, 0.0f), pj, sinThetaF), 1.5f, 1e-6f);
    // Perpendicular: sin α = 0, w = 0.5.
    EXPECT_EQ(fuzzyBadness(p, glm::vec3(1.0f, 0.7f, 0.0f), pj, sinThetaF), 0.5f);
    // α just above -θf: small positive; just below: 0.
    EXPECT_GT(fuzzyBadness(p, pj + polar(1.0, 120.0 - 2.0), pj, sinThetaF), 0.0f);
    EXPECT_LT(fuzzyBadness(p, pj + polar(1.0, 120.0 - 2.0), pj, sinThetaF), 0.05f);
    EXPECT_EQ(fuzzyBadness(p, pj + polar(1.0, 120.0 + 2.0), pj, sinThetaF), 0.0f);
    // α = -θf within rounding (sin θf = 1/2): w = 0.
    EXPECT_NEAR(fuzzyBadness(p, pj + polar(1.0, 120.0), pj, sinThetaF), 0.0f, 1e-6f);
    // α = -θf exactly with θf = π/2 (sin θf = 1): p_i in front of p_j, w = 0 exactly.
    EXPECT_EQ(fuzzyBadness(p, glm::vec3(0.5f, 0.0f, 0.0f), pj, 1.0f), 0.0f);
    // α < -θf: 0.
    EXPECT_EQ(fuzzyBadness(p, glm::vec3(0.5f, 0.1f, 0.0f), pj, sinThetaF), 0.0f);
    // Coincident p_i, p_j: 0 (no NaN).
    EXPECT_EQ(fuzzyBadness(p, pj, pj, sinThetaF), 0.0f);
}

TEST(FuzzyBadness, BothOverloadsAgree) {
    std::mt19937_64 rng(201);
    const float sinThetaF = std::sin(kPiF / 6.0f);
    int positive = 0;
    for (int trial = 0; trial < 5000; ++trial) {
        const glm::vec3 p(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
        const glm::vec3 pi(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
        const glm::vec3 pj(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
        const float w = fuzzyBadness(p, pi, pj, sinThetaF);
        EXPECT_NEAR(w, fuzzyBadness(glm::normalize(pj - p), pi - pj, sinThetaF), 1e-6f) << trial;
        // The formula itself, in double.
        const double sinAlpha =
            glm::dot(glm::normalize(glm::dvec3(pj - p)), glm::normalize(glm::dvec3(pi - pj)));
        const double expected = sinAlpha < -0.5 ? 0.0 : 0.5 * (sinAlpha / 0.5 + 1.0);
        EXPECT_NEAR(w, expected, 1e-5) << trial;
        positive += w > 0.0f;
    }
    EXPECT_GT(positive, 1000);
}

// ---------------------------------------------------------------------------------------------
// TangentFrame, sortFan

TEST(TangentFrame, OrthonormalRightHandedForManyNormals) {
    std::mt19937_64 rng(202);
    std::vector<glm::vec3> normals = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}};
    for (float eps : {1e-2f, 1e-4f, 1e-6f, 1e-8f}) {
        normals.push_back(glm::normalize(glm::vec3(eps, 0.0f, -1.0f)));
        normals.push_back(glm::normalize(glm::vec3(0.0f, -eps, -1.0f)));
        normals.push_back(glm::normalize(glm::vec3(eps, eps, -1.0f)));
        normals.push_back(glm::normalize(glm::vec3(eps, eps, 1.0f)));
    }
    normals.push_back(glm::vec3(0.6f, 0.8f, -0.0f)); // z = -0: the frame's sign switch
    normals.push_back(glm::vec3(0.6f, 0.8f, 0.0f));
    while (normals.size() < 1000) normals.push_back(randomUnit(rng));
    for (const glm::vec3 n : normals) {
        const TangentFrame f(n);
        EXPECT_EQ(f.n, n);
        EXPECT_NEAR(glm::length(f.u), 1.0f, 1e-5f) << n.x << " " << n.y << " " << n.z;
        EXPECT_NEAR(glm::length(f.v), 1.0f, 1e-5f) << n.x << " " << n.y << " " << n.z;
        EXPECT_NEAR(glm::dot(f.u, f.v), 0.0f, 1e-5f);
        EXPECT_NEAR(glm::dot(f.u, n), 0.0f, 1e-5f);
        EXPECT_NEAR(glm::dot(f.v, n), 0.0f, 1e-5f);
        EXPECT_LT(glm::length(glm::cross(f.u, f.v) - n), 1e-5f) << n.x << " " << n.y << " " << n.z;
        // angleOf measures the angle of the tangent projection in that frame.
        EXPECT_NEAR(f.angleOf(f.u), 0.0f, 1e-5f);
        EXPECT_NEAR(f.angleOf(f.v + 3.0f * n), kPiF / 2.0f, 1e-4f);
        EXPECT_NEAR(std::abs(f.angleOf(-f.u)), kPiF, 1e-4f);
    }
}

TEST(SortFan, SortsByAngleAroundTheNormal) {
    std::mt19937_64 rng(203);
    NeighbourhoodScratch scratch;
    for (int trial = 0; trial < 200; ++trial) {
        const glm::vec3 p(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
        const glm::vec3 n = randomUnit(rng);
        const TangentFrame frame(n);
        NeighbourSet set;
        const int count = 1 + static_cast<int>(rng() % 20);
        std::vector<std::uint32_t> inputIndex;
        for (int k = 0; k < count; ++k) {
            const glm::vec3 q = p + uniform(rng, 0.1, 1.0) * randomUnit(rng);
            const auto id = static_cast<std::uint32_t>(rng() % 100000);
            set.push(id, q, randomUnit(rng));
            inputIndex.push_back(id);
        }
        sortFan(p, n, set, scratch);
        ASSERT_EQ(set.size(), static_cast<std::size_t>(count));
        ASSERT_EQ(set.angle.size(), set.size());
        ASSERT_EQ(set.nearControl.size(), set.size());
        ASSERT_EQ(set.farControl.size(), set.size());
        std::vector<std::uint32_t> out = indices(set);
        std::sort(out.begin(), out.end());
        std::sort(inputIndex.begin(), inputIndex.end());
        EXPECT_EQ(out, inputIndex); // a permutation
        for (std::size_t k = 0; k < set.size(); ++k) {
            const glm::vec3 d = set.position[k] - p;
            const double expected = std::atan2(glm::dot(d, frame.v), glm::dot(d, frame.u));
            EXPECT_NEAR(set.angle[k], expected, 2e-5);
            if (k > 0) {
                EXPECT_LE(set.angle[k - 1], set.angle[k]);
            }
            EXPECT_EQ(set.nearControl[k], edgeControlPoint(p, n, set.position[k]));
            EXPECT_EQ(set.farControl[k], edgeControlPoint(set.position[k], set.normal[k], p));
        }
    }
}

// ---------------------------------------------------------------------------------------------
// filterFuzzy on a planar hexagonal configuration

struct HexCase {
    glm::vec3 p{0.25f, -0.5f, 2.0f};
    glm::vec3 n{0.0f, 0.0f, 1.0f};
    NeighbourSet set;
    std::vector<std::uint32_t> firstRingByAngle; // expected result
};

// A centre with its 6 first-ring neighbours (distance 1, ids 0-5), the 6 second-ring points at √3
// (ids 10-15) and the 6 at distance 2 (ids 20-25). Rotated by 7° so no angle sits on ±π. With
// jitterDeg != 0 the second ring is turned by ±jitterDeg (alternating) so that no second-ring point
// has exactly the tangent angle of a first-ring point.
HexCase makeHexCase(double jitterDeg = 0.0) {
    HexCase c;
    const double rotation = 7.0;
    for (std::uint32_t k = 0; k < 6; ++k) {
        const double a = rotation + 60.0 * k;
        const double jitter = k % 2 == 0 ? jitterDeg : -jitterDeg;
        c.set.push(k, c.p + polar(1.0, a), c.n);
        c.set.push(10 + k, c.p + polar(std::sqrt(3.0), a + 30.0 + jitter), c.n);
        c.set.push(20 + k, c.p + polar(2.0, a + jitter), c.n);
    }
    // Angles 7, 67, 127, 187 = -173, 247 = -113, 307 = -53: sorted: 3, 4, 5, 0, 1, 2.
    c.firstRingByAngle = {3, 4, 5, 0, 1, 2};
    return c;
}

void checkHexResult(const HexCase& c, const NeighbourSet& set, const std::string& label) {
    ASSERT_EQ(indices(set), c.firstRingByAngle) << label;
    ASSERT_EQ(set.angle.size(), set.size());
    for (std::size_t k = 1; k < set.size(); ++k) EXPECT_LT(set.angle[k - 1], set.angle[k]) << label;
    for (std::size_t k = 0; k < set.size(); ++k) {
        const glm::vec3 d = set.position[k] - c.p;
        EXPECT_NEAR(glm::length(d), 1.0f, 1e-6f) << label;
        EXPECT_NEAR(set.angle[k], std::atan2(d.y, d.x), 2e-5) << label;
        // Flat: the control points are at the thirds of the segment.
        EXPECT_LT(glm::length(set.nearControl[k] - (c.p + d / 3.0f)), 1e-6f) << label;
        EXPECT_LT(glm::length(set.farControl[k] - (c.p + 2.0f * d / 3.0f)), 1e-6f) << label;
    }
}

// The second ring turned by 0.3°: every point at distance 2 is strongly behind a first-ring point
// (w ≈ 1.5), every point at √3 slightly behind two (w ≈ 1 + 1). Only the first ring survives.
TEST(FilterFuzzy, JitteredHexagonKeepsExactlyTheFirstRingInFanOrder) {
    for (bool geodesic : {false, true}) {
        const HexCase reference = makeHexCase(0.3);
        HexCase c = reference;
        FuzzyParams params;
        params.geodesicProjection = geodesic;
        NeighbourhoodScratch scratch;
        filterFuzzy(c.p, c.n, params, c.set, scratch);
        checkHexResult(c, c.set, geodesic ? "Ng" : "Nf");
        // On a plane G = |d|: the geodesic projections are the points themselves (Ng = Nf).
        if (geodesic) {
            ASSERT_GE(scratch.px.size(), reference.set.size()); // input order, 18 entries (and padding)
            for (std::size_t k = 0; k < reference.set.size(); ++k)
                EXPECT_LT(glm::length(projected(scratch, k) - reference.set.position[k]), 2e-6f) << k;
        }
    }
}

// Regression: a neighbour p_j at exactly p_i's tangent angle (delta == 0) used to count in neither
// Succ_i nor Pred_i, so a point exactly behind another (w_ij = 1.5) was kept. On this exact hexagon
// the points at distance 2 straight behind the first ring survived whenever their float angles
// tied. Such a j now counts as a successor (neighbourhood.cpp).
TEST(FilterFuzzy, HexagonKeepsExactlyTheFirstRingInFanOrder) {
    for (bool geodesic : {false, true}) {
        HexCase c = makeHexCase();
        FuzzyParams params;
        params.geodesicProjection = geodesic;
        NeighbourhoodScratch scratch;
        filterFuzzy(c.p, c.n, params, c.set, scratch);
        checkHexResult(c, c.set, geodesic ? "Ng" : "Nf");
    }
}

TEST(FilterFuzzy, IndependentOfInputOrder) {
    const HexCase reference = makeHexCase(0.3);
    std::mt19937_64 rng(204);
    for (bool geodesic : {false, true}) {
        FuzzyParams params;
        params.geodesicProjection = geodesic;
        for (int trial = 0; trial < 20; ++trial) {
            std::vector<std::uint32_t> order(reference.set.size());
            for (std::uint32_t k = 0; k < order.size(); ++k) order[k] = k;
            std::shuffle(order.begin(), order.end(), rng);
            NeighbourSet set;
            for (std::uint32_t k : order)
                set.push(reference.set.index[k], reference.set.position[k], reference.set.normal[k]);
            NeighbourhoodScratch scratch;
            filterFuzzy(reference.p, reference.n, params, set, scratch);
            EXPECT_EQ(indices(set), reference.firstRingByAngle)
                << "trial " << trial << " geodesic " << geodesic;
        }
    }
}

// The filter computes its per-entry terms in flat arrays, eight lanes at a time. Oracle: the vector
// formulas of ALGORITHM.md §2.2, §2.7 and §3.3 in glm, entry by entry, which must give the same
// bits: the positions the badness is measured on (q'_i = p + tangent · (G / |tangent|), q_i itself
// for Nf or where the tangent is 0), their unit directions from p (glm::normalize), and the fan's
// edge control points (edgeControlPoints), the tangent-plane coordinates and the angles, for Nf, Ng
// and variant 1, with and without the control points asked for, on random sets of 1 to 40 entries
// with random normals (some along the edge, where the control point is the edge's third, and some
// entries straight above p).
TEST(FilterFuzzy, PerEntryTermsAreTheVectorFormulasBitForBit) {
    std::mt19937_64 rng(212);
    enum class Measure { Points, Geodesic, Euclidean };
    NeighbourhoodScratch scratch;
    std::size_t checked = 0, straight = 0, above = 0;
    for (int trial = 0; trial < 300; ++trial) {
        const Measure measure = static_cast<Measure>(trial % 3);
        FuzzyParams params;
        params.geodesicProjection = measure != Measure::Points;
        params.euclideanGeodesic = measure == Measure::Euclidean;
        params.edgeControls = trial % 2 == 0;
        const glm::vec3 p(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
        const glm::vec3 n = randomUnit(rng);
        const TangentFrame frame(n);
        NeighbourSet set;
        const auto count = static_cast<std::uint32_t>(1 + rng() % 40);
        for (std::uint32_t k = 0; k < count; ++k) {
            const glm::vec3 d = k % 11 == 5 ? n * static_cast<float>(uniform(rng, 0.1, 1.0))
                                            : static_cast<float>(uniform(rng, 0.1, 1.0)) * randomUnit(rng);
            const glm::vec3 m = k % 7 == 3 ? glm::normalize(d) : randomUnit(rng);
            set.push(k, p + d, m);
        }
        const NeighbourSet input = set;
        filterFuzzy(p, n, params, set, scratch);
        for (std::uint32_t k = 0; k < count; ++k) {
            const glm::vec3 q = input.position[k], d = q - p;
            ASSERT_EQ(scratch.su[k], glm::dot(d, frame.u)) << "trial " << trial << ", entry " << k;
            ASSERT_EQ(scratch.sv[k], glm::dot(d, frame.v)) << "trial " << trial << ", entry " << k;
            glm::vec3 y = q;
            if (params.geodesicProjection) {
                const glm::vec3 tangent = d - glm::dot(d, n) * n;
                const float tangentLength = glm::length(tangent);
                const float g =
                    params.euclideanGeodesic ? glm::length(d) : geodesicDistance(p, n, q, input.normal[k]);
                if (tangentLength > 0.0f) y = p + tangent * (g / tangentLength);
                above += tangentLength > 0.0f ? 0 : 1;
            }
            const glm::vec3 direction = glm::normalize(y - p);
            ASSERT_EQ(projected(scratch, k), y) << "trial " << trial << ", entry " << k;
            ASSERT_EQ(glm::vec3(scratch.dx[k], scratch.dy[k], scratch.dz[k]), direction)
                << "trial " << trial << ", entry " << k;
            ++checked;
        }
        for (std::size_t k = 0; k < set.size(); ++k)
            ASSERT_EQ(set.angle[k], frame.angleOf(set.position[k] - p))
                << "trial " << trial << ", fan member " << k;
        if (!params.edgeControls && measure != Measure::Geodesic) {
            EXPECT_TRUE(set.nearControl.empty() && set.farControl.empty()) << "trial " << trial;
            continue;
        }
        for (std::size_t k = 0; k < set.size(); ++k) {
            const EdgeControls e = edgeControlPoints(p, n, set.position[k], set.normal[k]);
            ASSERT_EQ(set.nearControl[k], e.ab) << "trial " << trial << ", fan member " << k;
            ASSERT_EQ(set.farControl[k], e.ba) << "trial " << trial << ", fan member " << k;
            const glm::vec3 third = (set.position[k] - p) * (1.0f / 3.0f);
            straight += set.farControl[k] == set.position[k] - third ? 1 : 0;
        }
    }
    EXPECT_GT(checked, 5000u);
    EXPECT_GT(straight, 0u); // a normal along the edge: the control point is the edge's third
    EXPECT_GT(above, 0u);    // an entry straight above p: measured where it is
}

// Sets of more than 64 entries take the filter's blocked path (entries by distance, each test ended
// once it fails); the small sets after them reuse the scratch arrays, whose padding lanes (past a
// set's size, up to a multiple of 8) then hold the earlier sets' leftovers, which must not count.
// Oracle: the rule of ALGORITHM.md §3.2 by brute force, w_i = max over Succ_i + max over Pred_i of
// fuzzyBadness against every other entry, on random points of a paraboloid patch, measured on the
// points themselves (Nf), on their geodesic projections q'_i = p + G(p,p_i)·normalize(q_i - p)
// (Ng), and on those with G = |p p_i| (variant 1). Entries whose oracle w_i lies within 1e-4 of
// 1 are left out of the comparison: the filter computes the same formula with a multiplication
// where fuzzyBadness divides. Shuffled inputs give the same output. The last large set puts 80
// points on one side of p and two far points on the other, one behind the other: the farther is
// removed only by a point outside the first block of nearest entries.
TEST(FilterFuzzy, SetsMatchBruteForce) {
    enum class Measure { Points, Geodesic, Euclidean };
    for (const Measure measure : {Measure::Points, Measure::Geodesic, Measure::Euclidean}) {
        std::mt19937_64 rng(611);
        const glm::vec3 p(0.0f), n(0.0f, 0.0f, 1.0f);
        const TangentFrame frame(n);
        FuzzyParams params;
        params.geodesicProjection = measure != Measure::Points;
        params.euclideanGeodesic = measure == Measure::Euclidean;
        const float sinThetaF = std::sin(params.thetaF);
        std::size_t compared = 0, removed = 0;
        const auto onPatch = [](float x, float y) { return glm::vec3(x, y, 0.3f * (x * x + y * y)); };
        const auto normalAt = [](float x, float y) {
            return glm::normalize(glm::vec3(-0.6f * x, -0.6f * y, 1.0f));
        };
        // Where the badness of an entry is measured (ALGORITHM.md §3.2).
        const auto measured = [&](glm::vec3 pi, glm::vec3 ni) {
            if (measure == Measure::Points) return pi;
            const glm::vec3 q = pi - glm::dot(pi - p, n) * n;
            const float g =
                measure == Measure::Geodesic ? geodesicDistance(p, n, pi, ni) : glm::length(pi - p);
            return p + g * glm::normalize(q - p);
        };
        NeighbourhoodScratch scratch; // shared: the small sets' padding lanes hold the large sets' leftovers
        // Large sets (survivors by distance), then small ones (survivorsOfSmallSet), many of the size
        // of a first ring.
        std::vector<std::size_t> counts = {65u, 100u, 256u, 700u, 82u, 13u, 5u, 30u};
        for (std::size_t k = 0; k < 200; ++k) counts.push_back(3 + k % 62);
        for (const std::size_t count : counts) {
            const bool farPair = count == 82u;
            NeighbourSet set;
            for (std::uint32_t k = 0; k < count; ++k) {
                float x = uniform(rng, -1.0, 1.0), y = uniform(rng, -1.0, 1.0);
                if (farPair) {
                    x = k < 80 ? uniform(rng, 0.2, 1.0) : (k == 80 ? -2.0f : -3.0f);
                    y = k < 80 ? y : 0.05f * float(k - 79);
                }
                set.push(k, onPatch(x, y), normalAt(x, y));
            }
            std::vector<glm::vec3> at(count);
            for (std::size_t i = 0; i < count; ++i) at[i] = measured(set.position[i], set.normal[i]);
            std::vector<std::uint32_t> expected;
            std::set<std::uint32_t> borderline;
            for (std::size_t i = 0; i < count; ++i) {
                const glm::vec3 di = set.position[i] - p;
                const float ui = glm::dot(di, frame.u), vi = glm::dot(di, frame.v);
                float succ = 0.0f, pred = 0.0f;
                for (std::size_t j = 0; j < count; ++j) {
                    const glm::vec3 dj = set.position[j] - p;
                    const float uj = glm::dot(dj, frame.u), vj = glm::dot(dj, frame.v);
                    const float cross = ui * vj - vi * uj;
                    const float w = fuzzyBadness(p, at[i], at[j], sinThetaF);
                    if (cross > 0.0f || (cross == 0.0f && ui * uj + vi * vj > 0.0f))
                        succ = std::max(succ, w);
                    else if (cross < 0.0f)
                        pred = std::max(pred, w);
                }
                if (std::abs(succ + pred - 1.0f) < 1e-4f)
                    borderline.insert(set.index[i]);
                else if (succ + pred < 1.0f)
                    expected.push_back(set.index[i]);
            }
            NeighbourSet shuffled;
            std::vector<std::uint32_t> order(count);
            for (std::uint32_t k = 0; k < count; ++k) order[k] = k;
            std::shuffle(order.begin(), order.end(), rng);
            for (const std::uint32_t k : order) shuffled.push(set.index[k], set.position[k], set.normal[k]);
            filterFuzzy(p, n, params, set, scratch);
            filterFuzzy(p, n, params, shuffled, scratch);
            EXPECT_EQ(indices(set), indices(shuffled)) << count << " entries";
            EXPECT_TRUE(std::is_sorted(set.angle.begin(), set.angle.end())) << count << " entries";
            std::vector<std::uint32_t> kept;
            for (const std::uint32_t i : set.index)
                if (!borderline.count(i)) kept.push_back(i);
            std::sort(kept.begin(), kept.end());
            EXPECT_EQ(kept, expected) << count << " entries, measure " << static_cast<int>(measure);
            if (farPair) {
                EXPECT_TRUE(std::count(expected.begin(), expected.end(), 80u) == 1 &&
                            std::count(expected.begin(), expected.end(), 81u) == 0)
                    << "the oracle keeps the nearer far point and removes the one behind it";
            }
            compared += count - borderline.size();
            removed += count - set.size();
        }
        std::cout << "[filter sets, measure " << static_cast<int>(measure) << "] " << compared
                  << " entries compared with brute force, " << removed << " removed\n";
        EXPECT_GT(removed, 900u); // most of a dense patch lies behind the first ring
    }
}

TEST(FilterFuzzy, StronglyBehindOneIsRemovedSlightlyBehindTwoIsKept) {
    const glm::vec3 p(0.0f), n(0.0f, 0.0f, 1.0f);
    FuzzyParams params;
    params.geodesicProjection = false;
    NeighbourhoodScratch scratch;
    {
        // i = 9 behind j = 1 with sin α = cos 20°: w = (0.94/0.5 + 1)/2 = 1.44 > 1, one side only.
        NeighbourSet set;
        set.push(1, glm::vec3(1.0f, 0.0f, 0.0f), n);
        set.push(9, glm::vec3(1.0f, 0.0f, 0.0f) + polar(1.0, -20.0), n);
        set.push(2, polar(1.0, 120.0), n);
        set.push(3, polar(1.0, -120.0), n);
        filterFuzzy(p, n, params, set, scratch);
        EXPECT_EQ(indices(set), (std::vector<std::uint32_t>{3, 1, 2}));
    }
    {
        // i = 9 at (2,0) on the Thales circle of j = 1 at (1,1) and j = 2 at (1,-1): p_i - p_j is
        // perpendicular to p_j - p on both sides, w_i = 0.5 + 0.5 = 1 exactly: kept (rule is w_i > 1).
        NeighbourSet set;
        set.push(1, glm::vec3(1.0f, 1.0f, 0.0f), n);
        set.push(2, glm::vec3(1.0f, -1.0f, 0.0f), n);
        set.push(9, glm::vec3(2.0f, 0.0f, 0.0f), n);
        filterFuzzy(p, n, params, set, scratch);
        EXPECT_EQ(indices(set), (std::vector<std::uint32_t>{2, 9, 1}));
    }
    {
        // Slightly farther out: a little more than 0.5 on each side, removed.
        NeighbourSet set;
        set.push(1, glm::vec3(1.0f, 1.0f, 0.0f), n);
        set.push(2, glm::vec3(1.0f, -1.0f, 0.0f), n);
        set.push(9, glm::vec3(2.05f, 0.0f, 0.0f), n);
        filterFuzzy(p, n, params, set, scratch);
        EXPECT_EQ(indices(set), (std::vector<std::uint32_t>{2, 1}));
    }
    {
        // Behind only one of the two (the other far away sideways): w_i ≈ 0.52 + 0.06 < 1, kept.
        NeighbourSet set;
        set.push(1, glm::vec3(1.0f, 1.0f, 0.0f), n);
        set.push(2, glm::vec3(0.0f, -1.0f, 0.0f), n);
        set.push(9, glm::vec3(2.05f, 0.0f, 0.0f), n);
        filterFuzzy(p, n, params, set, scratch);
        EXPECT_EQ(indices(set), (std::vector<std::uint32_t>{2, 9, 1}));
    }
}

// Regression, the smallest case: p_i = (2,0,0) exactly behind p_j = (1,0,0) (w_ij = 1.5) has the
// same tangent angle; it used to be kept.
TEST(FilterFuzzy, PointExactlyBehindAnotherIsRemoved) {
    const glm::vec3 p(0.0f), n(0.0f, 0.0f, 1.0f);
    FuzzyParams params;
    params.geodesicProjection = false;
    NeighbourhoodScratch scratch;
    NeighbourSet set;
    set.push(1, glm::vec3(1.0f, 0.0f, 0.0f), n);
    set.push(9, glm::vec3(2.0f, 0.0f, 0.0f), n); // w_{9,1} = 1.5
    set.push(2, polar(1.0, 120.0), n);
    set.push(3, polar(1.0, -120.0), n);
    filterFuzzy(p, n, params, set, scratch);
    EXPECT_EQ(indices(set), (std::vector<std::uint32_t>{3, 1, 2}));
}

// The paper's Figure 6 on a cylinder of radius 1 (axis y), p on top: p0 at 30° around the tube
// (shifted slightly along the axis so its tangent angle differs from p1's), p1 at 135°. Euclidean:
// sin α = cos(135°/2) ≈ 0.38, w ≈ 0.88, so Nf keeps both. After geodesic projection p1 is almost
// exactly behind p0 (w ≈ 1.5): Ng removes it.
TEST(FilterFuzzy, GeodesicProjectionRemovesPointBehindOnCurvedSurface) {
    const glm::vec3 p(0.0f, 0.0f, 1.0f), n(0.0f, 0.0f, 1.0f);
    const auto onCylinder = [](double degrees, float y, glm::vec3& normal) {
        const double a = radians(degrees);
        normal = glm::vec3(static_cast<float>(std::sin(a)), 0.0f, static_cast<float>(std::cos(a)));
        return glm::vec3(normal.x, y, normal.z);
    };
    glm::vec3 n0, n1;
    const glm::vec3 p0 = onCylinder(30.0, 0.02f, n0);
    const glm::vec3 p1 = onCylinder(135.0, 0.0f, n1);
    ASSERT_TRUE(validNeighbours(p, n, p0, n0));
    ASSERT_TRUE(validNeighbours(p, n, p1, n1));
    const auto run = [&](bool geodesic, NeighbourhoodScratch& scratch) {
        NeighbourSet set;
        set.push(0, p0, n0);
        set.push(1, p1, n1);
        FuzzyParams params;
        params.geodesicProjection = geodesic;
        filterFuzzy(p, n, params, set, scratch);
        return indices(set);
    };
    NeighbourhoodScratch euclidean, geodesic;
    EXPECT_EQ(run(false, euclidean), (std::vector<std::uint32_t>{1, 0}));
    EXPECT_EQ(run(true, geodesic), (std::vector<std::uint32_t>{0}));
    // The projections used by Ng lie in the tangent plane at the geodesic distance G(p, p_i).
    const glm::vec3 ps[2] = {p0, p1}, ns[2] = {n0, n1};
    for (std::size_t k = 0; k < 2; ++k) {
        const glm::vec3 q = projected(geodesic, k);
        EXPECT_NEAR(glm::dot(q - p, n), 0.0f, 1e-6f);
        EXPECT_NEAR(glm::length(q - p), geodesicDistance(p, n, ps[k], ns[k]), 1e-5f);
        EXPECT_GT(glm::length(q - p), glm::length(ps[k] - p) * 1.01f); // a real change of distance
    }
    // The badness values behind the decision.
    const float sinThetaF = std::sin(kPiF / 6.0f);
    EXPECT_LT(fuzzyBadness(p, p1, p0, sinThetaF), 1.0f);
    EXPECT_GT(fuzzyBadness(p, projected(geodesic, 1), projected(geodesic, 0), sinThetaF), 1.4f);
}

// ---------------------------------------------------------------------------------------------
// Symmetry rates (ALGORITHM.md §3.2)

struct SymmetryResult {
    double rate = 0.0;
    double meanSize = 0.0;
    std::size_t pairs = 0;
};

// Nε by brute force (|p - p_i| < r_p and eq. 6), then filterFuzzy; rate = share of the unordered
// pairs {i, j} present in at least one neighbourhood that are present in both.
SymmetryResult symmetryRate(const PointSet& points, bool geodesic) {
    const std::size_t count = points.size();
    std::vector<std::vector<std::uint32_t>> hood(count);
    NeighbourSet set;
    NeighbourhoodScratch scratch;
    FuzzyParams params;
    params.geodesicProjection = geodesic;
    std::size_t total = 0;
    for (std::size_t i = 0; i < count; ++i) {
        const glm::vec3 x = points.position[i], n = points.normal[i];
        const float r = points.radius[i];
        set.clear();
        for (std::size_t j = 0; j < count; ++j) {
            if (j == i || !(glm::length(points.position[j] - x) < r)) continue;
            if (validNeighbours(x, n, points.position[j], points.normal[j]))
                set.push(static_cast<std::uint32_t>(j), points.position[j], points.normal[j]);
        }
        filterFuzzy(x, n, params, set, scratch);
        hood[i] = set.index;
        std::sort(hood[i].begin(), hood[i].end());
        total += hood[i].size();
    }
    std::set<std::pair<std::uint32_t, std::uint32_t>> all;
    std::size_t both = 0;
    for (std::uint32_t i = 0; i < count; ++i)
        for (std::uint32_t j : hood[i]) {
            if (!all.insert(std::minmax(i, j)).second) continue;
            const std::vector<std::uint32_t>& other = hood[j];
            both += std::binary_search(other.begin(), other.end(), i);
        }
    SymmetryResult result;
    result.pairs = all.size();
    result.rate = static_cast<double>(both) / static_cast<double>(all.size());
    result.meanSize = static_cast<double>(total) / static_cast<double>(count);
    return result;
}

void report(const std::string& name, const SymmetryResult& r) {
    ::testing::Test::RecordProperty(name, std::to_string(r.rate));
    std::cout << "symmetry rate " << name << ": " << r.rate << " (" << r.pairs << " pairs, mean |N| "
              << r.meanSize << ")\n";
}

// Measured (gcc, x86-64): sphere Nf 1.0, Ng 1.0; the thresholds leave a small margin.
TEST(SymmetryRate, UniformSphere2000) {
    PointSet points = sampleSphereUniform(2000, 1.0f);
    estimateRadii(points, 1);
    const SymmetryResult nf = symmetryRate(points, false);
    const SymmetryResult ng = symmetryRate(points, true);
    report("sphere2000_Nf", nf);
    report("sphere2000_Ng", ng);
    EXPECT_GT(nf.meanSize, 5.5);
    EXPECT_LT(nf.meanSize, 6.5);
    EXPECT_GE(nf.rate, 0.99);
    EXPECT_GE(ng.rate, 0.99);
}

// Measured (gcc, x86-64): torus Nf 1.0, Ng 0.9974.
TEST(SymmetryRate, RandomTorus3500) {
    PointSet points = sampleTorusRandom(3500, 1.0f, 0.4f, 7);
    estimateRadii(points, 1);
    const SymmetryResult nf = symmetryRate(points, false);
    const SymmetryResult ng = symmetryRate(points, true);
    report("torus3500_Nf", nf);
    report("torus3500_Ng", ng);
    EXPECT_GE(nf.rate, 0.99);
    EXPECT_GE(ng.rate, 0.985);
}

// ---------------------------------------------------------------------------------------------
// estimateRadii

// A planar hexagonal grid (spacing h) of rows x cols points, tilted out of the xy plane, each point
// moved in its plane by up to jitter·h. ringDepth = rows/columns to the nearest border.
PointSet hexGrid(int rows, int cols, float h, float jitter, std::vector<int>& ringDepth) {
    std::mt19937_64 rng(205);
    PointSet points;
    const glm::vec3 normal = glm::normalize(glm::vec3(0.2f, -0.1f, 1.0f));
    const glm::vec3 u = glm::normalize(glm::cross(normal, glm::vec3(0.0f, 1.0f, 0.0f)));
    const glm::vec3 v = glm::cross(normal, u);
    const glm::vec3 origin(0.5f, 0.25f, -1.0f);
    for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c) {
            const float x =
                (static_cast<float>(c) + 0.5f * static_cast<float>(r % 2) + jitter * uniform(rng, -1, 1)) * h;
            const float y =
                (static_cast<float>(r) * std::sqrt(3.0f) / 2.0f + jitter * uniform(rng, -1, 1)) * h;
            points.position.push_back(origin + x * u + y * v);
            points.normal.push_back(normal);
            ringDepth.push_back(std::min({r, rows - 1 - r, c, cols - 1 - c}));
        }
    return points;
}

// Interior points (3 or more rows from the border) get the distance of their farthest first-ring
// neighbour, just above (one float step), never the second ring at √3 h.
void checkHexRadii(float jitter) {
    const float h = 0.1f;
    std::vector<int> depth;
    PointSet points = hexGrid(24, 24, h, jitter, depth);
    estimateRadii(points, 1);
    ASSERT_EQ(points.radius.size(), points.size());
    int interior = 0, notReached = 0, tooLarge = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        EXPECT_GT(points.radius[i], 0.0f) << i;
        if (depth[i] < 3) continue;
        ++interior;
        float firstRing = 0.0f;
        int ringCount = 0;
        for (std::size_t j = 0; j < points.size(); ++j) {
            const float d = glm::length(points.position[j] - points.position[i]);
            if (j != i && d < 1.2f * h) {
                firstRing = std::max(firstRing, d);
                ++ringCount;
            }
        }
        ASSERT_EQ(ringCount, 6) << i;
        // First ring reached (open ball), just above it (one float step), second ring (√3 h) not.
        notReached += !(points.radius[i] > firstRing);
        if (!(points.radius[i] <= firstRing * (1.0f + 1e-6f)) && tooLarge++ == 0)
            ADD_FAILURE() << "point " << i << ": radius " << points.radius[i] << ", first ring " << firstRing;
    }
    EXPECT_EQ(notReached, 0);
    EXPECT_EQ(tooLarge, 0) << "of " << interior << " interior points";
    EXPECT_GT(interior, 300);
}

TEST(EstimateRadii, JitteredHexagonalGridInteriorRadiusJustAboveFirstRing) {
    checkHexRadii(0.02f);
}

// Regression for the same cause: on an exact hexagonal grid the points at 2h straight behind a
// first-ring neighbour survived the Nf filter and interior radii came out as 2h instead of just
// above h.
TEST(EstimateRadii, HexagonalGridInteriorRadiusJustAboveSpacing) {
    checkHexRadii(0.0f);
}

TEST(EstimateRadii, IndependentOfThreadCount) {
    PointSet a = sampleTorusRandom(3000, 1.0f, 0.4f, 11);
    PointSet b = a;
    estimateRadii(a, 1);
    estimateRadii(b, 2);
    EXPECT_EQ(a.radius, b.radius);
    PointSet c = sampleSphereUniform(2000, 1.0f);
    PointSet d = c;
    estimateRadii(c, 1);
    estimateRadii(d, 2);
    EXPECT_EQ(c.radius, d.radius);
}

// Recomputes the documented estimate by brute force: candidates within twice the distance of the
// 6th nearest neighbour (at most kMaxCandidates), eq. 6, Nf; r_i reaches its own survivors and
// every point that keeps p_i.
TEST(EstimateRadii, MatchesBruteForceAndIsSymmetric) {
    PointSet points = sampleTorusRandom(1500, 1.0f, 0.4f, 12);
    estimateRadii(points, 2);
    const std::size_t count = points.size();
    std::vector<std::vector<std::uint32_t>> survivors(count);
    NeighbourSet set;
    NeighbourhoodScratch scratch;
    FuzzyParams params;
    params.geodesicProjection = false;
    std::vector<std::pair<float, std::uint32_t>> byDistance;
    for (std::size_t i = 0; i < count; ++i) {
        byDistance.clear();
        for (std::size_t j = 0; j < count; ++j) {
            if (j == i) continue;
            const glm::vec3 d = points.position[j] - points.position[i];
            byDistance.emplace_back(glm::dot(d, d), static_cast<std::uint32_t>(j));
        }
        std::sort(byDistance.begin(), byDistance.end());
        const float limit2 = 4.0f * byDistance[kRadiusNearest - 1].first;
        set.clear();
        for (std::size_t k = 0; k < kMaxCandidates && byDistance[k].first <= limit2; ++k) {
            const std::uint32_t j = byDistance[k].second;
            if (validNeighbours(points.position[i], points.normal[i], points.position[j], points.normal[j]))
                set.push(j, points.position[j], points.normal[j]);
        }
        filterFuzzy(points.position[i], points.normal[i], params, set, scratch);
        survivors[i] = set.index;
    }
    std::vector<float> expected(count, 0.0f);
    for (std::size_t i = 0; i < count; ++i)
        for (std::uint32_t j : survivors[i]) {
            const float d = glm::length(points.position[i] - points.position[j]);
            expected[i] = std::max(expected[i], d);
            expected[j] = std::max(expected[j], d);
        }
    std::size_t mismatches = 0;
    for (std::size_t i = 0; i < count; ++i) {
        for (std::uint32_t j : survivors[i]) {
            const float d = glm::length(points.position[i] - points.position[j]);
            EXPECT_GT(points.radius[i], d) << i << " " << j;
            EXPECT_GT(points.radius[j], d) << i << " " << j; // symmetric: p_j reaches p_i
        }
        mismatches += std::abs(points.radius[i] - expected[i]) > 1e-6f * expected[i];
    }
    EXPECT_EQ(mismatches, 0u);
}

TEST(EstimateRadii, TinyInputs) {
    PointSet empty;
    estimateRadii(empty, 1);
    EXPECT_TRUE(empty.radius.empty());
    PointSet one;
    one.position = {glm::vec3(1.0f)};
    one.normal = {glm::vec3(0.0f, 0.0f, 1.0f)};
    estimateRadii(one, 1);
    ASSERT_EQ(one.radius.size(), 1u);
    EXPECT_EQ(one.radius[0], 0.0f);
}

} // namespace
} // namespace pnsplat
