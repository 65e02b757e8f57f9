// The frame's selection of nodes (selection.h), without a device: culling, the level of detail and
// its hysteresis, the order of what is wanted, the facing classes, the measure of the splats drawn.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <vector>

#include "pnsplat/engine/selection.h"
#include "pnsplat/refine/input.h"
#include "pnsplat/refine/node_tree.h"
#include "pnsplat/refine/shapes/shapes.h"

using namespace pnsplat;
using namespace pnsplat::engine;

namespace {

constexpr std::uint32_t kWidth = 320, kHeight = 240;

// The unit sphere (3,000 random points, radii estimated) in nodes of at most 256 points, refined
// `levels` levels everywhere.
NodeTree sphereTree(std::uint32_t levels) {
    PointSet sphere = sampleSphereRandom(3000, 1.0f, 11);
    EXPECT_TRUE(completeInput(sphere, 2).ok());
    NodeSettings settings;
    settings.maxNodePoints = 256;
    NodeTree tree = NodeTree::create(std::move(sphere), settings).value();
    for (bool changed = true; changed;) {
        changed = false;
        for (NodeId id = 0; id < tree.slotCount(); ++id) {
            std::vector<NodeId> blockers;
            if (!tree.isLive(id) || tree.node(id).level >= levels || !tree.ready(id, blockers)) continue;
            EXPECT_TRUE(tree.attach(NodeTree::run(tree.makeJob(id), tree.settings())));
            changed = true;
        }
    }
    return tree;
}

// Every live node resident, its facing classes counted from its points (as the engine packs them).
std::vector<NodeSelection> allResident(const NodeTree& tree) {
    std::vector<NodeSelection> states(tree.slotCount());
    for (NodeId id = 0; id < tree.slotCount(); ++id) {
        if (!tree.isLive(id)) continue;
        ClassStarts& classes = states[id].classes;
        for (const glm::vec3 n : tree.node(id).points.normal) {
            ++classes[facingClass(n) + 1];
            states[id].pointClass.push_back(static_cast<std::uint8_t>(facingClass(n)));
        }
        for (std::uint32_t c = 0; c < kFacingClasses; ++c) classes[c + 1] += classes[c];
        states[id].resident = true;
    }
    return states;
}

FrameView viewFrom(float distance, float radiusScale = 1.0f) {
    Camera camera;
    camera.eye = {0.0f, 0.0f, distance};
    return frameView(camera, kWidth, kHeight, radiusScale, {glm::vec3(0.0f), 1.2f});
}

SelectionSettings thresholdOf(float px) {
    SelectionSettings s;
    s.threshold = px;
    s.asked = 1.0f; // fixed, as the engine's asked threshold while the one in force moves
    return s;
}

Selection run(const NodeTree& tree, const FrameView& view, const SelectionSettings& settings,
              std::uint64_t stamp, std::vector<NodeSelection>& states) {
    return selectNodes(tree, view, settings, stamp, [&](NodeId id) -> NodeSelection& { return states[id]; });
}

// The nodes a walk of frame `stamp` drew through their children.
std::set<NodeId> descendedIn(const std::vector<NodeSelection>& states, std::uint64_t stamp) {
    std::set<NodeId> out;
    for (NodeId id = 0; id < states.size(); ++id)
        if (states[id].descended && states[id].lastVisited == stamp) out.insert(id);
    return out;
}

} // namespace

TEST(Selection, AFarCameraDrawsTheRootsAndAsksForNothing) {
    const NodeTree tree = sphereTree(1);
    std::vector<NodeSelection> states = allResident(tree);
    const Selection s = run(tree, viewFrom(200.0f), thresholdOf(3.0f), 1, states);
    EXPECT_TRUE(s.refine.empty());
    EXPECT_TRUE(s.upload.empty());
    ASSERT_FALSE(s.draw.empty());
    for (const NodeId id : s.draw) EXPECT_EQ(tree.node(id).level, 0u);
    EXPECT_LT(s.draw.size(), tree.roots().size()) << "the roots on the far side face away";
}

// A node too coarse is drawn itself until every visible child is resident (they are wanted for
// upload, coarsest level then largest first), then through them; a leaf too coarse is wanted
// refined, unless the engine is not adaptive.
TEST(Selection, ChildrenAreDrawnOnceResidentAndCoarseLeavesAreWantedRefined) {
    const NodeTree tree = sphereTree(1);
    std::vector<NodeSelection> states = allResident(tree);
    for (NodeId id = 0; id < tree.slotCount(); ++id)
        if (tree.isLive(id) && tree.node(id).level > 0) states[id].resident = false;
    const FrameView close = viewFrom(2.5f);
    const Selection before = run(tree, close, thresholdOf(1.0f), 1, states);
    ASSERT_FALSE(before.upload.empty());
    for (const NodeId id : before.draw) EXPECT_EQ(tree.node(id).level, 0u);
    for (const WantedNode& w : before.upload) EXPECT_EQ(tree.node(w.node).level, 1u);
    EXPECT_TRUE(std::is_sorted(before.upload.begin(), before.upload.end(), [](const auto& a, const auto& b) {
        return a.level != b.level ? a.level < b.level : a.size > b.size;
    }));

    for (const WantedNode& w : before.upload) states[w.node].resident = true;
    const Selection after = run(tree, close, thresholdOf(1.0f), 2, states);
    EXPECT_TRUE(after.upload.empty());
    std::size_t children = 0;
    for (const NodeId id : after.draw) children += tree.node(id).level == 1 ? 1 : 0;
    EXPECT_GT(children, 0u);
    EXPECT_FALSE(after.refine.empty()) << "the level-1 leaves are too coarse for 1 px this close";
    for (const WantedNode& w : after.refine) EXPECT_TRUE(tree.node(w.node).isLeaf());

    SelectionSettings fixed = thresholdOf(1.0f);
    fixed.adaptive = false;
    EXPECT_TRUE(run(tree, close, fixed, 3, states).refine.empty());
}

// The level of detail against the rule written out splat by splat (selection.cpp): a node is drawn
// through its children while more than half of its splats drawn are wider than the threshold in
// force T, or while more than a tenth of those within acos(0.3) of edge-on (at least 4) stand out by
// more than 0.2 px · sqrt(T / asked) and are wider than 1 px, if more than half of them are wider
// than asked / √3 (at most a level past the median at the threshold asked). Each root of the sphere, first
// seen (no hysteresis), at thresholds raised from the one asked; the cases where the silhouettes decide
// differently from a median alone, from a bulge limit that grows with T / asked itself, and from
// the silhouettes without the level's bound are counted so that the test shows something.
TEST(Selection, TheLevelOfDetailIsTheMedianAndTheSilhouettesCoarsenedByTheSquareRootOfTheRise) {
    const NodeTree tree = sphereTree(1);
    const auto rule = [](const FrameView& view, const Node& node, float threshold, float asked,
                         float bulgeLimit) {
        std::size_t drawn = 0, over = 0, coarse = 0, rim = 0, rimOver = 0;
        for (std::size_t i = 0; i < node.points.size(); ++i) {
            const glm::vec3 d = node.points.position[i] - view.camera.eye;
            const float depth = glm::dot(d, view.forward);
            const float facing = -glm::dot(node.points.normal[i], d);
            if (!(depth > view.frustum.range.near && facing > 0.0f &&
                  std::abs(glm::dot(d, view.right)) <= view.frustum.tanX * depth &&
                  std::abs(glm::dot(d, view.upward)) <= view.frustum.tanY * depth))
                continue;
            const float px = 2.0f * node.shape.splatRadius[i] * view.focal / depth;
            ++drawn;
            over += px > threshold;
            coarse += px * std::sqrt(3.0f) > asked; // wider than a level past the asked median would draw it
            if (facing < 0.3f * glm::length(d)) {
                ++rim;
                rimOver += px * node.shape.bend[i] / 4.0f > bulgeLimit && px > 1.0f;
            }
        }
        const bool silhouette = rim >= 4 && double(rimOver) > 0.1 * double(rim);
        return std::array<bool, 3>{double(over) > 0.5 * double(drawn),
                                   silhouette && double(coarse) > 0.5 * double(drawn), silhouette};
    };
    std::size_t roots = 0, bySilhouette = 0, bySquareRoot = 0, stoppedALevelPast = 0;
    for (const float distance : {2.2f, 6.0f, 12.0f, 24.0f})
        for (const float asked : {0.5f, 1.0f, 2.0f, 4.0f, 8.0f, 16.0f, 32.0f})
            for (const float rise : {1.0f, 1.5f, 2.0f, 3.0f, 4.0f}) {
                const FrameView view = viewFrom(distance);
                SelectionSettings settings = thresholdOf(asked * rise);
                settings.asked = asked;
                std::vector<NodeSelection> states = allResident(tree);
                run(tree, view, settings, 1, states);
                for (const NodeId id : tree.roots()) {
                    if (states[id].lastVisited != 1) continue; // culled
                    const Node& node = tree.node(id);
                    const auto [median, silhouette, uncapped] =
                        rule(view, node, asked * rise, asked, 0.2f * std::sqrt(rise));
                    EXPECT_EQ(states[id].descended, median || silhouette)
                        << "root " << id << " from " << distance << " at " << asked * rise << " px, asked "
                        << asked;
                    ++roots;
                    bySilhouette += silhouette && !median;
                    bySquareRoot +=
                        !median && silhouette != rule(view, node, asked * rise, asked, 0.2f * rise)[1];
                    stoppedALevelPast += uncapped && !silhouette && !median;
                }
            }
    EXPECT_GT(roots, 0u);
    EXPECT_GT(stoppedALevelPast, 0u)
        << "no root whose silhouette the median a level finer stops: the test shows nothing";
    EXPECT_GT(bySilhouette, 0u) << "no root refined for its silhouette alone: the test shows nothing";
    EXPECT_GT(bySquareRoot, 0u) << "no root where the square root decides: the test shows nothing";
}

// Frame 2 at a coarser threshold T keeps a node that frame 1 drew through its children while its
// splats pass the test at hysteresis × T; a node not seen in the frame before decides afresh.
TEST(Selection, HysteresisHoldsOnlyForNodesSeenInTheLastFrame) {
    const NodeTree tree = sphereTree(1);
    const FrameView close = viewFrom(3.0f);
    const auto fresh = [&](float px) {
        std::vector<NodeSelection> states = allResident(tree);
        run(tree, close, thresholdOf(px), 1, states);
        return descendedIn(states, 1);
    };
    bool held = false;
    for (float first = 0.5f; first < 30.0f; first *= 1.15f) {
        const float second = first / 0.9f;
        std::vector<NodeSelection> states = allResident(tree);
        run(tree, close, thresholdOf(first), 1, states);
        const std::set<NodeId> d1 = descendedIn(states, 1);
        run(tree, close, thresholdOf(second), 2, states);
        // Held: those of frame 1 that pass at 0.8 × second; new: those that pass at second.
        std::set<NodeId> expected;
        const std::set<NodeId> atHysteresis = fresh(0.8f * second), atSecond = fresh(second);
        std::set_intersection(d1.begin(), d1.end(), atHysteresis.begin(), atHysteresis.end(),
                              std::inserter(expected, expected.end()));
        expected.insert(atSecond.begin(), atSecond.end());
        EXPECT_EQ(descendedIn(states, 2), expected) << first << " px, then " << second;
        held = held || expected != atSecond;

        run(tree, close, thresholdOf(second), 4, states); // frame 3 missed: no hysteresis
        EXPECT_EQ(descendedIn(states, 4), atSecond);
    }
    EXPECT_TRUE(held) << "no node between the two thresholds: the test shows nothing";
}

// Facing classes over 20,000 directions spread over the sphere (a Fibonacci lattice): each is
// on the face of its largest component, every class holds some, and each class is a cone narrower
// than a whole face's (54.7° from the face's axis to its corners): the cells of kFacingCells = 2
// hold their directions within 36° of their mean.
TEST(Selection, FacingClassesCutEachFaceIntoCells) {
    constexpr int kCount = 20000;
    std::vector<glm::vec3> directions;
    std::array<glm::vec3, kFacingClasses> sum{};
    for (int i = 0; i < kCount; ++i) {
        const float z = 1.0f - 2.0f * (static_cast<float>(i) + 0.5f) / kCount, rho = std::sqrt(1.0f - z * z);
        const float phi = 2.39996323f * static_cast<float>(i); // the golden angle
        const glm::vec3 n(rho * std::cos(phi), rho * std::sin(phi), z);
        const std::uint32_t c = facingClass(n);
        ASSERT_LT(c, kFacingClasses);
        const glm::vec3 a = glm::abs(n);
        const std::uint32_t axis = a.x >= a.y && a.x >= a.z ? 0u : a.y >= a.z ? 1u : 2u;
        EXPECT_EQ(c / (kFacingCells * kFacingCells), n[static_cast<int>(axis)] < 0.0f ? axis + 3u : axis);
        sum[c] += n;
        directions.push_back(n);
    }
    std::array<float, kFacingClasses> widest{};
    for (const glm::vec3 n : directions) {
        const std::uint32_t c = facingClass(n);
        widest[c] = std::max(widest[c], std::acos(std::min(1.0f, glm::dot(n, glm::normalize(sum[c])))));
    }
    for (std::uint32_t c = 0; c < kFacingClasses; ++c) {
        EXPECT_NE(sum[c], glm::vec3(0.0f)) << "class " << c << " holds no direction";
        EXPECT_LT(widest[c], glm::radians(36.0f)) << "class " << c;
    }
}

// A node draws exactly the facing classes that hold a splat facing the eye (brute force). Seen from
// +z, far, no splat whose normal is nearest -z faces the eye: no node draws a class of that face.
// Each point's class is kept (NodeSelection::pointClass), as the engine keeps them for resident nodes.
TEST(SelectionFacing, FacingClassesLeaveOutTheClassesThatFaceAway) {
    const NodeTree tree = sphereTree(0);
    std::vector<NodeSelection> states = allResident(tree);
    const FrameView view = viewFrom(200.0f);
    const Selection s = run(tree, view, thresholdOf(3.0f), 1, states);
    ASSERT_EQ(s.draw.size(), s.facing.size());
    constexpr std::uint32_t kFaceClasses = kFacingClasses / 6, kMinusZ = 5;
    bool anyWithBack = false, anyLeftOut = false;
    for (std::size_t k = 0; k < s.draw.size(); ++k) {
        const ClassStarts& classes = states[s.draw[k]].classes;
        const PointSet& points = tree.node(s.draw[k]).points;
        FacingMask present = 0, front = 0;
        for (std::size_t i = 0; i < points.size(); ++i) {
            present |= FacingMask{1} << facingClass(points.normal[i]);
            if (glm::dot(points.normal[i], points.position[i] - view.camera.eye) < 0.0f)
                front |= FacingMask{1} << facingClass(points.normal[i]);
        }
        EXPECT_EQ(s.facing[k], front) << "node " << s.draw[k];
        anyLeftOut = anyLeftOut || front != present;
        for (std::uint32_t c = kMinusZ * kFaceClasses; c < (kMinusZ + 1) * kFaceClasses; ++c) {
            anyWithBack = anyWithBack || classes[c + 1] > classes[c];
            EXPECT_EQ(s.facing[k] >> c & 1u, 0u) << "node " << s.draw[k] << ", class " << c;
        }
        EXPECT_NE(s.facing[k], 0u);
    }
    EXPECT_TRUE(anyWithBack) << "no node drawn holds a -z splat: the test shows nothing";
    EXPECT_TRUE(anyLeftOut) << "no node drawn leaves a class out: the test shows nothing";

    SelectionSettings everything = thresholdOf(3.0f);
    everything.cullNodes = false;
    const Selection all = run(tree, viewFrom(200.0f), everything, 2, states);
    EXPECT_EQ(all.draw.size(), tree.roots().size());
}

// The median, 99th-percentile and largest splat drawn (at 1.5 times their radii) and the share over the
// threshold, against the quantiles of camera.h's splatDiameterQuantile over the same points and radii.
TEST(Selection, MeasuredSplatsMatchTheQuantilesOfTheDrawnPoints) {
    const NodeTree tree = sphereTree(1);
    std::vector<NodeSelection> states = allResident(tree);
    const FrameView view = viewFrom(4.0f, 1.5f);
    const Selection s = run(tree, view, thresholdOf(2.0f), 1, states);
    std::vector<glm::vec3> positions, normals;
    std::vector<float> radii;
    for (const NodeId id : s.draw) {
        const Node& node = tree.node(id);
        positions.insert(positions.end(), node.points.position.begin(), node.points.position.end());
        normals.insert(normals.end(), node.points.normal.begin(), node.points.normal.end());
        for (const float r : node.shape.splatRadius) radii.push_back(1.5f * r);
    }
    const auto quantile = [&](float q) {
        return splatDiameterQuantile(positions, normals, radii, view.camera, kWidth, kHeight, q);
    };
    // Over the 90th percentile's diameter: between 0 and a tenth of them.
    const SplatSizes sizes = measureSplats(tree, s.draw, view, quantile(0.9f));
    EXPECT_FLOAT_EQ(sizes.medianPx, quantile(0.5f));
    EXPECT_FLOAT_EQ(sizes.p99Px, quantile(0.99f));
    EXPECT_LT(sizes.p99Px, sizes.maxPx); // a sphere seen whole: its splats' sizes spread
    EXPECT_FLOAT_EQ(sizes.maxPx, quantile(1.0f));
    EXPECT_GT(sizes.overThreshold, 0.0);
    EXPECT_LE(sizes.overThreshold, 0.1);
}
