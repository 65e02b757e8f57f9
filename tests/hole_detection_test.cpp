// Holes found without being told (hole_detection.h, ALGORITHM.md §9.8): analytic shapes with and
// without a hole cut out, an open hemisphere, sizes, and the holes of ../shared/data.
#include <cmath>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "pnsplat/refine/hole_detection.h"
#include "pnsplat/refine/input.h"
#include "pnsplat/refine/io/point_file.h"
#include "pnsplat/refine/shapes/shapes.h"
#include "test_data.h"

namespace pnsplat {
namespace {

// `set` without the points within `radius` of `centre`.
PointSet withoutBall(const PointSet& set, glm::vec3 centre, float radius) {
    PointSet out;
    for (std::size_t i = 0; i < set.size(); ++i)
        if (glm::distance(set.position[i], centre) >= radius) out.appendFrom(set, i);
    return out;
}

// A unit sphere of 4,000 points (spacing about 0.056) with a ball of radius 0.3 about the north
// pole cut out: a hole about 0.58 across, 10 spacings.
PointSet sphereWithHole() {
    return withoutBall(sampleSphereUniform(4000, 1.0f), {0.0f, 0.0f, 1.0f}, 0.3f);
}

TEST(HoleDetection, ACutOutCapIsFoundWithItsSize) {
    const PointSet sphere = sphereWithHole();
    const HoleSearch search = findHoles(sphere, 2.0f, false, 2);
    EXPECT_EQ(search.maxSize, 2.0f);
    ASSERT_EQ(search.holes.size(), 1u);
    EXPECT_TRUE(search.tooLarge.empty());
    const FoundHole& hole = search.holes[0];
    // The rim's centroid lies under the pole, inside the sphere, on the axis.
    EXPECT_NEAR(hole.ball.centre.x, 0.0f, 0.03f);
    EXPECT_NEAR(hole.ball.centre.y, 0.0f, 0.03f);
    EXPECT_GT(hole.ball.centre.z, 0.9f);
    EXPECT_LT(hole.ball.centre.z, 1.0f);
    // The rim: the circle where the cut ball meets the sphere, of diameter 2 · 0.3 · sqrt(1 - 0.15²)
    // = 0.593, sampled a spacing or so inside it.
    EXPECT_GT(hole.size, 0.5f);
    EXPECT_LT(hole.size, 0.75f);
    EXPECT_GE(hole.rimPoints, kHoleMinRimPoints);
    // The ball holds no input point.
    for (const glm::vec3& p : sphere.position)
        EXPECT_GE(glm::distance(p, hole.ball.centre), hole.ball.radius);
    EXPECT_GT(hole.ball.radius, 0.2f);
    // The same in multiples of the spacing.
    const HoleSearch relative = findHoles(sphere, 2.0f / search.spacing, true, 1);
    ASSERT_EQ(relative.holes.size(), 1u);
    EXPECT_FLOAT_EQ(relative.maxSize, 2.0f);
    EXPECT_EQ(relative.holes[0].ball.centre, hole.ball.centre);
    EXPECT_NEAR(search.spacing, 0.056f, 0.01f);
    // A size past the model's diagonal is the diagonal: the same hole (sizes of 1e6 and more
    // found none or others, the empty balls' far centres rounded past the spacing).
    for (const float huge : {1e6f, 1e30f}) {
        const HoleSearch past = findHoles(sphere, huge, false, 2);
        EXPECT_GT(past.maxSize, 3.4f);
        EXPECT_LT(past.maxSize, 3.5f); // the bounding box's diagonal, about 2 sqrt(3)
        ASSERT_EQ(past.holes.size(), 1u) << huge;
        EXPECT_EQ(past.holes[0].ball.centre, hole.ball.centre);
    }
}

TEST(HoleDetection, AHoleWiderThanTheSizeIsLeftOpen) {
    const HoleSearch search = findHoles(sphereWithHole(), 0.4f, false, 2);
    EXPECT_TRUE(search.holes.empty());
    // Its empty balls are capped at half the size, but the rim still surrounds one.
    ASSERT_EQ(search.tooLarge.size(), 1u);
    EXPECT_GT(search.tooLarge[0].size, 0.4f);
}

TEST(HoleDetection, ClosedShapesAndOpenBoundariesHaveNone) {
    for (const PointSet& shape : {sampleSphereUniform(4000, 1.0f), sampleTorusUniform(4000, 1.0f, 0.4f)}) {
        const HoleSearch search = findHoles(shape, 100.0f, true, 2);
        EXPECT_TRUE(search.holes.empty());
        EXPECT_TRUE(search.tooLarge.empty());
    }
    // A hemisphere: its rim, a great circle, is an open boundary whatever the size.
    PointSet hemisphere;
    const PointSet sphere = sampleSphereUniform(4000, 1.0f);
    for (std::size_t i = 0; i < sphere.size(); ++i)
        if (sphere.position[i].z > 0.0f) hemisphere.appendFrom(sphere, i);
    const HoleSearch open = findHoles(hemisphere, 100.0f, true, 2);
    EXPECT_TRUE(open.holes.empty());
    // Too few points, no normals, a size that is not positive: nothing.
    EXPECT_TRUE(findHoles(sampleSphereUniform(kHoleNearest, 1.0f), 10.0f).holes.empty());
    PointSet bare = sphereWithHole();
    bare.normal.clear();
    EXPECT_TRUE(findHoles(bare, 10.0f).holes.empty());
    EXPECT_TRUE(findHoles(sphereWithHole(), 0.0f).holes.empty());
    EXPECT_TRUE(findHoles(sphereWithHole(), std::nanf("")).holes.empty());
}

// Triangles of points 1e14 apart, 1e20 from each other (farApartTriangles): each point's k-d
// search finds its own triangle only (squared distances past single precision are not found; the fuzzer's
// case). The spacing is the triangles' and there is no hole.
TEST(HoleDetection, PointsTooFarApartToMeasureProposeNoHole) {
    const PointSet clusters = farApartTriangles(40);
    const HoleSearch search = findHoles(clusters, 4.0f, true, 2);
    EXPECT_NEAR(search.spacing, 1e14f, 1e10f);
    EXPECT_TRUE(search.holes.empty());
    EXPECT_TRUE(search.tooLarge.empty());
}

TEST(HoleDetection, TheSameHolesForAnyThreadCount) {
    const PointSet sphere = sphereWithHole();
    const HoleSearch one = findHoles(sphere, 2.0f, false, 1), two = findHoles(sphere, 2.0f, false, 2);
    ASSERT_EQ(one.holes.size(), two.holes.size());
    for (std::size_t k = 0; k < one.holes.size(); ++k) {
        EXPECT_EQ(one.holes[k].ball.centre, two.holes[k].ball.centre);
        EXPECT_EQ(one.holes[k].ball.radius, two.holes[k].ball.radius);
        EXPECT_EQ(one.holes[k].size, two.holes[k].size);
    }
}

// The holes cut out of ../shared/data's igea and bunny (data README: their balls) are found, and
// nothing on the clean models whose openings are real boundaries (the lion's base) or that are
// closed.
TEST(HoleDetection, DataHolesAreFoundWhereTheyWereCut) {
    struct Case {
        const char* file;
        glm::vec3 centre;
        float radius;
    };
    for (const Case& c : {Case{"igea-4000-uniform-hole.ply", {0.002176f, 0.012023f, -0.04599f}, 0.02346f},
                          Case{"bunny-3500-random-hole.ply", {0.019996f, 0.120682f, 0.03262f}, 0.02502f}}) {
        PNSPLAT_REQUIRE_DATA(c.file);
        auto data = readPointFile(test::dataDir() / c.file);
        ASSERT_TRUE(data.ok()) << data.error().message;
        PointSet points = std::move(data->data.points);
        ASSERT_TRUE(completeInput(points, 2).ok());
        const HoleSearch search = findHoles(points, 40.0f, true, 2);
        std::size_t near = 0;
        for (const FoundHole& hole : search.holes) {
            std::cout << "    " << c.file << ": a hole " << hole.size << " across at " << hole.ball.centre.x
                      << "," << hole.ball.centre.y << "," << hole.ball.centre.z << ", " << hole.rimPoints
                      << " rim points\n";
            if (glm::distance(hole.ball.centre, c.centre) < c.radius) {
                ++near;
                // Measured: 0.052 (igea) and 0.055 (bunny) for balls of diameter 0.047 and 0.050.
                EXPECT_GT(hole.size, 1.5f * c.radius) << c.file;
                EXPECT_LT(hole.size, 3.0f * c.radius) << c.file;
            }
        }
        EXPECT_EQ(near, 1u) << c.file;
    }
    for (const char* file : {"lion-3500-random.ply", "rockerarm-2000-uniform.ply", "igea-600-uniform.ply",
                             "banana-1500-random.ply", "fandisk-1500-uniform-crease.ply"}) {
        PNSPLAT_REQUIRE_DATA(file);
        auto data = readPointFile(test::dataDir() / file);
        ASSERT_TRUE(data.ok()) << data.error().message;
        PointSet points = std::move(data->data.points);
        ASSERT_TRUE(completeInput(points, 2).ok());
        EXPECT_TRUE(findHoles(points, 40.0f, true, 2).holes.empty()) << file;
    }
}

} // namespace
} // namespace pnsplat
