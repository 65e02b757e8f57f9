// The node hierarchy of the real-time refinement (node_tree.h): splits, roots, and the rules that
// make a node's children a function of P(l) alone (balance, context, regions).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <set>
#include <span>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "oracles.h"
#include "pnsplat/refine/input.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/node_tree.h"
#include "pnsplat/refine/node_workers.h"
#include "pnsplat/refine/quantile.h"
#include "pnsplat/refine/shapes/shapes.h"
#include "pnsplat/refine/worker_pool.h"
#include "test_data.h"
#include "test_random.h"

namespace pnsplat {
namespace {

using Key = std::array<std::uint32_t, 3>;
Key keyOf(glm::vec3 p) {
    return {std::bit_cast<std::uint32_t>(p.x), std::bit_cast<std::uint32_t>(p.y),
            std::bit_cast<std::uint32_t>(p.z)};
}

PointSet withRadii(PointSet set) {
    EXPECT_TRUE(completeInput(set, 2).ok());
    return set;
}

NodeSettings smallNodes(std::uint32_t maxNodePoints = 256) {
    NodeSettings settings;
    settings.maxNodePoints = maxNodePoints;
    return settings;
}

// Refines every leaf of level < `level`, coarsest first, blockers first; `order` shuffles the
// leaves of each pass (fixed seed) so that tests can vary the history.
void refineEverywhere(NodeTree& tree, std::uint32_t level, std::uint64_t seed = 0) {
    std::mt19937_64 random(seed);
    for (bool changed = true; changed;) {
        changed = false;
        std::vector<NodeId> leaves;
        for (NodeId id = 0; id < tree.slotCount(); ++id)
            if (tree.isLive(id) && tree.node(id).isLeaf() && tree.node(id).level < level)
                leaves.push_back(id);
        if (seed != 0) std::shuffle(leaves.begin(), leaves.end(), random);
        for (const NodeId id : leaves) {
            std::vector<NodeId> blockers;
            if (!tree.isLive(id) || !tree.node(id).isLeaf() || !tree.ready(id, blockers)) continue;
            ASSERT_TRUE(tree.attach(NodeTree::run(tree.makeJob(id), tree.settings())));
            changed = true;
        }
    }
}

// The points of the leaves of `level`, by position, with everything they carry.
std::map<Key, std::array<float, 7>> pointsOfLevel(const NodeTree& tree, std::uint32_t level) {
    std::map<Key, std::array<float, 7>> all;
    for (NodeId id = 0; id < tree.slotCount(); ++id) {
        if (!tree.isLive(id) || tree.node(id).level != level) continue;
        const PointSet& p = tree.node(id).points;
        for (std::size_t i = 0; i < p.size(); ++i) {
            const bool fresh =
                all.emplace(keyOf(p.position[i]), std::array<float, 7>{p.normal[i].x, p.normal[i].y,
                                                                       p.normal[i].z, p.radius[i], 0, 0, 0})
                    .second;
            EXPECT_TRUE(fresh) << "a point held twice at level " << level;
        }
    }
    return all;
}

TEST(NodeSplit, PartsPartitionTheRegionByCount) {
    std::mt19937 random(5);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (const std::size_t n : {100u, 300u, 600u, 1000u, 5000u}) {
        std::vector<glm::vec3> points(n);
        for (auto& p : points) p = {4.0f * u(random), u(random), 0.5f * u(random)};
        const Region region{glm::vec3(-4.0f, -1.0f, -0.5f), glm::vec3(4.0f, 1.0f, 0.5f)};
        const auto parts = splitNode(points, region, 256);
        const std::size_t expected = n <= 256 ? 1 : n <= 512 ? 2 : n <= 768 ? 3 : 4;
        ASSERT_EQ(parts.size(), expected) << n;
        std::vector<int> seen(n, 0);
        for (const SplitPart& part : parts) {
            EXPECT_FALSE(part.indices.empty());
            if (expected < 4) {
                EXPECT_LE(part.indices.size(), 256u + 1);
            }
            EXPECT_TRUE(std::is_sorted(part.indices.begin(), part.indices.end()));
            for (const std::uint32_t i : part.indices) {
                ++seen[i];
                EXPECT_TRUE(part.region.contains(points[i]));
            }
            // The parts' regions are disjoint: no point of another part lies in this one.
            for (const SplitPart& other : parts) {
                if (&other == &part) continue;
                for (const std::uint32_t i : other.indices) EXPECT_FALSE(part.region.contains(points[i]));
            }
        }
        EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](int s) { return s == 1; }));
        if (expected >= 2) {
            // Split along x, the longest axis: the first part lies left of the others.
            EXPECT_EQ(parts[0].region.lo.x, -4.0f);
            EXPECT_LT(parts[0].region.hi.x, 4.0f);
        }
    }
}

// The workers run jobs as NodeTree::run does on the calling thread, and count as busy only the time a
// job was waiting or running: nothing while idle, and never more than the time that passed. The
// jobs' processor time is no more than two workers can spend in the queue's time. A bounded wait
// (the engine's at rest) ends when the jobs do, and at once when there are none.
TEST(NodeWorkers, ResultsAreRunsAndBusyTimeIsTheQueuesTime) {
    auto tree = NodeTree::create(withRadii(sampleSphereRandom(3000, 1.0f, 11)), smallNodes());
    ASSERT_TRUE(tree) << tree.error().message;
    NodeWorkers workers(2, tree->settings());
    EXPECT_EQ(workers.busySeconds(), 0.0);
    EXPECT_EQ(workers.jobSeconds(), 0.0);
    const auto start = std::chrono::steady_clock::now();
    std::vector<NodeJob> jobs;
    for (const NodeId root : tree->roots()) jobs.push_back(tree->makeJob(root));
    workers.submit(jobs);
    EXPECT_TRUE(workers.waitIdleFor(std::chrono::minutes(10)));
    EXPECT_TRUE(workers.waitIdleFor(std::chrono::milliseconds(0)));
    const double busy = workers.busySeconds();
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_GT(busy, 0.0);
    EXPECT_LE(busy, elapsed);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    EXPECT_EQ(workers.busySeconds(), busy); // idle: results waiting do not count
    const double jobTime = workers.jobSeconds();
    EXPECT_GT(jobTime, 0.0);
    EXPECT_LE(jobTime, 2.0 * busy);

    std::vector<NodeJobResult> results = workers.takeResults();
    ASSERT_EQ(results.size(), jobs.size());
    std::ranges::sort(results, {}, &NodeJobResult::node);
    for (const NodeJobResult& result : results) {
        const NodeJobResult alone = NodeTree::run(tree->makeJob(result.node), tree->settings());
        ASSERT_EQ(result.children.size(), alone.children.size());
        for (std::size_t c = 0; c < alone.children.size(); ++c)
            EXPECT_EQ(result.children[c].points.position, alone.children[c].points.position);
    }
    EXPECT_EQ(workers.outstanding(), 0u);
}

TEST(NodeTree, RootsPartitionTheInput) {
    const PointSet input = withRadii(sampleSphereRandom(3000, 1.0f, 11));
    auto tree = NodeTree::create(input, smallNodes());
    ASSERT_TRUE(tree) << tree.error().message;
    std::size_t total = 0;
    for (const NodeId root : tree->roots()) {
        const Node& node = tree->node(root);
        EXPECT_LE(node.points.size(), 256u);
        EXPECT_EQ(node.level, 0u);
        total += node.points.size();
        for (const glm::vec3 p : node.points.position) {
            EXPECT_TRUE(node.region.contains(p));
            for (int a = 0; a < 3; ++a) EXPECT_TRUE(node.lo[a] <= p[a] && p[a] <= node.hi[a]);
        }
    }
    EXPECT_EQ(total, input.size());
    EXPECT_EQ(tree->pointCount(), input.size());
}

// The roots hold one density each (kRootSpread): a terrestrial scan's density falls with the
// square of the range, and roots cut by count alone ran from its near field to its far field (the
// 90th percentile of their radii up to 13 times the 10th at 10,000 points). Its roots are split
// until their radii spread at most kRootSpread, or they hold fewer than kRootSpreadPoints; a
// uniform random sphere's spread less (about 2.3) and are split by count alone, as is a tree only
// drawn.
TEST(NodeTree, RootsHoldOneDensityEach) {
    const auto spreadOf = [](const Node& node) {
        std::vector<float> r(node.points.radius.begin(), node.points.radius.end());
        std::sort(r.begin(), r.end());
        return r[quantileIndex(r.size(), 0.9f)] / r[quantileIndex(r.size(), 0.1f)];
    };
    const PointSet scan = withRadii(sampleTerrainScan(10000, 0.5, 200.0, 8));
    const NodeTree scanTree = NodeTree::create(scan, NodeSettings{}).value();
    std::size_t total = 0;
    for (const NodeId root : scanTree.roots()) {
        const Node& node = scanTree.node(root);
        total += node.points.size();
        if (node.points.size() >= kRootSpreadPoints) {
            EXPECT_LE(spreadOf(node), kRootSpread);
        }
    }
    EXPECT_EQ(total, scan.size());
    // By count alone: 16 roots of 625 points.
    EXPECT_GT(scanTree.roots().size(), 16u);

    const NodeTree sphereTree =
        NodeTree::create(withRadii(sampleSphereRandom(10000, 1.0f, 8)), NodeSettings{}).value();
    EXPECT_EQ(sphereTree.roots().size(), 16u);
    // A tree only drawn decides no level of detail: cut by count alone.
    EXPECT_EQ(NodeTree::create(scan, NodeSettings{}, false).value().roots().size(), 16u);
}

// A part whose median along its longest axis is its smallest coordinate there (more than half of
// its points on one plane) is cut just above that coordinate: it used to be left whole and cut
// into roots of consecutive points sharing one region, and the whole levels' points of that region
// all went to the first of them, the others' children taking the whole level (an empty subset).
TEST(NodeTree, RootsSplitWhereMostPointsShareACoordinate) {
    std::mt19937_64 rng(12);
    PointSet input;
    for (int i = 0; i < 600; ++i) { // the plane x = 0
        input.position.emplace_back(0.0f, test::uniform(rng, 0.0, 1.0), test::uniform(rng, 0.0, 1.0));
        input.normal.emplace_back(1.0f, 0.0f, 0.0f);
    }
    for (int i = 0; i < 500; ++i) { // the plane z = 0, beside it
        input.position.emplace_back(test::uniform(rng, 0.05, 1.0), test::uniform(rng, 0.0, 1.0), 0.0f);
        input.normal.emplace_back(0.0f, 0.0f, 1.0f);
    }
    input = withRadii(std::move(input));
    NodeSettings settings = smallNodes();
    Refiner offline(input, RefineOptions{});
    offline.refineLevel();
    settings.wholeLevelPoints =
        static_cast<std::size_t>(double(input.size()) * kLevelGrowth); // level 1, not 2
    const NodeTree tree = NodeTree::create(input, settings).value();
    ASSERT_EQ(tree.wholeLevels(), 1u);
    for (const NodeId a : tree.roots())
        for (const NodeId b : tree.roots())
            if (a < b) {
                EXPECT_FALSE(tree.node(a).region.lo == tree.node(b).region.lo &&
                             tree.node(a).region.hi == tree.node(b).region.hi)
                    << "roots " << a << " and " << b << " share a region";
            }
    EXPECT_EQ(pointsOfLevel(tree, 1).size(), offline.points().size()); // each point once
}

TEST(NodeTree, RefiningEverywhereApproachesTheUniformLevels) {
    const PointSet input = withRadii(sampleSphereRandom(2000, 1.0f, 3));
    auto tree = NodeTree::create(input, smallNodes());
    ASSERT_TRUE(tree);
    Refiner offline(input, RefineOptions{});
    for (std::uint32_t level = 1; level <= 3; ++level) {
        refineEverywhere(*tree, level);
        offline.refineLevel();
        const auto nodes = pointsOfLevel(*tree, level);
        const double ratio = double(nodes.size()) / double(offline.points().size());
        std::printf("level %u: nodes %zu, offline %zu (%.4f)\n", level, nodes.size(), offline.points().size(),
                    ratio);
        EXPECT_NEAR(ratio, 1.0, 0.05);
        // On the sphere.
        double worst = 0.0;
        for (const auto& [key, value] : nodes) {
            const glm::vec3 p{std::bit_cast<float>(key[0]), std::bit_cast<float>(key[1]),
                              std::bit_cast<float>(key[2])};
            worst = std::max(worst, std::abs(double(glm::length(p)) - 1.0));
        }
        EXPECT_LT(worst, 0.01);
    }
}

// Whole levels first (NodeSettings::wholeLevelPoints): the nodes of each level down to the last
// whole level hold the offline refinement's level bit for bit, the last with its segments; the
// budget decides how many levels (the next estimated at kLevelGrowth times the last); jobs go on
// from there.
TEST(NodeTree, WholeLevelsFirstAreTheOfflineLevels) {
    const PointSet sphere = sampleSphereRandom(3000, 1.0f, 21);
    PointSet dome; // open: its rim has boundary segments
    for (std::size_t i = 0; i < sphere.size(); ++i)
        if (sphere.position[i].z > -0.2f) dome.appendFrom(sphere, i);
    const PointSet input = withRadii(std::move(dome));
    Refiner offline(input, RefineOptions{});
    offline.refineLevel();
    const std::size_t firstLevel = offline.points().size();
    offline.refineLevel();
    const std::vector<SegmentEnds> offlineSegments = offline.segmentEnds();
    ASSERT_GT(offlineSegments.size(), 10u) << "no rim: the test shows nothing of the segments";

    // Room for level 2 (level 1 times kLevelGrowth), not for level 3.
    NodeSettings settings = smallNodes();
    settings.wholeLevelPoints = static_cast<std::size_t>(double(firstLevel) * kLevelGrowth);
    auto tree = NodeTree::create(input, settings);
    ASSERT_TRUE(tree) << tree.error().message;
    EXPECT_EQ(tree->wholeLevels(), 2u);
    EXPECT_EQ(tree->inputPoints(), input.size());
    // Level by level, the offline refinement's points with the radii of that level; every node of
    // a level above 2 has children, those of level 2 are leaves.
    Refiner replay(input, RefineOptions{});
    for (std::uint32_t level = 0; level <= 2; ++level) {
        if (level > 0) replay.refineLevel();
        const PointSet& offlineLevel = replay.points();
        const auto nodes = pointsOfLevel(*tree, level);
        ASSERT_EQ(nodes.size(), offlineLevel.size()) << "level " << level;
        for (std::size_t i = 0; i < offlineLevel.size(); ++i) {
            const auto found = nodes.find(keyOf(offlineLevel.position[i]));
            ASSERT_NE(found, nodes.end()) << "an offline point of level " << level << " is in no node";
            const std::array<float, 7> expected{offlineLevel.normal[i].x, offlineLevel.normal[i].y,
                                                offlineLevel.normal[i].z, offlineLevel.radius[i]};
            EXPECT_EQ(found->second, expected)
                << "a node's point differs from the offline one, level " << level;
        }
    }
    std::vector<std::array<float, 7>> segments;
    for (NodeId id = 0; id < tree->slotCount(); ++id) {
        if (!tree->isLive(id)) continue;
        const Node& node = tree->node(id);
        EXPECT_EQ(node.isLeaf(), node.level == 2) << "node " << id;
        for (const SegmentEnds& e : node.segments)
            segments.push_back({e.a.x, e.a.y, e.a.z, e.b.x, e.b.y, e.b.z});
        if (!node.segments.empty()) {
            EXPECT_EQ(node.level, 2u) << "segments are the leaves' only";
        }
    }
    std::vector<std::array<float, 7>> expectedSegments;
    for (const SegmentEnds& e : offlineSegments)
        expectedSegments.push_back({e.a.x, e.a.y, e.a.z, e.b.x, e.b.y, e.b.z});
    std::sort(segments.begin(), segments.end());
    std::sort(expectedSegments.begin(), expectedSegments.end());
    EXPECT_EQ(segments, expectedSegments);

    // One point short of room for level 2: level 1 only. Short of room for level 1: the input.
    settings.wholeLevelPoints = static_cast<std::size_t>(double(firstLevel) * kLevelGrowth) - 1;
    EXPECT_EQ(NodeTree::create(input, settings)->wholeLevels(), 1u);
    settings.wholeLevelPoints = static_cast<std::size_t>(double(input.size()) * kLevelGrowth) - 1;
    auto none = NodeTree::create(input, settings);
    ASSERT_TRUE(none);
    EXPECT_EQ(none->wholeLevels(), 0u);
    EXPECT_EQ(none->pointCount(), input.size());
    for (const NodeId root : none->roots()) EXPECT_TRUE(none->node(root).isLeaf());

    // The nodes go on from level 2 as from any level.
    refineEverywhere(*tree, 3);
    offline.refineLevel();
    const double ratio = double(pointsOfLevel(*tree, 3).size()) / double(offline.points().size());
    EXPECT_NEAR(ratio, 1.0, 0.05);
}

// Why whole levels first: a job's level differs from the whole level's (§8.2: the order of the
// refinement, the context near region borders), and the difference grows with every level that
// jobs refine. Level 3 made by jobs from the whole level 2 holds more of the offline level 3's
// points, bit for bit, than level 3 made by jobs from P0.
TEST(NodeTree, WholeLevelsBringTheJobsNearerTheOfflineLevels) {
    const PointSet input = withRadii(sampleTorusRandom(2500, 1.0f, 0.35f, 9));
    Refiner offline(input, RefineOptions{});
    for (int l = 0; l < 3; ++l) offline.refineLevel();
    std::set<Key> level3;
    for (const glm::vec3 p : offline.points().position) level3.insert(keyOf(p));
    const auto shared = [&](std::size_t wholeLevelPoints) {
        NodeSettings settings = smallNodes();
        settings.wholeLevelPoints = wholeLevelPoints;
        auto tree = NodeTree::create(input, settings);
        EXPECT_TRUE(tree);
        EXPECT_EQ(tree->wholeLevels(), wholeLevelPoints > 0 ? 2u : 0u);
        refineEverywhere(*tree, 3);
        const auto nodes = pointsOfLevel(*tree, 3);
        std::size_t same = 0;
        for (const auto& entry : nodes) same += level3.count(entry.first);
        return double(same) / double(level3.size());
    };
    const double fromInput = shared(0);
    const double fromLevel2 =
        shared(static_cast<std::size_t>(kLevelGrowth * kLevelGrowth * double(input.size())) + 1000);
    std::printf(
        "offline level 3 points made bit for bit by the jobs: from P0 %.4f, from the whole level 2 %.4f\n",
        fromInput, fromLevel2);
    EXPECT_GT(fromLevel2, fromInput + 0.1);
}

// Attributes (PointSet::attributes) go through the node tree's copies (roots, contexts, regions,
// children): every node carries them for each point; input points keep their values, a constant
// stays constant, and every mean stays within the input's range.
TEST(NodeTree, NodesCarryAttributes) {
    PointSet input = withRadii(sampleSphereRandom(2000, 1.0f, 3));
    input.attributes = {Attribute{"intensity", ScalarType::Float32, {}},
                        Attribute{"quality", ScalarType::UInt8, {}}};
    std::map<Key, double> inputValue;
    for (std::size_t i = 0; i < input.size(); ++i) {
        const double value = double(float(1.0 + 999.0 * double(i) / double(input.size())));
        input.attributes[0].values.push_back(value);
        input.attributes[1].values.push_back(9.0);
        inputValue[keyOf(input.position[i])] = value;
    }
    auto tree = NodeTree::create(input, smallNodes());
    ASSERT_TRUE(tree);
    refineEverywhere(*tree, 2);
    std::size_t points = 0, kept = 0;
    for (NodeId id = 0; id < tree->slotCount(); ++id) {
        if (!tree->isLive(id)) continue;
        const PointSet& p = tree->node(id).points;
        ASSERT_TRUE(sameAttributes(p, input));
        ASSERT_EQ(test::pointSetDefect(p), "");
        for (std::size_t i = 0; i < p.size(); ++i, ++points) {
            const double value = p.attributes[0].values[i];
            EXPECT_EQ(p.attributes[1].values[i], 9.0);
            EXPECT_TRUE(value >= 1.0 && value <= 1000.0) << value;
            const auto found = inputValue.find(keyOf(p.position[i]));
            if (found == inputValue.end()) continue;
            ++kept;
            EXPECT_EQ(value, found->second) << "an input point's value changed";
        }
    }
    EXPECT_GT(points, 3u * input.size());
    EXPECT_GE(kept, input.size()); // every input point, in its nodes of each level
}

// A node's children are a function of P(l) alone: whatever order the nodes are refined in, and
// after children are released and made again, every level holds the same points bit for bit.
TEST(NodeTree, ChildrenDoNotDependOnHistory) {
    const PointSet input = withRadii(sampleTorusRandom(2500, 1.0f, 0.35f, 9));
    auto first = NodeTree::create(input, smallNodes());
    auto second = NodeTree::create(input, smallNodes());
    ASSERT_TRUE(first && second);
    refineEverywhere(*first, 3);
    // The second tree: a shuffled order, with a detour: refined to 2, half of the level-1 nodes'
    // children released, then on to 3 in another order.
    refineEverywhere(*second, 2, 77);
    std::size_t released = 0;
    for (NodeId id = 0; id < second->slotCount(); ++id) {
        if (!second->isLive(id) || second->node(id).level != 1 || second->node(id).isLeaf()) continue;
        const auto children = second->node(id).childIds();
        if (id % 2 == 0 && std::all_of(children.begin(), children.end(),
                                       [&](NodeId c) { return second->node(c).isLeaf(); })) {
            second->release(id);
            ++released;
        }
    }
    EXPECT_GT(released, 3u);
    refineEverywhere(*second, 3, 78);
    for (std::uint32_t level = 0; level <= 3; ++level) {
        const auto a = pointsOfLevel(*first, level), b = pointsOfLevel(*second, level);
        EXPECT_EQ(a.size(), b.size()) << "level " << level;
        EXPECT_TRUE(a == b) << "level " << level << " differs";
    }
}

// The radii a node's splats are measured and drawn with reach every node, the roots and the
// children of jobs: one per point, none above the point's own radius (the refinement's; the
// input's for the roots), and most below it (the sixth nearest lies nearer than the refinement's
// radius, which reaches the farthest member of the next one-ring: node_tree.h, splatRadius).
TEST(NodeTree, NodesCarryTheRadiiTheirSplatsAreDrawnWith) {
    auto tree = NodeTree::create(withRadii(sampleSphereRandom(3000, 1.0f, 5)), smallNodes());
    ASSERT_TRUE(tree);
    refineEverywhere(*tree, 2);
    std::size_t smaller = 0, points = 0, levels = 0;
    for (NodeId id = 0; id < tree->slotCount(); ++id) {
        if (!tree->isLive(id)) continue;
        const Node& node = tree->node(id);
        ASSERT_EQ(node.shape.splatRadius.size(), node.points.size()) << "node " << id;
        for (std::size_t i = 0; i < node.points.size(); ++i) {
            EXPECT_LE(node.shape.splatRadius[i], node.points.radius[i]) << "node " << id;
            smaller += node.shape.splatRadius[i] < node.points.radius[i];
        }
        points += node.points.size();
        levels = std::max<std::size_t>(levels, node.level + 1);
    }
    EXPECT_EQ(levels, 3u);
    EXPECT_GT(smaller, points / 2) << "the splats are drawn with the refinement's radii";
}

// Acceptance 3 of the real-time issue: where neighbouring nodes sit at different levels, every
// point of level l+1 is made from points of P(l) only. The parents recorded by the refinement are
// checked against the points of the level-l nodes (an independent record: the tree's own nodes).
TEST(NodeTree, LevelsStaySeparatedAcrossNodesOfDifferentLevels) {
    const PointSet input = withRadii(sampleSphereRandom(2000, 1.0f, 21));
    auto tree = NodeTree::create(input, smallNodes());
    ASSERT_TRUE(tree);
    // Refine the nodes near +x three levels deep, the rest stays coarser: a node is refined when
    // its box reaches x > 0.4 (blockers first, which refines some neighbours one level).
    std::size_t checked = 0, mixedNeighbourhoods = 0;
    for (std::uint32_t round = 0; round < 40; ++round) {
        std::vector<NodeId> wanted;
        for (NodeId id = 0; id < tree->slotCount(); ++id)
            if (tree->isLive(id) && tree->node(id).isLeaf() && tree->node(id).hi.x > 0.4f &&
                tree->node(id).level < 3)
                wanted.push_back(id);
        if (wanted.empty()) break;
        for (const NodeId id : wanted) {
            std::vector<NodeId> blockers;
            if (!tree->isLive(id) || !tree->node(id).isLeaf()) continue;
            const NodeId target = tree->ready(id, blockers) ? id : blockers.front();
            std::vector<NodeId> none;
            if (!tree->ready(target, none)) continue; // its own blockers come in a later round
            const std::uint32_t level = tree->node(target).level;
            // P(level) and P(level + 1) as the tree holds them now.
            std::set<Key> levelPoints, finer;
            std::set<std::uint32_t> levelsNear;
            for (NodeId n = 0; n < tree->slotCount(); ++n) {
                if (!tree->isLive(n)) continue;
                for (const glm::vec3 p : tree->node(n).points.position)
                    (tree->node(n).level == level ? levelPoints : finer).insert(keyOf(p));
                if (tree->node(n).isLeaf()) levelsNear.insert(tree->node(n).level);
            }
            mixedNeighbourhoods += levelsNear.size() > 1;
            NodeJobResult result = NodeTree::run(tree->makeJob(target, true), tree->settings());
            std::size_t newPoints = 0;
            for (const NodeChild& child : result.children) newPoints += child.points.size();
            newPoints -= tree->node(target).points.size();
            ASSERT_EQ(result.parents.size(), newPoints);
            for (const auto& corners : result.parents) {
                for (const glm::vec3 c : corners) {
                    EXPECT_TRUE(levelPoints.count(keyOf(c)) == 1) << "a parent not of P(" << level << ")";
                    ++checked;
                }
            }
            ASSERT_TRUE(tree->attach(std::move(result)));
        }
    }
    std::set<std::uint32_t> leafLevels;
    for (NodeId n = 0; n < tree->slotCount(); ++n)
        if (tree->isLive(n) && tree->node(n).isLeaf()) leafLevels.insert(tree->node(n).level);
    EXPECT_GE(leafLevels.size(), 3u) << "the test needs leaves of several levels side by side";
    EXPECT_GT(mixedNeighbourhoods, 0u);
    EXPECT_GT(checked, 10000u);
}

// The oracle of a splat's radius drawn (node_tree.h, splatRadius), exact in double: the farthest
// corner of the point's Voronoi cell among `neighbours` in its tangent plane, kCellMargin times
// that, at most the distance to the farthest neighbour and the point's radius. The cell is open
// (infinite) where the neighbours' directions leave a half-plane free; else its corners are the
// points where two bisectors meet that no other bisector cuts off.
float splatRadiusOracle(glm::vec3 point, glm::vec3 normal, float radius,
                        std::span<const glm::vec3> neighbours) {
    const glm::dvec3 n = glm::normalize(glm::dvec3(normal));
    const glm::dvec3 u =
        glm::normalize(glm::cross(n, std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0)));
    const glm::dvec3 v = glm::cross(n, u);
    double farthest = 0.0;
    std::vector<glm::dvec2> projected;
    std::vector<double> angles;
    for (const glm::vec3& q : neighbours) {
        const glm::dvec3 d = glm::dvec3(q) - glm::dvec3(point);
        farthest = std::max(farthest, glm::length(d));
        projected.push_back({glm::dot(d, u), glm::dot(d, v)});
        angles.push_back(std::atan2(projected.back().y, projected.back().x));
    }
    std::sort(angles.begin(), angles.end());
    double widestGap = angles.front() + 2.0 * std::numbers::pi - angles.back();
    for (std::size_t k = 1; k < angles.size(); ++k)
        widestGap = std::max(widestGap, angles[k] - angles[k - 1]);
    double cell = std::numeric_limits<double>::infinity();
    if (widestGap < std::numbers::pi) {
        cell = 0.0;
        for (std::size_t a = 0; a < projected.size(); ++a)
            for (std::size_t b = a + 1; b < projected.size(); ++b) {
                // x · q = |q|² / 2 for both: two lines.
                const glm::dvec2 qa = projected[a], qb = projected[b];
                const double det = qa.x * qb.y - qa.y * qb.x;
                if (std::abs(det) < 1e-12 * glm::dot(qa, qa) * glm::dot(qb, qb)) continue; // parallel
                const double ha = 0.5 * glm::dot(qa, qa), hb = 0.5 * glm::dot(qb, qb);
                const glm::dvec2 corner((ha * qb.y - hb * qa.y) / det, (qa.x * hb - qb.x * ha) / det);
                bool inside = true;
                for (const glm::dvec2 q : projected)
                    inside = inside && glm::dot(corner, q) <= 0.5 * glm::dot(q, q) * (1.0 + 1e-9);
                if (inside) cell = std::max(cell, glm::length(corner));
            }
    }
    return float(std::min({double(radius), farthest, double(kCellMargin) * cell}));
}

// neighbourShapeOf (the engine's measure of the silhouette and its splats' radii, engine.cpp): per
// point the largest angle between its normal and those of its kBendNeighbours nearest points, and
// the radius that covers its cell among them (splatRadiusOracle), against a brute-force search on a
// random sphere (whose bends are then about the angle the 6th neighbour subtends) and a plane.
TEST(NodeDetail, BendIsTheWidestNormalAngleToTheNearestPoints) {
    PointSet sphere = sampleSphereRandom(1500, 2.0f, 7);
    sphere.radius.assign(sphere.size(), 1.0f);                                   // beyond the 6th point
    for (std::size_t i = 0; i < sphere.size(); i += 2) sphere.radius[i] = 0.01f; // below its spacing
    const NeighbourShape shape = neighbourShapeOf(sphere);
    const std::vector<float>& bend = shape.bend;
    ASSERT_EQ(bend.size(), sphere.size());
    ASSERT_EQ(shape.splatRadius.size(), sphere.size());
    std::size_t smaller = 0, cellLimited = 0;
    std::vector<std::pair<float, std::size_t>> byDistance;
    for (std::size_t i = 0; i < sphere.size(); ++i) {
        byDistance.clear();
        for (std::size_t j = 0; j < sphere.size(); ++j)
            if (j != i) byDistance.push_back({glm::distance(sphere.position[i], sphere.position[j]), j});
        std::partial_sort(byDistance.begin(), byDistance.begin() + kBendNeighbours, byDistance.end());
        float lowest = 1.0f;
        for (std::size_t k = 0; k < kBendNeighbours; ++k)
            lowest = std::min(lowest, glm::dot(sphere.normal[i], sphere.normal[byDistance[k].second]));
        ASSERT_NEAR(bend[i], std::acos(std::clamp(lowest, -1.0f, 1.0f)), 1e-4f) << "point " << i;
        // On a sphere of radius 2 the normals turn by the angle the farthest neighbour subtends.
        const float subtended = 2.0f * std::asin(byDistance[kBendNeighbours - 1].first / 4.0f);
        ASSERT_NEAR(bend[i], subtended, 2e-3f) << "point " << i;
        std::array<glm::vec3, kBendNeighbours> nearest;
        for (std::size_t k = 0; k < kBendNeighbours; ++k) nearest[k] = sphere.position[byDistance[k].second];
        const float expected =
            splatRadiusOracle(sphere.position[i], sphere.normal[i], sphere.radius[i], nearest);
        ASSERT_NEAR(shape.splatRadius[i], expected, 1e-4f * expected) << "point " << i;
        smaller += shape.splatRadius[i] < sphere.radius[i];
        const float farthest = byDistance[kBendNeighbours - 1].first;
        cellLimited += expected < std::min(sphere.radius[i], farthest) * (1.0f - 1e-4f);
    }
    EXPECT_EQ(smaller, sphere.size() - sphere.size() / 2); // the points of radius 1
    EXPECT_GT(cellLimited, 100u) << "points whose splat their cell decides";
    PointSet plane;
    for (int y = 0; y < 20; ++y)
        for (int x = 0; x < 20; ++x) {
            plane.position.push_back({0.1f * float(x), 0.1f * float(y), 0.0f});
            plane.normal.push_back({0.0f, 0.0f, 1.0f});
        }
    for (const float b : neighbourShapeOf(plane).bend) EXPECT_EQ(b, 0.0f);
    EXPECT_TRUE(neighbourShapeOf(PointSet{}).bend.empty());
}

// The splats of an even sampling cover their cells and no more: on a hexagonal lattice of spacing
// h a point's cell is a hexagon of circumradius h / √3, on a square lattice a square of h / √2, and
// its splat kCellMargin times that; a point on the patch's border, whose cell is open, keeps the
// distance to its 6th nearest point.
TEST(NodeDetail, SplatsOfALatticeCoverTheirCells) {
    constexpr float h = 0.1f;
    constexpr int n = 16;
    for (const bool hexagonal : {true, false}) {
        PointSet plane;
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x) {
                const float shift = hexagonal && y % 2 == 1 ? 0.5f * h : 0.0f;
                const float row = hexagonal ? 0.5f * std::numbers::sqrt3_v<float> * h : h;
                plane.position.push_back({shift + h * float(x), row * float(y), 0.0f});
                plane.normal.push_back({0.0f, 0.0f, 1.0f});
            }
        plane.radius.assign(plane.size(), 1.0f); // beyond every neighbour
        const NeighbourShape shape = neighbourShapeOf(plane);
        const float cell = hexagonal ? h / std::numbers::sqrt3_v<float> : h / std::numbers::sqrt2_v<float>;
        for (int y = 2; y < n - 2; ++y)
            for (int x = 2; x < n - 2; ++x)
                ASSERT_NEAR(shape.splatRadius[std::size_t(y * n + x)], kCellMargin * cell, 1e-4f * h)
                    << (hexagonal ? "hexagonal" : "square") << " lattice, point " << x << ", " << y;
        // A corner: its 6 nearest lie on one side, and its cell is open.
        std::vector<float> distances;
        for (std::size_t j = 1; j < plane.size(); ++j)
            distances.push_back(glm::distance(plane.position[0], plane.position[j]));
        std::nth_element(distances.begin(), distances.begin() + kBendNeighbours - 1, distances.end());
        EXPECT_FLOAT_EQ(shape.splatRadius[0], distances[kBendNeighbours - 1]);
    }
}

// With a region, the cells are cut to it as well (a root's shapes, NodeTree::create): the splats of
// the points in a region cover it up to its faces whatever lies beyond. A square lattice of spacing h
// whose region ends 0.99 h past its last column: measured among the whole lattice, the last
// column's cells end at the bisector 0.5 h past it, their splats reach about kCellMargin · h / √2
// (1.06 h) from their centre, and the slivers beyond, between the rows, in the region, are left to
// the points across the face (which a root drawn beside nodes drawn deeper does not have: holes);
// measured among the region's points with the region, it is covered, the last column's splats
// reaching past the face by the margin only (open, their cells would reach the 6th nearest), and
// the points whose cells do not reach the face keep their splats.
TEST(NodeDetail, SplatsOfARegionCoverItUpToItsFaces) {
    constexpr float h = 0.1f;
    constexpr int n = 16;
    PointSet plane;
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            plane.position.push_back({h * float(x), h * float(y), 0.0f});
            plane.normal.push_back({0.0f, 0.0f, 1.0f});
        }
    plane.radius.assign(plane.size(), 1.0f); // beyond every neighbour
    constexpr int inside = 8;                // the columns x < 8 lie in the region
    Region region;
    region.hi.x = h * (float(inside - 1) + 0.99f);
    PointSet own;
    std::vector<std::size_t> ownIndex;
    for (std::size_t i = 0; i < plane.size(); ++i)
        if (region.contains(plane.position[i])) {
            own.appendFrom(plane, i);
            ownIndex.push_back(i);
        }
    const NeighbourShape whole = neighbourShapeOf(plane);
    const NeighbourShape cut = neighbourShapeOf(own, nullptr, &region);
    // The uncovered samples of the region's inner rows, x from 2 h to its face.
    const auto uncovered = [&](const std::vector<float>& radius) {
        std::size_t count = 0;
        for (float y = 3.0f * h; y <= 12.0f * h; y += 0.05f * h)
            for (float x = 2.0f * h; x < region.hi.x; x += 0.05f * h) {
                bool covered = false;
                for (std::size_t k = 0; k < own.size() && !covered; ++k)
                    covered = glm::distance(glm::vec3(x, y, 0.0f), own.position[k]) <= radius[k];
                count += covered ? 0 : 1;
            }
        return count;
    };
    std::vector<float> wholeOfOwn;
    for (const std::size_t i : ownIndex) wholeOfOwn.push_back(whole.splatRadius[i]);
    EXPECT_GT(uncovered(wholeOfOwn), 0u) << "the lattice shows nothing: its splats reach the face";
    EXPECT_EQ(uncovered(cut.splatRadius), 0u);
    // Among the region's points alone, the last column's cells would be open, their splats the
    // distance to their 6th nearest (2 h); cut to the face, kCellMargin times √(0.99² + 0.5²) h.
    const NeighbourShape open = neighbourShapeOf(own);
    for (std::size_t k = 0; k < own.size(); ++k) {
        const glm::vec3 p = own.position[k];
        if (p.y < 2.0f * h || p.y > 13.0f * h) continue;
        if (p.x > 6.5f * h) {
            EXPECT_NEAR(cut.splatRadius[k], kCellMargin * std::hypot(0.99f, 0.5f) * h, 1e-4f * h);
            EXPECT_NEAR(open.splatRadius[k], 2.0f * h, 1e-4f * h);
        } else if (p.x >= 2.0f * h && p.x <= 5.0f * h) {
            EXPECT_FLOAT_EQ(cut.splatRadius[k], wholeOfOwn[k]) << "an inner point at " << p.x << ", " << p.y;
        }
    }
}

// Neighbours within about 2e-7 times the 6th nearest's distance of a point can cut its cell to
// nothing in float (its true cell holds it strictly; these do, found by a random search): its splat
// keeps the distance to the 6th nearest, and no later cut reads a corner of the empty cell (a read
// before the corners' buffer, found by review, which the sanitizer suite would report).
TEST(NodeDetail, NeighboursNearlyOnThePointKeepItsSplat) {
    PointSet points;
    points.position = {{0.0f, 0.0f, 0.0f},
                       {-1.24398412e-08f, 1.43608929e-08f, 0.0f},
                       {2.96245162e-08f, 2.81090706e-08f, 0.0f},
                       {-5.83588502e-08f, -8.92814711e-08f, 0.0f},
                       {1.74625825e-07f, 1.20785273e-07f, 0.0f},
                       {0.544317484f, 0.449011326f, 0.0f},
                       {-0.78823185f, -0.991201758f, 0.0f}};
    points.normal.assign(points.size(), glm::vec3(0.0f, 0.0f, 1.0f));
    points.radius.assign(points.size(), 10.0f); // beyond every neighbour
    const NeighbourShape shape = neighbourShapeOf(points);
    float sixth = 0.0f;
    for (std::size_t j = 1; j < points.size(); ++j) sixth = std::max(sixth, glm::length(points.position[j]));
    EXPECT_FLOAT_EQ(shape.splatRadius[0], sixth);
    for (const float r : shape.splatRadius) EXPECT_TRUE(std::isfinite(r) && r > 0.0f) << r;
}

// neighbourShapeOf's nearest points (a grid searched cell block by cell block, node_tree.cpp) are exactly a
// brute-force search's, ties in distance to the lower index: random normals make the widest
// angle depend on which points are taken. A plane grid (every distance tied many times over), and
// a sphere with a dense cluster and far, isolated points (their nearest lie beyond the cells
// around them, which the search must widen to, up to the whole grid), a crowd in one cell of a
// sparse sphere, with ties (searched in a finer grid), and points spread past the
// largest float (render of such a model failed with "cannot create std::vector larger than
// max_size()" before its one-line error).
TEST(NodeDetail, BendTakesExactlyTheNearestPointsTiesByIndex) {
    std::mt19937 random(11);
    std::normal_distribution<float> gauss;
    const auto randomNormal = [&] {
        return glm::normalize(glm::vec3(gauss(random), gauss(random), gauss(random)) + glm::vec3(1e-6f));
    };
    PointSet plane, clustered = sampleSphereRandom(2000, 1.0f, 5);
    for (int y = 0; y < 30; ++y)
        for (int x = 0; x < 30; ++x) plane.position.push_back({0.1f * float(x), 0.1f * float(y), 0.0f});
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    for (int k = 0; k < 500; ++k)
        clustered.position.push_back(glm::vec3(0.0f, 0.0f, 1.0f) +
                                     0.01f * glm::vec3(unit(random), unit(random), unit(random)));
    for (int k = 0; k < 5; ++k)
        clustered.position.push_back(glm::vec3(10.0f + 10.0f * float(k), 0.0f, -3.0f * float(k)));
    // Coordinates near the largest float: the grid's extent passes it (distances overflow to
    // infinity, tied by index like any other).
    PointSet huge;
    for (const float x : {-3e38f, 3e38f, 0.0f, 1.0f, 2.0f})
        for (const float y : {-3e38f, 0.0f, 3e38f}) huge.position.push_back({x, y, 0.5f * x});
    // Points on a line, in a grid a million cells long: the last point's nearest lie about 1,000 away
    // on either side, 999,999.375 squared in single precision both ways, the 7 at +z first by index
    // (and truly nearer). Searched with a margin of a thousandth of a cell alone, rounding hid them
    // and the far side's 7 were taken (a review's case; its bend then π/2).
    PointSet line;
    for (int k = 0; k < 7; ++k) line.position.push_back({0.0f, 0.0f, 999.99939f});
    for (int k = 0; k < 12000; ++k) line.position.push_back({0.0f, 0.0f, -1000.0f});
    line.position.push_back({0.0f, 0.0f, -0.0003f});
    line.normal.assign(line.size(), glm::vec3(0.0f, 0.0f, 1.0f));
    std::fill_n(line.normal.begin(), 7, glm::vec3(1.0f, 0.0f, 0.0f));
    line.normal.back() = glm::vec3(1.0f, 0.0f, 0.0f);
    EXPECT_EQ(neighbourShapeOf(line).bend.back(), 0.0f); // the 7 at +z, whose normals are its own
    // A crowd in one cell amid a sparse sphere (a scan's near field): 2,500 random points and a
    // lattice of 8 × 8 × 8 (distances tied) within 0.002 of the pole, the cell's points searched in
    // a finer grid of their own.
    PointSet crowded = sampleSphereRandom(1000, 1.0f, 9);
    for (int k = 0; k < 2500; ++k)
        crowded.position.push_back(glm::vec3(0.0f, 0.0f, 1.0f) +
                                   0.001f * glm::vec3(unit(random), unit(random), 0.1f * unit(random)));
    for (int z = 0; z < 8; ++z)
        for (int y = 0; y < 8; ++y)
            for (int x = 0; x < 8; ++x)
                crowded.position.push_back(glm::vec3(0.0f, 0.0f, 1.0f) +
                                           0.0002f * glm::vec3(float(x), float(y), float(z)));
    // Four crowds of 1,100 points within 1e-4, each with 60 points 0.02 to 0.1 away, amid sparse
    // points: each crowd's cell, with the points about it that share it, searched in a finer grid.
    for (int c = 0; c < 4; ++c) {
        const glm::vec3 centre(unit(random), unit(random), unit(random));
        for (int k = 0; k < 1100; ++k)
            crowded.position.push_back(centre + 1e-4f * glm::vec3(unit(random), unit(random), unit(random)));
        for (int k = 0; k < 60; ++k) {
            const glm::vec3 away(unit(random), unit(random), unit(random));
            crowded.position.push_back(centre + (0.02f + 0.08f * std::abs(unit(random))) *
                                                    glm::normalize(away + glm::vec3(1e-6f)));
        }
    }
    for (int k = 0; k < 400; ++k)
        crowded.position.push_back(glm::vec3(unit(random), unit(random), unit(random)));
    // A crowd whose cell holds a point nearer to 7 points beyond its cell's 3×3×3 than to the crowd
    // (a review's construction): an 11³ lattice at spacing 0.1 hollowed inside (0.2, 0.8)³ sizes the
    // grid's cells (0.09), a crowd of 1,100 points at spacing 1e-4 from 0.455 and the point at
    // 0.536 share a cell, and the 7 lie 0.1 from the point in the cell two over. The finer grid of
    // the crowd's cells finds the crowd; the search must widen.
    PointSet hollow;
    for (int z = 0; z <= 10; ++z)
        for (int y = 0; y <= 10; ++y)
            for (int x = 0; x <= 10; ++x) {
                const glm::vec3 q = 0.1f * glm::vec3(float(x), float(y), float(z));
                if (glm::all(glm::greaterThan(q, glm::vec3(0.2001f))) &&
                    glm::all(glm::lessThan(q, glm::vec3(0.7999f))))
                    continue;
                hollow.position.push_back(q);
            }
    for (int z = 0; z < 10; ++z)
        for (int y = 0; y < 10; ++y)
            for (int x = 0; x < 11; ++x)
                hollow.position.push_back(glm::vec3(0.455f) +
                                          1e-4f * glm::vec3(float(x), float(y), float(z)));
    hollow.position.push_back(glm::vec3(0.536f));
    for (int k = 0; k < 7; ++k) hollow.position.push_back({0.636f, 0.536f + 1e-4f * float(k), 0.536f});
    for (PointSet* set : {&plane, &clustered, &huge, &crowded, &hollow}) {
        set->normal.resize(set->position.size());
        for (glm::vec3& n : set->normal) n = randomNormal();
        const std::vector<float> bend = neighbourShapeOf(*set).bend;
        ASSERT_EQ(bend.size(), set->size());
        std::vector<std::pair<float, std::size_t>> byDistance;
        for (std::size_t i = 0; i < set->size(); ++i) {
            byDistance.clear();
            for (std::size_t j = 0; j < set->size(); ++j) {
                const glm::vec3 d = set->position[j] - set->position[i];
                byDistance.push_back({glm::dot(d, d), j});
            }
            std::partial_sort(byDistance.begin(), byDistance.begin() + kBendNeighbours + 1, byDistance.end());
            float lowest = 1.0f;
            for (std::size_t k = 0; k <= kBendNeighbours; ++k)
                lowest = std::min(lowest, glm::dot(set->normal[i], set->normal[byDistance[k].second]));
            ASSERT_EQ(bend[i], std::acos(std::clamp(lowest, -1.0f, 1.0f)))
                << "point " << i << " of " << set->size();
        }
    }
}

// neighbourShapeOf on a pool (the whole levels' shapes, NodeTree::create) splits the grid's cells into
// ranges of columns that workers take in any order: every point's nearest are found exactly, so the
// shape is the one thread's bit for bit, whatever the thread count (a range skipped leaves bends of
// zero and radii not shrunk; two workers on one range are TSan's to find).
TEST(NodeDetail, ShapeOnWorkersIsTheSameAsOnOneThread) {
    std::mt19937 random(17);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    PointSet sphere = sampleSphereRandom(20000, 1.0f, 3);
    for (int k = 0; k < 2000; ++k) { // a dense cluster: columns of unlike counts
        sphere.position.push_back(glm::vec3(0.0f, 0.0f, 1.0f) +
                                  0.02f * glm::vec3(unit(random), unit(random), unit(random)));
        sphere.normal.push_back(glm::normalize(glm::vec3(unit(random), unit(random), 1.0f)));
    }
    PointSet wall; // flat across x: one cell thick there, its work split along y
    for (int k = 0; k < 20000; ++k) {
        wall.position.push_back({0.0f, unit(random), unit(random)});
        wall.normal.push_back(glm::normalize(glm::vec3(1.0f, 0.5f * unit(random), 0.5f * unit(random))));
    }
    for (PointSet* set : {&sphere, &wall}) {
        set->radius.assign(set->size(), 0.05f);
        const NeighbourShape one = neighbourShapeOf(*set);
        ASSERT_GT(std::ranges::count_if(one.bend, [](float b) { return b > 0.0f; }), 19000);
        for (const unsigned threads : {2u, 3u, 5u}) {
            WorkerPool pool(threads);
            const NeighbourShape many = neighbourShapeOf(*set, &pool);
            EXPECT_EQ(many.bend, one.bend) << threads << " threads, " << set->size() << " points";
            EXPECT_EQ(many.splatRadius, one.splatRadius)
                << threads << " threads, " << set->size() << " points";
        }
    }
}

// medianRadiiOf, which settles the engine's median test for a node in full view (engine.cpp): more
// than half of the radii are at least the first, at most half exceed the second.
TEST(NodeDetail, MedianRadiiBoundTheMedianSplat) {
    EXPECT_EQ(medianRadiiOf(std::vector<float>{3.0f, 1.0f, 2.0f}), (std::array<float, 2>{2.0f, 2.0f}));
    EXPECT_EQ(medianRadiiOf(std::vector<float>{4.0f, 1.0f, 3.0f, 2.0f}), (std::array<float, 2>{2.0f, 3.0f}));
    EXPECT_EQ(medianRadiiOf(std::vector<float>{5.0f}), (std::array<float, 2>{5.0f, 5.0f}));
    EXPECT_EQ(medianRadiiOf(std::vector<float>{}), (std::array<float, 2>{0.0f, 0.0f}));
    std::mt19937_64 random(11);
    for (std::size_t n = 1; n < 40; ++n) {
        std::vector<float> radii(n);
        for (float& r : radii) r = float(random() % 7); // ties
        const auto [low, high] = medianRadiiOf(radii);
        EXPECT_GT(2 * std::ranges::count_if(radii, [&](float r) { return r >= low; }), std::ptrdiff_t(n));
        EXPECT_LE(2 * std::ranges::count_if(radii, [&](float r) { return r > high; }), std::ptrdiff_t(n));
    }
}

} // namespace
} // namespace pnsplat
