// Tests of the procedural models and analytic surfaces (shapes.h) against exact oracles: points on
// the implicit surface, normals equal to the analytic (or finite-difference) normal, area-uniform
// densities matching analytic area ratios, closest points matching brute force.
#include <algorithm>
#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "pnsplat/refine/angles.h"
#include "pnsplat/refine/shapes/shapes.h"

namespace pnsplat {
namespace {

// The outward normal of a star-shaped surface (its point in each direction) in direction d, by
// central differences of step h along two tangent axes (e1 x e2 = d).
template <class Surface>
glm::vec3 finiteDifferenceNormal(Surface surface, glm::vec3 d, float h) {
    const glm::vec3 helper = std::abs(d.z) < 0.9f ? glm::vec3(0, 0, 1) : glm::vec3(1, 0, 0);
    const glm::vec3 e1 = glm::normalize(glm::cross(helper, d));
    const glm::vec3 e2 = glm::cross(d, e1);
    const glm::vec3 tu = surface(d + h * e1) - surface(d - h * e1);
    const glm::vec3 tv = surface(d + h * e2) - surface(d - h * e2);
    return glm::normalize(glm::cross(tu, tv));
}

constexpr double kPi = std::numbers::pi;

bool allFinite(const PointSet& set) {
    for (std::size_t i = 0; i < set.size(); ++i)
        for (int k = 0; k < 3; ++k)
            if (!std::isfinite(set.position[i][k]) || !std::isfinite(set.normal[i][k])) return false;
    return true;
}

// Brute-force nearest-neighbour distances (small sets only).
std::vector<double> nearestDistances(const PointSet& set) {
    std::vector<double> d(set.size(), 1e300);
    for (std::size_t i = 0; i < set.size(); ++i)
        for (std::size_t j = 0; j < set.size(); ++j)
            if (i != j)
                d[i] = std::min(d[i], static_cast<double>(glm::length(set.position[i] - set.position[j])));
    return d;
}

// Share of torus points on the outer half (distance from the axis > R).
double outerShare(const PointSet& set, float R) {
    std::size_t outer = 0;
    for (const glm::vec3& p : set.position) outer += std::hypot(p.x, p.y) > R;
    return static_cast<double>(outer) / static_cast<double>(set.size());
}

TEST(SphereUniform, PointsOnSphereWithRadialNormals) {
    const float radius = 2.5f;
    const PointSet set = sampleSphereUniform(1000, radius);
    ASSERT_EQ(set.size(), 1000u);
    EXPECT_FALSE(set.hasRadius());
    EXPECT_FALSE(set.hasColour());
    for (std::size_t i = 0; i < set.size(); ++i) {
        EXPECT_NEAR(glm::length(set.position[i]), radius, 1e-5f * radius);
        EXPECT_NEAR(glm::length(set.normal[i]), 1.0f, 1e-6f);
        EXPECT_LT(angleInDegrees(set.normal[i], set.position[i]), 1e-4);
    }
}

TEST(SphereUniform, NearUniformSpacing) {
    const PointSet set = sampleSphereUniform(2000, 1.0f);
    const std::vector<double> d = nearestDistances(set);
    const double spacing = std::sqrt(4.0 * kPi / 2000.0);
    // A Fibonacci spiral has no close pairs and no large gaps.
    EXPECT_GT(*std::min_element(d.begin(), d.end()), 0.6 * spacing);
    EXPECT_LT(*std::max_element(d.begin(), d.end()), 1.3 * spacing);
}

TEST(SphereRandom, OnSphereDeterministicAndUniform) {
    const PointSet a = sampleSphereRandom(40000, 1.5f, 42);
    const PointSet b = sampleSphereRandom(40000, 1.5f, 42);
    const PointSet c = sampleSphereRandom(40000, 1.5f, 43);
    ASSERT_EQ(a.size(), 40000u);
    EXPECT_EQ(a.position, b.position);
    EXPECT_EQ(a.normal, b.normal);
    EXPECT_NE(a.position, c.position);
    std::size_t band = 0, upper = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        EXPECT_NEAR(glm::length(a.position[i]), 1.5f, 1e-5f);
        EXPECT_LT(angleInDegrees(a.normal[i], a.position[i]), 1e-4);
        band += std::abs(a.position[i].z) < 0.75f; // |z| < R/2: half the area (Archimedes)
        upper += a.position[i].x > 0.0f;
    }
    EXPECT_NEAR(static_cast<double>(band) / 40000.0, 0.5, 0.015);
    EXPECT_NEAR(static_cast<double>(upper) / 40000.0, 0.5, 0.015);
}

TEST(TorusRandom, OnTorusWithExactNormalsAndAreaUniform) {
    const float R = 1.0f, r = 0.4f;
    const PointSet set = sampleTorusRandom(50000, R, r, 7);
    ASSERT_EQ(set.size(), 50000u);
    const AnalyticSurface torus = AnalyticSurface::torus(R, r);
    for (std::size_t i = 0; i < set.size(); ++i) {
        const glm::vec3 p = set.position[i];
        // Implicit function with unit gradient: |(|p.xy| - R, p.z)| - r.
        const double implicit = std::hypot(std::hypot(p.x, p.y) - R, p.z) - r;
        ASSERT_LT(std::abs(implicit), 1e-5);
        ASSERT_LT(angleInDegrees(set.normal[i], torus.normalAt(p)), 1e-3);
    }
    // Area of the outer half (cos v > 0) over the total: (pi R + 2 r) / (2 pi R). Sampling v
    // uniformly (not by area) would give 0.5.
    const double expected = 0.5 + static_cast<double>(r) / (kPi * static_cast<double>(R));
    EXPECT_NEAR(outerShare(set, R), expected, 0.01);
    EXPECT_TRUE(allFinite(set));
}

TEST(TorusUniform, ExactCountOnTorusAndAreaUniform) {
    const float R = 2.0f, r = 0.5f;
    for (const std::size_t n : {std::size_t{1}, std::size_t{7}, std::size_t{1000}, std::size_t{30001}}) {
        const PointSet set = sampleTorusUniform(n, R, r);
        ASSERT_EQ(set.size(), n);
        for (const glm::vec3& p : set.position)
            ASSERT_LT(std::abs(std::hypot(std::hypot(p.x, p.y) - R, p.z) - r), 1e-5);
    }
    const PointSet set = sampleTorusUniform(30001, R, r);
    // Rings are area-correct bands; the outer-half boundary v = pi/2 falls inside a band, which
    // shifts the share by up to half a band (1/174 here).
    EXPECT_NEAR(outerShare(set, R), 0.5 + 0.5 / (kPi * 2.0), 0.01);
    // Near-uniform: nearest-neighbour distances close to the cell size sqrt(area / n).
    const PointSet small = sampleTorusUniform(3000, R, r);
    const std::vector<double> d = nearestDistances(small);
    const double cell = std::sqrt(4.0 * kPi * kPi * 2.0 * 0.5 / 3000.0);
    EXPECT_GT(*std::min_element(d.begin(), d.end()), 0.4 * cell);
    EXPECT_LT(*std::max_element(d.begin(), d.end()), 1.5 * cell);
}

TEST(BumpySphere, ColouredSparseFiniteUnitNormals) {
    const PointSet model = makeBumpySphere();
    EXPECT_GE(model.size(), 1500u);
    EXPECT_LE(model.size(), 2500u);
    ASSERT_TRUE(model.hasColour());
    ASSERT_EQ(model.colour.size(), model.size());
    EXPECT_FALSE(model.hasRadius());
    EXPECT_TRUE(allFinite(model));
    float minRadius = 10.0f, maxRadius = 0.0f;
    double maxTilt = 0.0;
    int minChannel = 255, maxChannel = 0;
    for (std::size_t i = 0; i < model.size(); ++i) {
        EXPECT_NEAR(glm::length(model.normal[i]), 1.0f, 1e-6f);
        const float len = glm::length(model.position[i]);
        minRadius = std::min(minRadius, len);
        maxRadius = std::max(maxRadius, len);
        maxTilt = std::max(maxTilt, angleInDegrees(model.normal[i], model.position[i]));
        EXPECT_GT(glm::dot(model.normal[i], model.position[i]), 0.0f); // outward (star-shaped)
        minChannel = std::min<int>(minChannel, model.colour[i].x);
        maxChannel = std::max<int>(maxChannel, model.colour[i].x);
    }
    // Real curvature variation: bumps of +-25 % and normals tilted well away from radial.
    EXPECT_GE(minRadius, 0.75f - 1e-5f);
    EXPECT_LE(maxRadius, 1.25f + 1e-5f);
    EXPECT_GT(maxRadius - minRadius, 0.2f);
    EXPECT_GT(maxTilt, 15.0);
    EXPECT_GT(maxChannel - minChannel, 100); // colour follows the bumps, not constant
    // Deterministic.
    const PointSet again = makeBumpySphere();
    EXPECT_EQ(model.position, again.position);
    EXPECT_EQ(model.colour, again.colour);
}

TEST(BumpySphere, NormalsMatchFiniteDifferencesOfTheSurface) {
    const PointSet model = makeBumpySphere();
    const float h = 1e-3f;
    double worst = 0.0;
    for (std::size_t i = 0; i < model.size(); ++i) {
        const glm::vec3 d = glm::normalize(model.position[i]);
        // The point lies on the surface in its own direction.
        ASSERT_LT(glm::length(bumpySphereSurface(d) - model.position[i]), 1e-5f);
        const glm::vec3 fd = finiteDifferenceNormal(bumpySphereSurface, d, h);
        worst = std::max(worst, angleInDegrees(fd, model.normal[i]));
    }
    EXPECT_LT(worst, 0.1);
}

TEST(BumpySphere, IrregularButNotPathological) {
    const PointSet model = makeBumpySphere();
    const std::vector<double> d = nearestDistances(model);
    double mean = 0.0;
    for (const double x : d) mean += x;
    mean /= static_cast<double>(d.size());
    double var = 0.0;
    for (const double x : d) var += (x - mean) * (x - mean);
    const double cv = std::sqrt(var / static_cast<double>(d.size())) / mean;
    EXPECT_GT(cv, 0.1); // irregular (a Fibonacci spiral alone is about 0.03)
    EXPECT_LT(cv, 0.5);
    EXPECT_GT(*std::min_element(d.begin(), d.end()), 0.3 * mean); // no near-duplicates
}

// The default model (issue 26): sparse, coloured with three colours, the horns and ridges there,
// its normals those of its surface, and its dense version on the same surface.
TEST(DefaultModel, SparseColouredWithRidgesAndHorns) {
    const PointSet model = makeDefaultModel();
    EXPECT_EQ(model.size(), kDefaultModelPoints);
    EXPECT_LE(model.size(), 3000u); // sparse, as the paper's inputs
    ASSERT_TRUE(model.hasColour());
    EXPECT_FALSE(model.hasRadius());
    EXPECT_TRUE(allFinite(model));
    float maxRadius = 0.0f;
    double maxTilt = 0.0;
    std::size_t red = 0, blue = 0, light = 0;
    for (std::size_t i = 0; i < model.size(); ++i) {
        EXPECT_NEAR(glm::length(model.normal[i]), 1.0f, 1e-6f);
        EXPECT_GT(glm::dot(model.normal[i], model.position[i]), 0.0f); // outward (star-shaped)
        maxRadius = std::max(maxRadius, glm::length(model.position[i]));
        maxTilt = std::max(maxTilt, angleInDegrees(model.normal[i], model.position[i]));
        const glm::ivec3 c(model.colour[i]);
        red += c.x > 180 && c.y < 80;    // a horn
        blue += c.z > 150 && c.x < 80;   // the body
        light += c.x > 220 && c.y > 180; // a ridge's crest
    }
    EXPECT_GT(maxRadius, 1.6f); // the horns reach out
    EXPECT_GT(maxTilt, 60.0);   // their sides are steep
    EXPECT_GT(red, 20u);
    EXPECT_GT(blue, 200u);
    EXPECT_GT(light, 20u);
    const PointSet again = makeDefaultModel();
    EXPECT_EQ(model.position, again.position);
    EXPECT_EQ(model.colour, again.colour);
}

TEST(DefaultModel, NormalsMatchFiniteDifferencesAndTheDenseVersionLiesOnTheSameSurface) {
    const PointSet sparse = makeDefaultModel();
    const PointSet dense = sampleDefaultModel(20000);
    EXPECT_EQ(dense.size(), 20000u);
    ASSERT_TRUE(dense.hasColour());
    for (const PointSet* model : {&sparse, &dense}) {
        const float h = 1e-3f;
        double worst = 0.0;
        float farthest = 0.0f;
        for (std::size_t i = 0; i < model->size(); ++i) {
            const glm::vec3 d = glm::normalize(model->position[i]);
            farthest = std::max(farthest, glm::length(defaultModelSurface(d) - model->position[i]));
            const glm::vec3 fd = finiteDifferenceNormal(defaultModelSurface, d, h);
            worst = std::max(worst, angleInDegrees(fd, model->normal[i]));
        }
        EXPECT_LT(farthest, 1e-5f) << model->size() << " points";
        // The horns' sides turn fast: finite differences of float positions are good to about 0.5°.
        EXPECT_LT(worst, 0.5) << model->size() << " points";
    }
}

TEST(AnalyticSurface, SphereClosestPointDistanceNormal) {
    AnalyticSurface s = AnalyticSurface::sphere(2.0f);
    s.centre = glm::vec3(1.0f, -2.0f, 0.5f);
    const glm::vec3 p = s.centre + glm::vec3(3.0f, 0.0f, 4.0f); // at distance 5
    EXPECT_NEAR(s.distance(p), 3.0f, 1e-6f);
    EXPECT_NEAR(s.signedDistance(p), 3.0f, 1e-6f);
    EXPECT_NEAR(s.signedDistance(s.centre + glm::vec3(0.0f, 0.5f, 0.0f)), -1.5f, 1e-6f);
    EXPECT_LT(glm::length(s.closestPoint(p) - (s.centre + glm::vec3(1.2f, 0.0f, 1.6f))), 1e-6f);
    EXPECT_LT(glm::length(s.normalAt(p) - glm::vec3(0.6f, 0.0f, 0.8f)), 1e-6f);
    // Degenerate: the centre gets the +z pole, not NaN.
    EXPECT_EQ(s.normalAt(s.centre), glm::vec3(0.0f, 0.0f, 1.0f));
    EXPECT_NEAR(s.boundingDiagonal(), 4.0f * std::sqrt(3.0f), 1e-5f);
}

TEST(AnalyticSurface, TorusClosestPointMatchesBruteForce) {
    const double R = 1.0, r = 0.3;
    const AnalyticSurface torus = AnalyticSurface::torus(1.0f, 0.3f);
    // Dense parametric grid of the torus (1200 x 400) as the brute-force oracle.
    const int nu = 1200, nv = 400;
    std::vector<glm::vec3> grid;
    grid.reserve(nu * nv);
    for (int i = 0; i < nu; ++i)
        for (int j = 0; j < nv; ++j) {
            const double u = 2.0 * kPi * i / nu, v = 2.0 * kPi * j / nv;
            grid.emplace_back((R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u),
                              r * std::sin(v));
        }
    const double gridStep = 2.0 * kPi * (R + r) / nu; // largest spacing between grid points
    const PointSet queries = sampleSphereRandom(60, 1.6f, 11);
    for (std::size_t q = 0; q < queries.size(); ++q) {
        const glm::vec3 p =
            queries.position[q] * (0.2f + 0.02f * static_cast<float>(q)); // inside and outside
        double brute = 1e300;
        for (const glm::vec3& g : grid) brute = std::min(brute, static_cast<double>(glm::length(g - p)));
        const double exact = torus.distance(p);
        EXPECT_LE(exact, brute + 1e-5);
        EXPECT_GE(exact, brute - gridStep);
        const glm::vec3 c = torus.closestPoint(p);
        EXPECT_LT(torus.distance(c), 1e-5f);
        EXPECT_NEAR(glm::length(p - c), exact, 1e-5);
        // The normal at the closest point is along p - c (when p is off the surface).
        if (exact > 1e-3) {
            const float side = torus.signedDistance(p) > 0.0f ? 1.0f : -1.0f;
            EXPECT_LT(angleInDegrees(torus.normalAt(p), side * (p - c)), 1e-2);
        }
    }
    // Degenerate queries stay finite: on the axis and on the tube circle.
    for (const glm::vec3 p : {glm::vec3(0.0f), glm::vec3(0.0f, 0.0f, 2.0f), glm::vec3(0.0f, 1.0f, 0.0f)}) {
        const glm::vec3 c = torus.closestPoint(p), n = torus.normalAt(p);
        EXPECT_TRUE(std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z));
        EXPECT_NEAR(glm::length(n), 1.0f, 1e-6f);
        EXPECT_LT(torus.distance(c), 1e-5f);
    }
    EXPECT_NEAR(torus.distance(glm::vec3(0.0f)), 0.7f, 1e-6f);
}

} // namespace
} // namespace pnsplat
