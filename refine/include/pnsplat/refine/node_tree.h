// The node hierarchy of the real-time refinement: paper section 7 ("Real-Time Refinement");
// docs/ARCHITECTURE.md, "Real-time refinement", has the rules and the reasons.
//
// Nodes are axis-aligned regions holding about a thousand or two points each. The roots split the
// input P0 by medians; refining a node runs one level of the refinement over its points
// (refineRegion, refiner.h), then splits the result into 1, 2 or 3 children along the longest
// axis of its box, or 4 along its two longest, by its point count. A child owns a region (the
// regions of one level partition space) and holds the points of P(l+1) in it, contiguous; its box
// is refit to exactly its points.
//
// Levels stay separated: a node of level l is refined from the points of P(l) only, its own and,
// as context, those of the other regions of level l within reach of its points (the reach of a
// point's neighbourhood search, 1.5 r); the context points near its region are refined with it,
// and what they insert in its region is kept (refineRegion). Rule (balance): a node of level l
// can be refined only when every region of level l that its reach touches exists; otherwise the
// coarser leaves there are refined first (ready() names them). Since no point is inserted outside
// its region, the context is exactly the points of those regions near the node, so the children
// of a node are a function of P(l) alone: the same whatever was refined, evicted or refined again
// before, and on whichever thread (the tree's jobs run refineRegion on copies of their input).
//
// Thread use: the tree is changed and read by one thread (the engine's); run() is a pure function
// of its job and may run on any thread.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "pnsplat/refine/memory_budget.h"
#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/refiner.h"
#include "pnsplat/refine/result.h"

namespace pnsplat {

class WorkerPool;

using NodeId = std::uint32_t;
inline constexpr NodeId kNoNode = UINT32_MAX;
inline constexpr float kDrawnRadiusQuantile = 0.99f;

// The kDrawnRadiusQuantile quantile of `radii` (0 when empty).
float drawnRadiusOf(std::span<const float> radii);
// The lower and upper medians of `radii`, the (n-1)/2-th and n/2-th smallest (equal for an odd
// count): more than half of the radii are at least the first, at most half exceed the second.
std::array<float, 2> medianRadiiOf(std::span<const float> radii);
// Per point, from its kBendNeighbours nearest points in `points` (a level's points in a region, unit
// normals):
//  - bend: how far the surface turns within one spacing, the largest angle (radians) between its
//    normal and theirs. A splat at the silhouette stands out of the surface by about r · bend / 2
//    (the sagitta of a circle turning by bend over r), which the next level's smaller splats halve;
//    the engine refines the nodes whose silhouette splats stand out visibly (selection.cpp, the level
//    of detail).
//  - splatRadius: the radius its splat is measured and drawn with: kCellMargin times the distance
//    to the farthest corner of its Voronoi cell among them in its tangent plane (a disk of that
//    radius covers the part of the surface nearer to it than to them), at most the distance to the
//    farthest of them and its own radius (the point's radius when it has no neighbour). Choice
//    (docs/REALTIME.md, "Splats of the local spacing" and "Splats that cover their cell"): the
//    refinement's radius reaches the farthest member of the point's next one-ring, about twice the
//    spacing, so that its disk covers each pixel many times over; the sixth nearest point lies
//    about 1.3 spacings away and still covers the surface, but on an even sampling the cell's
//    corners lie at 0.58 (hexagonal) to 0.71 (square) spacings, so that distance drew each disk
//    over three to four times the area it must cover. A point whose cell is open (at an open
//    boundary, the sixth nearest on one side) is drawn with the distance to the farthest of them,
//    about √3 spacings, and its splat reaches that far past the last points (docs/REALTIME.md,
//    "Smaller nodes, and no open boundaries": drawn with the fourth nearest, the splats along the
//    borders of nodes, whose points find their nearest on one side only, and of strands left holes).
inline constexpr std::size_t kBendNeighbours = 6;
// See splatRadius above: the splats overlap their cells' corners by this much, for the turn of the
// surface across a cell and the Gaussian's fall to the disk's rim (docs/REALTIME.md, "Splats that
// cover their cell": 1.25 opened a two-pixel hole in the lion's tail, where the input is sparse).
inline constexpr float kCellMargin = 1.5f;
// Arrays apart (the selection's per-splat loop reads both in SIMD lanes).
struct NeighbourShape {
    std::vector<float> bend, splatRadius;

    void reserve(std::size_t count);
    void appendFrom(const NeighbourShape& from, std::size_t i); // point i of `from`
};
// With a pool, on its workers (the same bits as without). With a region that holds the points,
// their cells are cut to it too: the splats cover the region up to its faces, whatever covers the
// space beyond (a root's shapes, NodeTree::create).
NeighbourShape neighbourShapeOf(const PointSet& points, WorkerPool* pool = nullptr,
                                const Region* region = nullptr);
// The cone of `normals` (unit): axis their normalised sum, half-angle the largest angle to it (π
// when the sum is too short to be an axis).
void normalConeOf(std::span<const glm::vec3> normals, glm::vec3& axis, float& angle);

struct NodeSettings {
    // A node is split so that its children hold at most this many points (the paper: "one or two
    // thousands points per cell"). At least 16. Choice (docs/REALTIME.md, "Smaller nodes, and no
    // open boundaries"): 1,024, where 2,048 made up to 12.5 points a covered pixel (the
    // rockerarm's close-up), 2.8 times what it drew: a job refines a whole node, whose children
    // out of the view or facing away nothing draws. Smaller nodes waste less, but each job
    // refines the context along its borders too: 512 made only 2 % fewer points than 1,024 on
    // the rockerarm's close-up.
    std::uint32_t maxNodePoints = 1024;
    // Nodes of this level are not refined further (each level shrinks the radii by about √3).
    std::uint32_t maxLevel = 14;
    // Whole levels first: the refinement of the whole input (Refiner, as `pnsplat refine` builds
    // it) goes on while the next level is estimated to hold at most this many points (kLevelGrowth
    // times the last, memory_budget.h), and the tree's nodes down to the last level built hold those levels:
    // each node's children split the next level's points in its region. Jobs refine from there. 0: none.
    // Choice (docs/REALTIME.md, "Whole levels first"): a node's refinement differs from the whole level's at
    // folds and region borders, and the difference grows with every level refined by nodes; levels refined
    // whole are the offline refinement's, bit for bit.
    std::size_t wholeLevelPoints = 0;
    // The method and its variants; threads is ignored (a job runs on one thread).
    RefineOptions refine;
};

struct Node {
    Region region;                // the part of space the node owns
    glm::vec3 lo{0.0f}, hi{0.0f}; // the box of its points (refit)
    float maxRadius = 0.0f;       // of its splats (shape.splatRadius)
    float maxPointRadius = 0.0f;  // of its points (the refinement's radii): the reach of its refinement
    // The splat radius that kDrawnRadiusQuantile of its points do not exceed: the order in which
    // nodes are refined and uploaded (a few points of much larger radius, such as those whose new
    // one-ring stayed empty, would otherwise put a node first).
    float drawnRadius = 0.0f;
    std::array<float, 2> medianRadius{}; // medianRadiiOf its splat radii
    float maxBend = 0.0f;                // of its points
    // A cone around coneAxis of half-angle coneAngle (radians) holds every normal of its points; at
    // π/2 or more it tells nothing. A renderer skips a node seen from behind (one-sided splats).
    glm::vec3 coneAxis{0.0f, 0.0f, 1.0f};
    float coneAngle = 3.14159265f;
    std::uint32_t level = 0; // its points are P(level) in its region
    NodeId parent = kNoNode; // kNoNode for a root
    std::array<NodeId, 4> children{kNoNode, kNoNode, kNoNode, kNoNode};
    std::uint32_t childCount = 0; // 0: a leaf (not refined, or its children released)
    std::uint32_t generation = 0; // counts the uses of this slot: jobs check it
    PointSet points;              // its points (normals, radii, colours, creases as P0's)
    // Per point, neighbourShapeOf over its level's points of its parent's region (a root: over its
    // own points, cut to its region; a node of the whole levels: of its whole level); a tree only
    // drawn draws points.radius.
    // Selection measures shape.splatRadius, and the cache's splats are drawn with it.
    NeighbourShape shape;
    std::vector<SegmentEnds> segments; // boundary and crease segments whose first point is its own

    bool isLeaf() const { return childCount == 0; }
    std::span<const NodeId> childIds() const { return {children.data(), childCount}; }
};

// What one refinement of a node needs, copied from the tree: it runs while the tree changes.
struct NodeJob {
    NodeId node = kNoNode;
    std::uint32_t generation = 0;
    RegionLevel input;
};

// The children a job made, not yet in the tree.
struct NodeChild {
    Region region;
    PointSet points;
    NeighbourShape shape;
    std::vector<SegmentEnds> segments;
};
struct NodeJobResult {
    NodeId node = kNoNode;
    std::uint32_t generation = 0;
    std::vector<NodeChild> children;               // 1 to 4
    std::vector<std::array<glm::vec3, 3>> parents; // RegionLevel::recordParents, per new point
    LevelStats stats;
};

// A root of at least kRootSpreadPoints points is split further while its radii spread more than
// kRootSpread: the 90th percentile over the 10th (the radii follow the spacing). Choice, not in the
// paper (docs/REALTIME.md, "Roots of one density"): the level of detail takes a node's median splat,
// which says nothing of the rest where the density varies within the node. A scan's density falls
// with the square of the range, and a root cut by count alone ran from the scanner's near field
// to the rim of its far field, its median splat the near field's: its far end was drawn levels
// coarser than the nodes beside it, its splats stood out of the rim in lumps, and holes opened
// along its border. The sparse inputs of ../shared/data spread by at most 3.5 within a root (the
// nefertiti; 1.4 to 2.4 for the others) and are not split further; a terrain of 10,000 points seen
// from its centre spread by up to 13. Each split narrows the range of densities a root holds (cut
// at the median count, near the middle of the ranges on a log scale for such a scan), and the
// nodes below a root inherit its spread. Below 32 points the percentiles tell little.
inline constexpr float kRootSpread = 4.0f;
inline constexpr std::size_t kRootSpreadPoints = 32;

class NodeTree {
  public:
    // The roots over `input`: split at medians along the longest axis until each holds at most
    // settings.maxNodePoints and, for refinement, its radii spread at most kRootSpread. For
    // refinement the input must pass validateForRefinement (else its error), the whole levels of
    // settings.wholeLevelPoints are refined and split under the roots, and the segments of the
    // leaves' level are found (findSegments on P0, or the whole levels' own;
    // settings.refine.threads workers); otherwise (a tree only drawn) it needs normals and radii,
    // and may be empty (no roots).
    static Result<NodeTree> create(PointSet input, const NodeSettings& settings, bool forRefinement = true);

    const NodeSettings& settings() const { return settings_; }
    std::span<const NodeId> roots() const { return roots_; }
    const Node& node(NodeId id) const { return nodes_[id]; }
    // Slots in use or free; valid ids are below this.
    std::size_t slotCount() const { return nodes_.size(); }
    bool isLive(NodeId id) const { return id < nodes_.size() && live_[id]; }
    std::size_t nodeCount() const { return liveCount_; }
    // Points held by all live nodes (each node holds its own copy of the points it keeps).
    std::size_t pointCount() const { return pointCount_; }
    std::size_t inputPoints() const { return inputPoints_; }
    // The whole levels refined when the tree was made (NodeSettings::wholeLevelPoints): the nodes of
    // these levels and above hold them. A node of a lower level is not released (its children are
    // the whole level's, which no job makes again).
    std::uint32_t wholeLevels() const { return wholeLevels_; }
    // The time create took: the whole levels refined, split into nodes and their shapes measured.
    double creationSeconds() const { return creationSeconds_; }

    // Whether leaf `id` can be refined now (balance rule, see the top). When it cannot, the coarser
    // leaves whose refinement must come first are appended to `blockers` (each once per call).
    // False also for a node that is not a leaf or is at settings().maxLevel (no blockers then).
    bool ready(NodeId id, std::vector<NodeId>& blockers) const;
    // The job that refines ready leaf `id` (its points, the context of its level within reach, its
    // segments); with recordParents the result carries every new point's parents (tests).
    NodeJob makeJob(NodeId id, bool recordParents = false) const;
    // Refines a job's region and splits the result into children. Pure; any thread.
    static NodeJobResult run(NodeJob job, const NodeSettings& settings);
    // Makes a job's children the children of its node; false (and nothing changes) when the
    // result is stale: the node was released, or refined, since the job was made.
    bool attach(NodeJobResult&& result);
    // Releases the children of `id`, which must all be leaves, and not of the whole levels (id's
    // level at least wholeLevels()); `id` becomes a leaf again.
    void release(NodeId id);

  private:
    NodeTree() = default;
    NodeId allocate();
    void gatherContext(NodeId id, glm::vec3 lo, glm::vec3 hi, std::uint32_t level, NodeId from,
                       PointSet& context) const;
    // Under each node of `level` (one level, in tree order), children that split the points of
    // `points` (the next whole level) in its region, as a job's result is split (run), with their
    // shape over the whole level (on `pool`) and the `segments` their regions hold; returns them in
    // tree order.
    std::vector<NodeId> splitUnder(std::span<const NodeId> level, const PointSet& points,
                                   std::span<const SegmentEnds> segments, WorkerPool& pool);
    // Makes `children` (1 to 4) the children of leaf `parent` (attach, splitUnder).
    void adopt(NodeId parent, std::vector<NodeChild>&& children);
    // Gives node `id` (level and parent set) the region, points, shape and segments of `made`.
    void place(NodeId id, NodeChild&& made);

    NodeSettings settings_;
    std::vector<Node> nodes_;
    std::vector<std::uint8_t> live_;
    std::vector<NodeId> free_;
    std::vector<NodeId> roots_;
    std::size_t liveCount_ = 0, pointCount_ = 0, inputPoints_ = 0;
    std::uint32_t wholeLevels_ = 0;
    double creationSeconds_ = 0.0;
};

// The regions and point lists of a split (pure; exposed for tests): `points` split into children
// of at most maxNodePoints points where possible (1, 2 or 3 along the longest axis of their box, 4
// as 2 × 2 along the two longest), at the count quantiles, within `region`. Each child's indices
// keep the order of `points`; no child is empty. `points` must lie in `region`.
struct SplitPart {
    Region region;
    std::vector<std::uint32_t> indices;
};
std::vector<SplitPart> splitNode(std::span<const glm::vec3> points, const Region& region,
                                 std::uint32_t maxNodePoints);

} // namespace pnsplat
