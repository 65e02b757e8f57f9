// Inputs that come with normals, some of them flipped (ALGORITHM.md §9, beyond the paper): findFlippedNormals
// against the points flipped on purpose (isolated and in a cluster), thin walls and the clean
// inputs of ../shared/data left alone, completeInput turning them back or refusing them, the radius
// of a point with no valid neighbour, and acceptance 2 of issue 20: real models with 0.2 % and 2 %
// of their normals flipped refine as close to the true surface as the clean ones.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <iostream>
#include <limits>
#include <numeric>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "oracles.h"
#include "pnsplat/refine/evaluation/quality.h"
#include "pnsplat/refine/input.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/normal_estimation.h"
#include "pnsplat/refine/outliers.h"
#include "pnsplat/refine/radius_estimation.h"
#include "pnsplat/refine/refiner.h"
#include "pnsplat/refine/shapes/shapes.h"
#include "test_data.h"
#include "test_random.h"

namespace pnsplat {
namespace {

constexpr unsigned kThreads = 2;

// Negates the normals of `count` distinct points drawn with a fixed seed; their indices, sorted.
std::vector<std::uint32_t> flipAtRandom(PointSet& points, std::size_t count, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::set<std::uint32_t> chosen;
    while (chosen.size() < count)
        chosen.insert(static_cast<std::uint32_t>(test::uniform01(rng) * static_cast<double>(points.size())));
    for (const std::uint32_t i : chosen) points.normal[i] = -points.normal[i];
    return {chosen.begin(), chosen.end()};
}

// The indices of the k points nearest to point i (i itself left out), by brute force.
std::vector<std::uint32_t> nearestOf(const PointSet& points, std::uint32_t i, std::size_t k) {
    std::vector<std::uint32_t> order;
    for (std::uint32_t j = 0; j < points.size(); ++j)
        if (j != i) order.push_back(j);
    std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(k), order.end(),
                      [&](std::uint32_t a, std::uint32_t b) {
                          return glm::distance(points.position[a], points.position[i]) <
                                 glm::distance(points.position[b], points.position[i]);
                      });
    order.resize(k);
    return order;
}

// A random sphere with 40 isolated normals flipped and a cluster of three (a point and its two
// nearest): every one is found, none other, for any thread count. (Four together fit each other
// past kFlippedFits: a patch, taken as it is.)
TEST(FlippedNormals, FoundOnASphereIsolatedAndInACluster) {
    PointSet points = sampleSphereRandom(3000, 1.0f, 5);
    const PointSet truth = points;
    std::vector<std::uint32_t> flipped = flipAtRandom(points, 40, 11);
    std::uint32_t centre = 0;
    while (std::binary_search(flipped.begin(), flipped.end(), centre)) ++centre;
    std::vector<std::uint32_t> cluster = nearestOf(truth, centre, 2);
    cluster.push_back(centre);
    for (const std::uint32_t i : cluster)
        if (!std::binary_search(flipped.begin(), flipped.end(), i)) {
            points.normal[i] = -points.normal[i];
            flipped.insert(std::upper_bound(flipped.begin(), flipped.end(), i), i);
        }
    EXPECT_EQ(findFlippedNormals(points, 1), flipped);
    EXPECT_EQ(findFlippedNormals(points, kThreads), flipped);
    EXPECT_TRUE(findFlippedNormals(truth, kThreads).empty());
}

// A thin wall: two parallel sheets a fifth of their spacing apart, facing away from each other.
// A point's nearest lie on both sides, and the other side's are valid neighbours only of its
// normal turned around; still nothing is flipped. (A flipped point there looks like a point of the
// other side, and is not found either.)
TEST(FlippedNormals, ThinWallIsLeftAlone) {
    std::mt19937_64 rng(3);
    PointSet wall;
    for (int k = 0; k < 2000; ++k) {
        const bool top = k % 2 == 0;
        wall.position.emplace_back(test::uniform(rng, 0, 1), test::uniform(rng, 0, 1), top ? 0.005f : 0.0f);
        wall.normal.emplace_back(0.0f, 0.0f, top ? 1.0f : -1.0f);
    }
    EXPECT_TRUE(findFlippedNormals(wall, kThreads).empty());
}

// The clean sparse inputs of ../shared/data: nothing is flipped (the nefertiti's ears, thinner
// than their sampling, are the hard case: see kFlippedFits).
TEST(FlippedNormals, CleanDataModelsHaveNone) {
    for (const char* file :
         {"bunny-3500-random.ply", "nefertiti-3500-random.ply", "lion-3500-random.ply",
          "banana-1500-random.ply", "igea-600-uniform.ply", "igea-4000-uniform-hole.ply",
          "rockerarm-2000-uniform.ply", "fandisk-1500-uniform.ply", "fandisk-1500-uniform-crease.ply"}) {
        PNSPLAT_REQUIRE_DATA(file);
        const Result<PlyData> data = readPly(test::dataDir() / file);
        ASSERT_TRUE(data.ok()) << data.error().message;
        EXPECT_EQ(findFlippedNormals(data->points, kThreads).size(), 0u) << file;
    }
}

// completeInput turns flipped normals back (a crease point's two normals together), says how many
// and the first; asked to keep the normals, it refuses, naming the first and where it is.
TEST(FlippedNormals, CompleteInputTurnsThemOrRefuses) {
    PointSet points = sampleSphereRandom(1000, 1.0f, 9);
    points.crease.assign(points.size(), glm::vec3(0.0f));
    const std::vector<std::uint32_t> flipped = flipAtRandom(points, 5, 2);
    const glm::vec3 second =
        glm::normalize(glm::cross(points.normal[flipped[1]], glm::vec3(0, 0, 1)) + points.normal[flipped[1]]);
    points.crease[flipped[1]] = second;

    PointSet kept = points;
    const Result<InputCompletion> refused = completeInput(kept, kThreads, {.keepNormals = true});
    ASSERT_FALSE(refused.ok());
    const glm::vec3 x = points.position[flipped[0]];
    std::cout << refused.error().message << "\n";
    EXPECT_NE(refused.error().message.find("5 normal(s) point against their neighbours' (the first: point " +
                                           std::to_string(flipped[0]) + ", at "),
              std::string::npos)
        << refused.error().message;
    EXPECT_NE(refused.error().message.find(std::to_string(x.x).substr(0, 5)), std::string::npos)
        << refused.error().message;

    const Result<InputCompletion> done = completeInput(points, kThreads);
    ASSERT_TRUE(done.ok()) << done.error().message;
    EXPECT_EQ(done->turnedNormals, 5u);
    EXPECT_EQ(done->firstTurned, flipped[0]);
    for (std::size_t i = 0; i < points.size(); ++i)
        ASSERT_GT(glm::dot(points.normal[i], points.position[i]), 0.0f) << "point " << i;
    EXPECT_EQ(points.crease[flipped[1]], -second);
    EXPECT_TRUE(validateForRefinement(points).ok());
}

// A set completed before (pnsplat's own output: InputOptions::asWritten) keeps its flipped normals
// and its stray points as given, where the same set otherwise loses the stray points and has its
// normals turned. Repeated positions are still merged.
TEST(FlippedNormals, ASetCompletedBeforeIsTakenAsWritten) {
    PointSet points = sampleSphereRandom(1000, 1.0f, 9);
    points.radius.assign(points.size(), 0.1f);
    const std::vector<std::uint32_t> flipped = flipAtRandom(points, 5, 2);
    points.appendFrom(points, 0); // a repeat
    points.position.back() = points.position[0];
    for (const glm::vec3 far : {glm::vec3(3.0f, 0.0f, 0.0f), glm::vec3(0.0f, -3.0f, 1.0f)}) {
        points.appendFrom(points, 1);
        points.position.back() = far;
    }
    PointSet written = points;
    const Result<InputCompletion> taken = completeInput(written, kThreads, {.asWritten = true});
    ASSERT_TRUE(taken.ok()) << taken.error().message;
    EXPECT_EQ(taken->repeats.points, 1u);
    EXPECT_EQ(taken->outliers, 0u);
    EXPECT_EQ(taken->turnedNormals, 0u);
    ASSERT_EQ(written.size(), 1002u);
    for (const std::uint32_t i : flipped) EXPECT_EQ(written.normal[i], points.normal[i]);

    const Result<InputCompletion> done = completeInput(points, kThreads);
    ASSERT_TRUE(done.ok()) << done.error().message;
    EXPECT_EQ(done->outliers, 2u);
    EXPECT_EQ(done->turnedNormals, 5u);
    EXPECT_EQ(points.size(), 1000u);
}

// completeInput says each step as it starts, in order, and the end: with radii to estimate and
// without (the last step then starts and ends at once).
TEST(FlippedNormals, CompletionReportsItsSteps) {
    for (const bool withRadii : {false, true}) {
        PointSet points = sampleSphereRandom(500, 1.0f, 3);
        if (withRadii) points.radius.assign(points.size(), 0.1f);
        std::vector<std::size_t> steps;
        const Result<InputCompletion> done =
            completeInput(points, kThreads, {}, [&](std::size_t k, std::size_t n) {
                EXPECT_EQ(n, kCompletionSteps);
                steps.push_back(k);
            });
        ASSERT_TRUE(done.ok()) << done.error().message;
        EXPECT_EQ(steps, (std::vector<std::size_t>{0, 1, 2, 3, 4})) << withRadii;
    }
}

// completeInput estimates on a copy of the points along a Morton curve and puts the results back in
// the input's order (input.cpp, SpatialCopy). Random points of a sphere with 12 strays in its box,
// positions only and with normals, 5 of them flipped:
//  - they complete to the normals and radii, bit for bit, of the steps run on the points in their
//    own order (as before the copy; the order breaks only ties, which these points do not have);
//  - a shuffled input completes to the same points, normals and radii, and reports the same
//    outliers and turned normals, the first of each by its own order (the copy's bookkeeping).
TEST(CompletedInput, TheSameForAnyOrderOfThePoints) {
    PointSet sphere = sampleSphereRandom(2000, 1.0f, 17);
    std::mt19937_64 rng(5);
    for (int k = 0; k < 12; ++k) {
        sphere.appendFrom(sphere, 0);
        sphere.position.back() = glm::vec3(test::uniform(rng, -1.5, 1.5), test::uniform(rng, -1.5, 1.5),
                                           test::uniform(rng, -1.5, 1.5));
    }
    const std::vector<std::uint32_t> flipped = flipAtRandom(sphere, 5, 3);
    for (const bool withNormals : {false, true}) {
        PointSet given = sphere, shuffled;
        std::vector<std::uint32_t> shuffle(given.size());
        std::iota(shuffle.begin(), shuffle.end(), 0u);
        std::shuffle(shuffle.begin(), shuffle.end(), rng);
        for (const std::uint32_t i : shuffle) shuffled.appendFrom(given, i);
        if (!withNormals) {
            given.normal.clear();
            shuffled.normal.clear();
        }
        PointSet inOrder = given; // the steps in the points' own order
        removePoints(inOrder, findOutliers(inOrder.position, kThreads).outliers);
        if (withNormals) {
            for (const std::uint32_t i : findFlippedNormals(inOrder, kThreads))
                inOrder.normal[i] = -inOrder.normal[i];
        } else {
            ASSERT_TRUE(estimateNormals(inOrder, kThreads).ok());
        }
        estimateRadii(inOrder, kThreads);
        const Result<InputCompletion> a = completeInput(given, kThreads);
        const Result<InputCompletion> b = completeInput(shuffled, kThreads);
        ASSERT_TRUE(a.ok() && b.ok());
        EXPECT_EQ(a->outliers, 12u) << withNormals;
        EXPECT_EQ(b->outliers, a->outliers);
        EXPECT_EQ(a->turnedNormals, withNormals ? flipped.size() : 0u);
        EXPECT_EQ(b->turnedNormals, a->turnedNormals);
        ASSERT_EQ(shuffled.size(), given.size());
        ASSERT_EQ(inOrder.size(), given.size());
        EXPECT_TRUE(std::equal(given.normal.begin(), given.normal.end(), inOrder.normal.begin()))
            << withNormals;
        EXPECT_TRUE(std::equal(given.radius.begin(), given.radius.end(), inOrder.radius.begin()))
            << withNormals;
        // Each point of the shuffled set at its place in the given one.
        std::vector<std::uint32_t> byPosition(given.size());
        std::iota(byPosition.begin(), byPosition.end(), 0u);
        const auto before = [&](glm::vec3 p, glm::vec3 q) {
            return std::tie(p.x, p.y, p.z) < std::tie(q.x, q.y, q.z);
        };
        std::sort(byPosition.begin(), byPosition.end(), [&](std::uint32_t i, std::uint32_t j) {
            return before(given.position[i], given.position[j]);
        });
        std::size_t firstTurned = shuffled.size();
        for (std::uint32_t k = 0; k < shuffled.size(); ++k) {
            const auto at =
                std::lower_bound(byPosition.begin(), byPosition.end(), shuffled.position[k],
                                 [&](std::uint32_t i, glm::vec3 p) { return before(given.position[i], p); });
            ASSERT_TRUE(at != byPosition.end() && given.position[*at] == shuffled.position[k]) << k;
            EXPECT_EQ(shuffled.normal[k], given.normal[*at]) << k;
            EXPECT_EQ(shuffled.radius[k], given.radius[*at]) << k;
            const bool turned = std::ranges::any_of(
                flipped, [&](std::uint32_t f) { return sphere.position[f] == shuffled.position[k]; });
            if (withNormals && turned) firstTurned = std::min<std::size_t>(firstTurned, k);
        }
        if (withNormals) {
            EXPECT_EQ(b->firstTurned, firstTurned);
        }
        // The first stray left out in the shuffled order.
        glm::vec3 firstOutlier(0.0f);
        for (const std::uint32_t i : shuffle)
            if (i >= 2000) {
                firstOutlier = sphere.position[i];
                break;
            }
        EXPECT_EQ(b->firstOutlier, firstOutlier) << withNormals;
    }
}

// A point whose normal fits none of its neighbours' reaches its kRadiusNearest nearest points (on
// a unit grid, the 6th nearest of an inner point is √2 away), not the smallest float (1e-45, which
// the refinement refused). Such a set refines: the point is kept, and the rest around it.
TEST(RadiusEstimation, PointWithNoValidNeighbourReachesItsNearest) {
    PointSet grid;
    for (int y = 0; y < 15; ++y)
        for (int x = 0; x < 15; ++x) {
            grid.position.emplace_back(static_cast<float>(x), static_cast<float>(y), 0.0f);
            grid.normal.emplace_back(0.0f, 0.0f, 1.0f);
        }
    const std::size_t centre = 7 * 15 + 7;
    grid.normal[centre] = glm::vec3(0.0f, 0.0f, -1.0f);
    estimateRadii(grid, kThreads);
    EXPECT_EQ(grid.radius[centre], std::nextafter(std::sqrt(2.0f), 2.0f));
    ASSERT_TRUE(validateForRefinement(grid).ok());
    RefineOptions options;
    options.threads = kThreads;
    Refiner refiner(grid, options);
    for (int level = 0; level < 2; ++level) refiner.refineLevel();
    EXPECT_EQ(test::inputMismatches(refiner, grid), 0u);
    EXPECT_EQ(test::pointSetDefect(refiner.points(), test::kRefined), "");
    EXPECT_GT(refiner.points().size(), 4 * grid.size());
}

// Distances of points to a mesh, and the mesh's (interpolated vertex) normal at the closest point.
struct MeshOracle {
    Reference reference;
    TriangleMeshIndex index;

    explicit MeshOracle(Reference r)
        : reference(std::move(r)), index(reference.points.position, reference.triangles) {}

    glm::vec3 normalAt(glm::vec3 x) const {
        const TriangleMeshIndex::Hit hit = index.closest(x);
        const glm::u32vec3 t = reference.triangles[hit.triangle];
        const HugePageVector<glm::vec3>& n = reference.points.normal;
        return hit.barycentric.x * n[t.x] + hit.barycentric.y * n[t.y] + hit.barycentric.z * n[t.z];
    }

    struct Distances {
        double mean = 0.0, p99 = 0.0;
    };
    Distances distances(const PointSet& points) const {
        std::vector<double> d;
        for (const glm::vec3& x : points.position)
            d.push_back(std::sqrt(double{index.closest(x).distanceSquared}));
        Distances result;
        for (const double v : d) result.mean += v;
        result.mean /= static_cast<double>(d.size());
        std::sort(d.begin(), d.end());
        result.p99 = d[static_cast<std::size_t>(0.99 * static_cast<double>(d.size() - 1))];
        return result;
    }
};

// An input completed (flipped normals turned back) and refined `levels` levels.
struct Refined {
    InputCompletion done;
    PointSet completed, refined;
};
Refined completeAndRefine(PointSet points, unsigned levels) {
    Refined r;
    const Result<InputCompletion> done = completeInput(points, kThreads);
    EXPECT_TRUE(done.ok()) << done.error().message;
    if (!done.ok()) return r;
    r.done = *done;
    r.completed = points;
    EXPECT_TRUE(validateForRefinement(points).ok());
    RefineOptions options;
    options.threads = kThreads;
    Refiner refiner(std::move(points), options);
    for (unsigned l = 0; l < levels; ++l) refiner.refineLevel();
    r.refined = std::move(refiner).takePoints();
    return r;
}

// Acceptance 2 of issue 20: the bunny with 7 flipped normals (a fixed-seed choice of our own; the
// issue's numpy draw cannot be repeated here), and the lion and the nefertiti with 0.2 % and 2 %
// of their normals flipped, refine; every normal turned back lies within 90 degrees of the mesh's;
// the refined points lie as close to the mesh as those of the clean input (mean and 99th-percentile
// distance within 10 %). Two levels (about 28,000 points each) keep it to seconds.
TEST(FlippedNormals, DataModelsRefineAsTheCleanOnes) {
    const struct {
        const char* model;
        const char* input;
        std::size_t flips[2];
    } cases[] = {
        {"bunny", "bunny-3500-random.ply", {7, 0}},
        {"lion", "lion-3500-random.ply", {7, 70}},
        {"nefertiti", "nefertiti-3500-random.ply", {7, 70}},
    };
    constexpr unsigned kLevels = 2;
    for (const auto& c : cases) {
        const std::string mesh = std::string(c.model) + "-mesh.ply";
        PNSPLAT_REQUIRE_DATA(c.input);
        PNSPLAT_REQUIRE_DATA(mesh);
        const Result<PlyData> data = readPly(test::dataDir() / c.input);
        ASSERT_TRUE(data.ok()) << data.error().message;
        Result<Reference> reference = parseReference((test::dataDir() / mesh).string());
        ASSERT_TRUE(reference.ok()) << reference.error().message;
        const MeshOracle oracle(std::move(reference).value());
        const MeshOracle::Distances clean =
            oracle.distances(completeAndRefine(data->points, kLevels).refined);
        for (const std::size_t count : c.flips) {
            if (count == 0) continue;
            SCOPED_TRACE(std::string(c.input) + ", " + std::to_string(count) + " flipped");
            PointSet input = data->points;
            const std::vector<std::uint32_t> flipped = flipAtRandom(input, count, 7);
            const Refined r = completeAndRefine(input, kLevels);
            ASSERT_FALSE(r.refined.empty());
            ASSERT_EQ(r.done.repeats.points, 0u); // the completed points are the input's, in order
            std::size_t turned = 0, turnedFlipped = 0, wrong = 0;
            for (std::size_t i = 0; i < input.size(); ++i) {
                if (r.completed.normal[i] == input.normal[i]) continue;
                ++turned;
                turnedFlipped += std::binary_search(flipped.begin(), flipped.end(), i) ? 1 : 0;
                wrong += glm::dot(r.completed.normal[i], oracle.normalAt(input.position[i])) > 0.0f ? 0 : 1;
            }
            const MeshOracle::Distances d = oracle.distances(r.refined);
            std::cout << "[" << c.input << ", " << count << " flipped] " << turned << " turned back ("
                      << turnedFlipped << " of them flipped), " << wrong
                      << " beyond 90 degrees of the mesh's normal; " << r.refined.size()
                      << " points, distance mean " << d.mean << " (clean " << clean.mean << "), p99 " << d.p99
                      << " (clean " << clean.p99 << ")\n";
            EXPECT_EQ(r.done.turnedNormals, turned);
            EXPECT_EQ(wrong, 0u);
            EXPECT_EQ(turnedFlipped, turned);
            EXPECT_GE(static_cast<double>(turned), 0.85 * static_cast<double>(count));
            EXPECT_LE(std::abs(d.mean - clean.mean), 0.1 * clean.mean);
            EXPECT_LE(std::abs(d.p99 - clean.p99), 0.1 * clean.p99);
        }
    }
}

} // namespace
} // namespace pnsplat
