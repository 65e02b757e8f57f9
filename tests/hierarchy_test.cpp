// Tests of the bounding-sphere hierarchy (hierarchy.h, ALGORITHM.md §7.2) on synthetic multi-level
// hierarchies built by hand: random roots, then levels where every point of P(l) receives 0-3 random
// children appended as one block. Oracles: brute force over all points for every query (the points
// closer than the radius, and exactly the points whose bounding sphere meets the ball), the bound
// recurrence recomputed independently, and the bookkeeping (levels, children ranges) against what
// was passed in. Tiny and degenerate cases: no root, one root, duplicates, radius 0.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <random>
#include <span>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "pnsplat/refine/hierarchy.h"
#include "test_random.h"

namespace pnsplat {
namespace {

using test::randomUnit;
using test::uniform;
using test::uniform01;

constexpr std::uint32_t kNoParent = 0xffffffffu;

glm::vec3 randomInCube(std::mt19937_64& rng) {
    return {uniform(rng, 0, 1), uniform(rng, 0, 1), uniform(rng, 0, 1)};
}
glm::vec3 randomInBall(std::mt19937_64& rng, float radius) {
    for (;;) {
        const glm::vec3 v(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
        if (glm::dot(v, v) <= 1.0f) return radius * v;
    }
}

// A hierarchy and the data it was built from.
struct Synthetic {
    std::vector<glm::vec3> positions;
    std::vector<std::uint32_t> parent;                  // kNoParent for roots
    std::vector<std::uint32_t> level;                   // block of first appearance
    std::vector<std::vector<std::uint32_t>> childBegin; // per transition, as given to addLevel
};

// Appends one level: every point of P(l) gets 0..maxChildren children within `spread` of it.
void addRandomLevel(Synthetic& s, PointHierarchy& h, std::mt19937_64& rng, std::uint32_t maxChildren,
                    float spread) {
    const auto n = static_cast<std::uint32_t>(s.positions.size());
    const std::uint32_t newLevel = h.levels();
    HugePageVector<std::uint32_t> begin;
    begin.reserve(n + 1);
    begin.push_back(n);
    for (std::uint32_t i = 0; i < n; ++i) {
        const auto k = static_cast<std::uint32_t>(rng() % (maxChildren + 1));
        for (std::uint32_t c = 0; c < k; ++c) {
            const glm::vec3 child = s.positions[i] + randomInBall(rng, spread);
            s.positions.push_back(child);
            s.parent.push_back(i);
            s.level.push_back(newLevel);
        }
        begin.push_back(static_cast<std::uint32_t>(s.positions.size()));
    }
    s.childBegin.emplace_back(begin.begin(), begin.end());
    h.addLevel(std::move(begin));
}

Synthetic makeRoots(std::mt19937_64& rng, std::size_t count) {
    Synthetic s;
    for (std::size_t i = 0; i < count; ++i) {
        s.positions.push_back(randomInCube(rng));
        s.parent.push_back(kNoParent);
        s.level.push_back(0);
    }
    return s;
}

struct Visit {
    std::vector<std::uint32_t> index;
    std::vector<float> distance2;
};

Visit runQuery(const PointHierarchy& h, glm::vec3 centre, float radius) {
    Visit v;
    std::vector<PointHierarchy::StackEntry> stack;
    h.query(centre, radius, stack, [&](std::uint32_t i, float d2) {
        v.index.push_back(i);
        v.distance2.push_back(d2);
    });
    return v;
}

// The documented sphere test, evaluated exactly as written in the header (float).
bool sphereMeetsBall(glm::vec3 p, float bound, glm::vec3 centre, float radius) {
    const glm::vec3 d = p - centre;
    const float reach = radius + bound;
    return glm::dot(d, d) <= reach * reach;
}

// Checks one query against brute force over all points; returns how many points were closer than
// the radius (to let callers make sure the queries are not all empty).
std::size_t checkQuery(const PointHierarchy& h, const Synthetic& s, glm::vec3 centre, float radius) {
    const Visit v = runQuery(h, centre, radius);
    const auto count = static_cast<std::uint32_t>(s.positions.size());
    std::vector<std::uint32_t> visited = v.index;
    std::sort(visited.begin(), visited.end());
    EXPECT_TRUE(std::adjacent_find(visited.begin(), visited.end()) == visited.end())
        << "a point visited twice";
    for (std::size_t k = 0; k < v.index.size(); ++k) {
        const std::uint32_t i = v.index[k];
        EXPECT_LT(i, count);
        if (i >= count) return 0;
        const glm::dvec3 d = glm::dvec3(s.positions[i]) - glm::dvec3(centre);
        EXPECT_NEAR(v.distance2[k], glm::dot(d, d), 1e-6 * (1.0 + glm::dot(d, d)));
        EXPECT_LE(glm::length(d), static_cast<double>(radius) + static_cast<double>(h.bound(i)) + 1e-6);
    }
    std::vector<std::uint32_t> inside, visitedInside, meets;
    for (std::uint32_t i = 0; i < count; ++i) {
        if (glm::length(s.positions[i] - centre) < radius) inside.push_back(i);
        if (sphereMeetsBall(s.positions[i], h.bound(i), centre, radius)) meets.push_back(i);
    }
    for (std::uint32_t i : visited)
        if (glm::length(s.positions[i] - centre) < radius) visitedInside.push_back(i);
    EXPECT_EQ(visitedInside, inside) << "centre " << centre.x << " " << centre.y << " " << centre.z
                                     << " radius " << radius;
    // Bounds nest (checked separately), so no ancestor prunes a point whose own sphere meets the
    // ball: the visited set is exactly the brute-force set.
    EXPECT_EQ(visited, meets);
    return inside.size();
}

// bound_i = max over children c (all transitions) of |p_c - p_i| + bound_c, 0 for a leaf; and every
// parent's sphere contains its children's spheres (evaluated in float as the query does).
void checkBounds(const PointHierarchy& h, const Synthetic& s) {
    const auto count = static_cast<std::uint32_t>(s.positions.size());
    std::vector<float> expected(count, 0.0f);
    for (std::uint32_t c = count; c-- > 0;)
        if (s.parent[c] != kNoParent) {
            const std::uint32_t i = s.parent[c];
            expected[i] = std::max(expected[i], glm::length(s.positions[c] - s.positions[i]) + expected[c]);
        }
    for (std::uint32_t i = 0; i < count; ++i) {
        // The documented recurrence, allowing a conservative upward rounding of a few ulps.
        EXPECT_GE(h.bound(i), expected[i]) << i;
        EXPECT_LE(h.bound(i), expected[i] * (1.0f + 1e-5f)) << i;
        if (s.parent[i] != kNoParent) {
            const std::uint32_t p = s.parent[i];
            EXPECT_GE(h.bound(p), glm::length(s.positions[i] - s.positions[p]) + h.bound(i)) << i;
        }
    }
}

void checkBookkeeping(const PointHierarchy& h, const Synthetic& s) {
    const auto count = static_cast<std::uint32_t>(s.positions.size());
    ASSERT_EQ(h.levels(), s.childBegin.size() + 1);
    ASSERT_EQ(h.pointCount(), count);
    for (std::uint32_t l = 0; l + 1 < h.levels(); ++l) {
        const std::vector<std::uint32_t>& begin = s.childBegin[l];
        EXPECT_EQ(h.levelEnd(l), begin.front());
        EXPECT_EQ(h.levelEnd(l + 1), begin.back());
        for (std::uint32_t i = 0; i < h.levelEnd(l); ++i) {
            EXPECT_EQ(h.childBegin(l, i), begin[i]);
            EXPECT_EQ(h.childEnd(l, i), begin[i + 1]);
            for (std::uint32_t c = h.childBegin(l, i); c < h.childEnd(l, i); ++c) EXPECT_EQ(s.parent[c], i);
        }
    }
    for (std::uint32_t i = 0; i < count; ++i) EXPECT_EQ(h.levelOf(i), s.level[i]) << i;
}

// ---------------------------------------------------------------------------------------------

TEST(PointHierarchy, QueriesMatchBruteForceAtEveryLevel) {
    for (float spread : {0.02f, 0.3f}) { // children near their parent, and far (larger bounds)
        std::mt19937_64 rng(spread < 0.1f ? 301 : 302);
        Synthetic s = makeRoots(rng, 300);
        PointHierarchy h(s.positions);
        std::size_t nonEmpty = 0;
        for (int l = 0; l <= 3; ++l) {
            if (l > 0) {
                addRandomLevel(s, h, rng, 3, spread / static_cast<float>(1 << (l - 1)));
                h.updateBounds(s.positions);
            }
            checkBookkeeping(h, s);
            checkBounds(h, s);
            const int queries = l == 3 ? 500 : 100;
            for (int q = 0; q < queries; ++q) {
                // Half the balls anywhere (many empty), half near an existing point.
                const glm::vec3 centre =
                    q % 2 == 0 ? randomInCube(rng) * 1.2f - glm::vec3(0.1f)
                               : s.positions[rng() % s.positions.size()] + randomInBall(rng, 0.1f);
                const float radius = q % 10 == 0 ? 0.0f : uniform(rng, 0.0, 0.15);
                nonEmpty += checkQuery(h, s, centre, radius) > 0;
            }
        }
        std::cout << "spread " << spread << ": " << s.positions.size() << " points, " << nonEmpty
                  << " non-empty queries\n";
        EXPECT_GT(s.positions.size(), 2000u); // three levels really added points
        EXPECT_GT(nonEmpty, 300u);
    }
}

TEST(PointHierarchy, LargeBallVisitsEveryPointOnceAndOrderIsDeterministic) {
    std::mt19937_64 rng(303);
    Synthetic s = makeRoots(rng, 100);
    PointHierarchy h(s.positions);
    for (int l = 0; l < 3; ++l) addRandomLevel(s, h, rng, 3, 0.05f);
    h.updateBounds(s.positions);
    const Visit all = runQuery(h, glm::vec3(0.5f), 10.0f);
    std::vector<std::uint32_t> sorted = all.index;
    std::sort(sorted.begin(), sorted.end());
    ASSERT_EQ(sorted.size(), s.positions.size());
    for (std::uint32_t i = 0; i < sorted.size(); ++i) EXPECT_EQ(sorted[i], i);
    for (int q = 0; q < 20; ++q) {
        const glm::vec3 centre = randomInCube(rng);
        const Visit a = runQuery(h, centre, 0.2f), b = runQuery(h, centre, 0.2f);
        EXPECT_EQ(a.index, b.index);
    }
}

// Regression: query() tests dot(d,d) <= (radius + bound)^2 in float. With a bound rounded to
// nearest, bound² could round below dot(d,d) of the farthest descendant itself, so a ball centred
// on it pruned its ancestor: root (0,0,0), child (0.4, 0.1, 0.24), bound² = 0.227599993 <
// dot(d,d) = 0.227600008. Bounds are now rounded up (hierarchy.cpp, kBoundRoundUp).
TEST(PointHierarchy, BoundSurvivesRoundingOfItsFarthestDescendant) {
    const std::vector<glm::vec3> positions = {glm::vec3(0.0f), glm::vec3(0.4f, 0.1f, 0.24f)};
    PointHierarchy h(std::span<const glm::vec3>(positions.data(), 1));
    h.addLevel({1u, 2u});
    h.updateBounds(positions);
    EXPECT_GE(h.bound(0), glm::length(positions[1] - positions[0]));
    for (float radius : {0.0f, 1e-8f}) {
        const Visit v = runQuery(h, positions[1], radius);
        EXPECT_NE(std::find(v.index.begin(), v.index.end(), 1u), v.index.end()) << "radius " << radius;
    }
}

// Regression for the same rounding (about 5% of the points were missed by a radius-0 query centred
// on them).
TEST(PointHierarchy, RadiusZeroAtAPointFindsItAndItsAncestors) {
    std::mt19937_64 rng(304);
    Synthetic s = makeRoots(rng, 200);
    PointHierarchy h(s.positions);
    for (int l = 0; l < 3; ++l) addRandomLevel(s, h, rng, 3, 0.05f);
    h.updateBounds(s.positions);
    for (int q = 0; q < 200; ++q) {
        const auto k = static_cast<std::uint32_t>(rng() % s.positions.size());
        const Visit v = runQuery(h, s.positions[k], 0.0f);
        for (std::uint32_t a = k; a != kNoParent; a = s.parent[a])
            EXPECT_NE(std::find(v.index.begin(), v.index.end(), a), v.index.end()) << k << " ancestor " << a;
        checkQuery(h, s, s.positions[k], 0.0f);
    }
}

TEST(PointHierarchy, LevelWithoutNewPoints) {
    std::mt19937_64 rng(305);
    Synthetic s = makeRoots(rng, 50);
    PointHierarchy h(s.positions);
    addRandomLevel(s, h, rng, 3, 0.05f);
    addRandomLevel(s, h, rng, 0, 0.05f); // no children at all: an empty block
    addRandomLevel(s, h, rng, 2, 0.05f);
    h.updateBounds(s.positions);
    ASSERT_EQ(h.levels(), 4u);
    EXPECT_EQ(h.levelEnd(1), h.levelEnd(2));
    EXPECT_LT(h.levelEnd(0), h.levelEnd(1));
    EXPECT_LT(h.levelEnd(2), h.levelEnd(3));
    checkBookkeeping(h, s);
    checkBounds(h, s);
    for (int q = 0; q < 100; ++q) checkQuery(h, s, randomInCube(rng), uniform(rng, 0.0, 0.2));
}

TEST(PointHierarchy, NoRoots) {
    const std::vector<glm::vec3> none;
    PointHierarchy h(none);
    EXPECT_EQ(h.levels(), 1u);
    EXPECT_EQ(h.pointCount(), 0u);
    EXPECT_TRUE(runQuery(h, glm::vec3(0.0f), 100.0f).index.empty());
    h.addLevel({0u});
    h.updateBounds(none);
    EXPECT_EQ(h.levels(), 2u);
    EXPECT_EQ(h.pointCount(), 0u);
    EXPECT_TRUE(runQuery(h, glm::vec3(0.0f), 100.0f).index.empty());
}

TEST(PointHierarchy, SingleRootWithDescendants) {
    std::vector<glm::vec3> positions = {glm::vec3(0.5f, -1.0f, 2.0f)};
    PointHierarchy h(positions);
    EXPECT_EQ(runQuery(h, positions[0], 0.0f).index, (std::vector<std::uint32_t>{0}));
    EXPECT_TRUE(runQuery(h, positions[0] + glm::vec3(0.1f, 0.0f, 0.0f), 0.05f).index.empty());
    // Two children at +x (0.3 and 0.1 away), then a grandchild of the second one at +y.
    positions.push_back(positions[0] + glm::vec3(0.3f, 0.0f, 0.0f));
    positions.push_back(positions[0] + glm::vec3(0.1f, 0.0f, 0.0f));
    h.addLevel({1u, 3u});
    positions.push_back(positions[2] + glm::vec3(0.0f, 0.4f, 0.0f));
    h.addLevel({3u, 3u, 3u, 4u});
    h.updateBounds(positions);
    EXPECT_EQ(h.levels(), 3u);
    EXPECT_EQ(h.levelOf(0), 0u);
    EXPECT_EQ(h.levelOf(1), 1u);
    EXPECT_EQ(h.levelOf(2), 1u);
    EXPECT_EQ(h.levelOf(3), 2u);
    EXPECT_EQ(h.childBegin(0, 0), 1u);
    EXPECT_EQ(h.childEnd(0, 0), 3u);
    EXPECT_EQ(h.childBegin(1, 0), h.childEnd(1, 0)); // no children of the root at the second step
    EXPECT_EQ(h.childBegin(1, 2), 3u);
    EXPECT_EQ(h.childEnd(1, 2), 4u);
    // Bounds: the grandchild is 0.1 + 0.4 through its parent, the other child 0.3; each nesting
    // rounds up by 2^-18 relative (hierarchy.cpp, kBoundRoundUp), never down.
    EXPECT_EQ(h.bound(3), 0.0f);
    EXPECT_GE(h.bound(2), 0.4f);
    EXPECT_NEAR(h.bound(2), 0.4f, 1e-5f);
    EXPECT_EQ(h.bound(1), 0.0f);
    EXPECT_GE(h.bound(0), 0.5f);
    EXPECT_NEAR(h.bound(0), 0.5f, 1e-5f);
    // A ball around the grandchild only.
    const Visit v = runQuery(h, positions[3], 0.01f);
    std::vector<std::uint32_t> found = v.index;
    std::sort(found.begin(), found.end());
    EXPECT_EQ(found, (std::vector<std::uint32_t>{0, 2, 3})); // 3 inside; 0 and 2 by their spheres
    EXPECT_NE(std::find(found.begin(), found.end(), 3u), found.end());
}

TEST(PointHierarchy, DuplicatePositions) {
    std::mt19937_64 rng(306);
    Synthetic s;
    const glm::vec3 same(0.25f, 0.5f, 0.75f);
    for (int k = 0; k < 20; ++k) { // more than a kd-tree leaf of identical points
        s.positions.push_back(same);
        s.parent.push_back(kNoParent);
        s.level.push_back(0);
    }
    for (int k = 0; k < 30; ++k) {
        s.positions.push_back(randomInCube(rng));
        s.parent.push_back(kNoParent);
        s.level.push_back(0);
    }
    PointHierarchy h(s.positions);
    // Children at their parent's exact position, and random ones.
    addRandomLevel(s, h, rng, 3, 0.0f);
    addRandomLevel(s, h, rng, 2, 0.05f);
    h.updateBounds(s.positions);
    checkBookkeeping(h, s);
    checkBounds(h, s);
    const Visit v = runQuery(h, same, 1e-4f);
    std::size_t atSame = 0;
    for (std::uint32_t i = 0; i < s.positions.size(); ++i) atSame += s.positions[i] == same;
    std::size_t found = 0;
    for (std::uint32_t i : v.index) found += s.positions[i] == same;
    EXPECT_GE(atSame, 20u);
    EXPECT_EQ(found, atSame);
    checkQuery(h, s, same, 0.0f);
    checkQuery(h, s, same, 1e-4f);
    for (int q = 0; q < 100; ++q) checkQuery(h, s, randomInCube(rng), uniform(rng, 0.0, 0.3));
}

} // namespace
} // namespace pnsplat

namespace pnsplat {
namespace {

// queryBox against brute force: every point within `margin` of the box is visited, every visited
// point's sphere meets the grown box, and the reported distance is the distance to the box.
TEST(PointHierarchy, BoxQueriesMatchBruteForce) {
    std::mt19937_64 rng(305);
    Synthetic s = makeRoots(rng, 300);
    PointHierarchy h(s.positions);
    for (int l = 0; l < 3; ++l) addRandomLevel(s, h, rng, 3, 0.05f / static_cast<float>(1 << l));
    h.updateBounds(s.positions);
    std::vector<PointHierarchy::StackEntry> stack;
    std::size_t nonEmpty = 0;
    for (int q = 0; q < 300; ++q) {
        const glm::vec3 a = randomInCube(rng),
                        b = a + glm::vec3(uniform(rng, 0, 0.1), uniform(rng, 0, 0.1), uniform(rng, 0, 0.1));
        const float margin = q % 7 == 0 ? 0.0f : uniform(rng, 0.0, 0.08);
        std::vector<std::uint32_t> visited;
        h.queryBox(a, b, margin, stack, [&](std::uint32_t i, float d2) {
            const glm::vec3 d = s.positions[i] - glm::clamp(s.positions[i], a, b);
            EXPECT_FLOAT_EQ(d2, glm::dot(d, d));
            const float reach = margin + h.bound(i);
            EXPECT_LE(d2, reach * reach);
            visited.push_back(i);
        });
        std::sort(visited.begin(), visited.end());
        std::size_t within = 0;
        for (std::uint32_t i = 0; i < s.positions.size(); ++i) {
            const glm::vec3 d = s.positions[i] - glm::clamp(s.positions[i], a, b);
            if (glm::dot(d, d) <= margin * margin) {
                ++within;
                EXPECT_TRUE(std::binary_search(visited.begin(), visited.end(), i))
                    << "query " << q << " point " << i;
            }
        }
        nonEmpty += within > 0;
    }
    EXPECT_GT(nonEmpty, 100u);
}

} // namespace
} // namespace pnsplat
