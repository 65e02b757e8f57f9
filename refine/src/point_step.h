// The one-point step of a level (paper sections 4 to 6, ALGORITHM.md §4): the neighbourhoods of a
// point of P(l), its candidates L_p, the choice of new points into N'_p, its segments' thirds, and
// the radii r'. It runs over a read-only view of the level (LevelView) and writes the level's new
// points (NewLevel); refiner.cpp's tiles decide which point runs when. Private to refine/src.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>
#include <span>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "level_cells.h"
#include "pnsplat/refine/hierarchy.h"
#include "pnsplat/refine/huge_pages.h"
#include "pnsplat/refine/neighbourhood.h"
#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/refiner.h"
#include "pnsplat/refine/simd_clone.h"
#include "segments.h"

namespace pnsplat {

// Choice: radii are set a hair above the distances they must reach. Neighbourhoods are open balls
// (|p - p_i| < r, eq. 7) while r' is the distance of the farthest new neighbour, which must stay a
// neighbour at the next level; without the margin it would drop out by rounding.
inline constexpr float kRadiusMargin = 1.0f + 1.0f / 4096.0f;

inline constexpr float kTwoPi = 2.0f * std::numbers::pi_v<float>;

// How far a crease point looks for its crease neighbours, times its radius (creaseNeighbours,
// ALGORITHM.md §6.4). Choice: a segment's points at its thirds then lie within 2/3 of it (1.47 r),
// inside the kRetryReach · r that a real-time region's context reaches (refiner.h).
inline constexpr float kCreaseReach = 2.2f;

// Cyclic successor and predecessor of j in [0, m), m > 0; no division (these run in the per-point
// loops over fans and rings).
inline std::size_t nextIndex(std::size_t j, std::size_t m) {
    return j + 1 == m ? 0 : j + 1;
}
inline std::size_t previousIndex(std::size_t j, std::size_t m) {
    return j == 0 ? m - 1 : j - 1;
}

// Counter-clockwise sweep from angle a to angle b, in [0, 2π).
inline float sweep(float a, float b) {
    float d = b - a;
    d = d < 0.0f ? d + kTwoPi : d; // selects, not branches: the signs are unpredictable
    d = d >= kTwoPi ? d - kTwoPi : d;
    return d;
}

// A point inserted during the current level, stored in the cell of its parent.
struct NewPoint {
    glm::vec3 position;
    glm::vec3 normal;
    float radius;
    glm::u8vec3 colour;
    glm::vec3 crease{0.0f}; // second normal of a point inserted on a crease segment (section 6)
};

// Where the children of a point of P(l) are, once it is refined.
struct ChildRange {
    std::uint32_t cell = 0, begin = 0, count = 0;
};

// A member of the new one-ring N'_p or of Y_p: a point of P(l+1) - P(l).
struct RingMember {
    std::uint32_t cell, local;
    glm::vec3 position;
    glm::vec3 normal;
    float angle;         // around n_p
    float gapToNext = 0; // gapValue to the next member, valid when neither stale nor exhausted
    bool gapStale = true;
    bool gapExhausted = false; // no candidate left inside this gap
    float discardRadius = 0;   // Y_p: λ2 times its radius, which stays while p is refined
};

// The cell of a member of N'_p that is not stored: a candidate that refineRegion left to the
// neighbouring region (its `local` counts such members of one point).
constexpr std::uint32_t kPhantomCell = UINT32_MAX;

// Storage order of new points: deterministic whatever the order in which they were found.
inline bool storedBefore(const RingMember& a, const RingMember& b) {
    return a.cell != b.cell ? a.cell < b.cell : a.local < b.local;
}

// A possible new point of L_p (eq. 12), from the fan triangle (p, fan[a], fan[b]).
// Normal and colour are computed only for the candidates actually inserted (newPointFrom).
struct Candidate {
    glm::vec3 position;
    float angle;
    std::uint32_t a, b;
    bool taken = false; // chosen already (inserted, or fell into the discard space)
    // For a PN-centre candidate: the control points b021, b012 of the edge fan[a] fan[b] (the
    // other edges' come with the fan), kept so that an inserted candidate's normal reuses them.
    glm::vec3 b021, b012;
};

// The points of P(l) a new point was made from, stored beside it when the set has attributes
// (PointSet::attributes) or refineRegion records parents: the refined point and the other two
// corners of its fan triangle (t < 0), or a segment's ends (a, b, b) and the curve parameter t of
// the point on it; indices of P(l).
struct PointSource {
    std::array<std::uint32_t, 3> corners;
    float t = -1.0f;
};

struct NearbyPoint {
    glm::vec3 position;
    std::uint32_t index;
    glm::vec3 normal;
};

constexpr std::uint64_t kNoCell = ~std::uint64_t{0}; // cell keys use 63 bits

// A group's candidates (gatherNearby's list) in cubic sub-cells of about half the group's largest
// radius, so that each point of the group scans the sub-cells its reach box touches instead of
// the whole list: on the bunny the list holds about 365 points, the box about a seventh of them.
// The points within reach are the same set; only their order differs, and nothing downstream
// depends on it (fans are sorted by angle with ties by index, N'_p and Y_p by storage position,
// the cut of an oversized neighbourhood by distance with ties by index).
class CandidateGrid {
  public:
    void build(std::span<const NearbyPoint> nearby, float largestRadius) {
        lo_ = glm::vec3(std::numeric_limits<float>::max());
        glm::vec3 hi(std::numeric_limits<float>::lowest());
        for (const NearbyPoint& c : nearby) {
            lo_ = glm::min(lo_, c.position);
            hi = glm::max(hi, c.position);
        }
        // Sub-cells of side largestRadius/kSubdivision, at most kMaxSide a side (a group of far
        // smaller radii than its cell's, as the adaptive refinement leaves, gets coarser ones).
        const float side = largestRadius / kSubdivision;
        for (int a = 0; a < 3; ++a) {
            const float extent = nearby.empty() ? 0.0f : hi[a] - lo_[a];
            scale_[a] = extent > 0.0f ? std::min(1.0f / side, float(kMaxSide) / extent) : 0.0f;
            dims_[a] = std::min(static_cast<int>(extent * scale_[a]) + 1, kMaxSide);
        }
        start_.assign(static_cast<std::size_t>(dims_.x * dims_.y * dims_.z) + 1, 0);
        key_.resize(nearby.size());
        for (std::size_t k = 0; k < nearby.size(); ++k) {
            const glm::ivec3 at = glm::min(glm::ivec3((nearby[k].position - lo_) * scale_), dims_ - 1);
            key_[k] = static_cast<std::uint32_t>((at.x * dims_.y + at.y) * dims_.z + at.z);
            ++start_[key_[k] + 1];
        }
        for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
        sorted_.resize(nearby.size());
        fill_.assign(start_.begin(), start_.end() - 1);
        for (std::size_t k = 0; k < nearby.size(); ++k) sorted_[fill_[key_[k]]++] = nearby[k];
    }

    // Into `out`: the candidates in the sub-cells that the box x ± reach touches, a superset of
    // those within reach of x (x one of the group's points, so within the grid's box). The box is
    // widened by 1/1000 of a sub-cell, far above the rounding of positions relative to the grid.
    void select(glm::vec3 x, float reach, std::vector<NearbyPoint>& out) const {
        const glm::vec3 at = (x - lo_) * scale_, halfSide = reach * scale_ + 1e-3f;
        const glm::ivec3 first = glm::clamp(glm::ivec3(glm::floor(at - halfSide)), glm::ivec3(0), dims_ - 1);
        const glm::ivec3 last = glm::clamp(glm::ivec3(glm::floor(at + halfSide)), glm::ivec3(0), dims_ - 1);
        out.clear();
        for (int cx = first.x; cx <= last.x; ++cx) {
            for (int cy = first.y; cy <= last.y; ++cy) {
                // The sub-cells (cx, cy, first.z..last.z) are consecutive.
                const int row = (cx * dims_.y + cy) * dims_.z;
                out.insert(out.end(), sorted_.begin() + start_[row + first.z],
                           sorted_.begin() + start_[row + last.z + 1]);
            }
        }
    }

    // The longest side of a sub-cell along an axis the candidates spread over (0 where they spread
    // over none): a point whose reach is a small part of it reads whole sub-cells of points it
    // cannot reach (a scan's near field, in a cell sized for its far field). An axis of no extent
    // (a flat, axis-aligned set) has one sub-cell and no side.
    float side() const {
        float widest = 0.0f;
        for (int a = 0; a < 3; ++a)
            if (scale_[a] > 0.0f) widest = std::max(widest, 1.0f / scale_[a]);
        return widest;
    }

  private:
    static constexpr float kSubdivision = 2.0f;
    static constexpr int kMaxSide = 16;
    glm::vec3 lo_{0.0f}, scale_{0.0f}; // sub-cell coordinates: (position - lo_) * scale_
    glm::ivec3 dims_{1};
    std::vector<std::uint32_t> start_, fill_, key_;
    std::vector<NearbyPoint> sorted_;
};

struct alignas(64) WorkerScratch {          // one cache line apart: workers write their counters
    std::vector<std::uint32_t> group;       // the points of the cell being refined
    std::optional<std::uint64_t> groupCell; // the colour cell of the group (none: a large point)
    std::vector<NearbyPoint> nearby;        // candidates for the Euclidean neighbourhoods of the group
    std::vector<NearbyPoint> wideNearby;    // the same for one point searched again wider
    CandidateGrid nearbyGrid;               // `nearby` of a colour cell's group, in sub-cells
    std::vector<NearbyPoint> pointNearby;   // the sub-cells of nearbyGrid around one point
    // Where the 3×3 columns of cells around `columnsOf` start in the grid (gatherNearby): a cell
    // with a larger key starts its search there, as the workers take cells in increasing key order.
    std::array<std::size_t, 9> columnStart{};
    std::uint64_t columnsOf = kNoCell;
    NeighbourSet fan;
    NeighbourhoodScratch neighbourhood;
    std::vector<PointHierarchy::StackEntry> stack;
    std::vector<RingMember> ring;  // N'_p
    std::vector<RingMember> outer; // Y_p
    std::vector<Candidate> candidates;
    PhaseTimes times;
    std::vector<std::uint32_t> inReach;         // the candidates within reach of the point being refined
    std::span<const NearbyPoint> reachableFrom; // the candidates inReach indexes (collectNeighbourhood)
    std::size_t reachable = 0;                  // the entries of inReach in use
    std::vector<NearbyPoint> nearest;           // the maxNeighbours nearest, for an oversized neighbourhood
    BlockArena<NewPoint> arena;                 // the points this worker inserts, cell after cell
    BlockArena<PointSource> sources; // beside `arena` when the level records them (NewLevel::cellSources)
    std::size_t inserted = 0, discarded = 0, retried = 0, beyondBound = 0, coincident = 0,
                boundaryInserted = 0, capped = 0, outsideRegion = 0;
    // LevelStats::scannedCandidates and neighbourhoodPoints
    std::size_t scanned = 0, neighbours = 0;
};

// What the one-point step reads of the level: P(l) as the level started (scaled), unchanged while
// the level runs. The new radii of P(l) go to NewLevel::radius; `points.radius` is not read.
struct LevelView {
    const RefineOptions& options;
    const PointSet& points;
    const PointHierarchy& hierarchy;    // over P(l)'s positions: a large point's surroundings
    std::span<const float> levelRadius; // r of each point of P(l)
    // Every point of P(l) by colour cell (LevelCells::gridKey, gridPoint); empty when the level
    // refines no group of cells (findSegmentsOf, before the cells are made).
    std::span<const std::uint64_t> gridKey;
    std::span<const std::uint32_t> gridPoint;
    std::optional<Region> region; // refineRegion: its region, scaled; none for the whole level
    bool splitsSegments = false;  // an odd level with segments: their first points split them
    bool meanNormals = false;     // Refiner::setMeanNormals
};

// The level being built, read and written by the one-point step: a point writes its own entries,
// its cell's storage and the radii of the new points within its reach, and reads those of the
// points within its reach (refiner.cpp's top says why no two workers meet there).
struct NewLevel {
    std::span<float> radius; // r' of each point of P(l) refined
    std::span<std::uint8_t> refined;
    std::span<ChildRange> childRange;
    // The points inserted in each cell, contiguous: cellBase[c][0, cellCount[c]), in the arena of
    // the worker that refines the cell; beside them their sources, cellSources[c][...], when the
    // level records them (for the attributes' values, or refineRegion's recordParents; else empty).
    std::span<NewPoint*> cellBase;
    std::span<std::uint32_t> cellCount;
    std::span<PointSource*> cellSources;
    Segments* segments = nullptr; // reads their index, writes `child` and `inserted`
};

// The one-point step. One object serves every worker of a level: its functions are const, and
// what they write goes through NewLevel's spans and the worker's scratch.
class PointStep {
  public:
    PointStep(const LevelView& level, const NewLevel& out) : level_(level), out_(out) {}
    const LevelView& level() const { return level_; }

    // The points of P(l) that the refinement of `group` may need (cell: their colour cell, or none
    // for a single large point), into `nearby`.
    void gatherNearby(std::span<const std::uint32_t> group, std::optional<std::uint64_t> cell,
                      float reachFactor, std::vector<NearbyPoint>& nearby, WorkerScratch& s) const;
    // Nε_p, N'_p and Y_p of p within `reach` into s.fan, s.ring, s.outer; whether it cut an
    // oversized neighbourhood.
    bool gatherNeighbourhood(std::uint32_t p, const TangentFrame& frame, float reach,
                             std::span<const NearbyPoint> candidates, WorkerScratch& s) const;
    // Refines the points of cell c of `cells` (a cell of large points: largeCell), in key order,
    // storing their children with the cell in the arena of the worker of `s`.
    void refineCell(const LevelCells& cells, std::uint32_t c, bool largeCell, WorkerScratch& s) const;

    // Whether consecutive fan neighbours leave an opening wider than θb around p (section 6).
    bool fanIsOpen(const NeighbourSet& fan) const;
    // The crease neighbours of crease point p among `nearby` (UINT32_MAX where none).
    std::array<std::uint32_t, 2> creaseNeighbours(std::uint32_t p, std::span<const NearbyPoint> nearby) const;
    // The plane a point is refined in: its normal, or for a crease point the bisector of its two.
    glm::vec3 planeNormal(std::uint32_t p) const;
    // The neighbourhood filter of the options; `edgeControls`: keep the fan's edge control points.
    FuzzyParams fuzzyParams(bool edgeControls) const;

  private:
    // Refines p, of the group whose surroundings s.nearby holds, storing its children in `cell`.
    PNSPLAT_V3_CLONE void refinePoint(std::uint32_t p, std::uint32_t cell, WorkerScratch& s) const;
    // The steps of refinePoint, in order: functions of their own, each with its x86-64-v3 clone.
    // Against refinePoint as one function of 218 lines (bench refine, level 5, one thread, best of
    // four or five runs alternated): 0.987-0.998 of its rate on the lion, the bunny, the nefertiti
    // and the igea, the calls' cost; always inlined into it, 0.969-0.980, for 0.2 % fewer
    // instructions (cachegrind): the inlined code ran slower, not longer.
    PNSPLAT_V3_CLONE void findOneRing(std::uint32_t p, const TangentFrame& frame,
                                      std::chrono::steady_clock::time_point& t0, WorkerScratch& s) const;
    PNSPLAT_V3_CLONE std::size_t nextCandidate(glm::vec3 x, WorkerScratch& s) const;
    PNSPLAT_V3_CLONE bool substituteIfDiscarded(std::uint32_t p, const TangentFrame& frame,
                                                const Candidate& c, WorkerScratch& s) const;
    PNSPLAT_V3_CLONE void insertCandidate(std::uint32_t p, std::uint32_t cell, const TangentFrame& frame,
                                          const Candidate& c, std::uint32_t& phantoms,
                                          WorkerScratch& s) const;
    PNSPLAT_V3_CLONE void updateRadii(std::uint32_t p, std::span<const RingMember> ring) const;
    PNSPLAT_V3_CLONE void collectNeighbourhood(std::uint32_t p, const TangentFrame& frame, float reach,
                                               std::span<const NearbyPoint> candidates,
                                               WorkerScratch& s) const;
    glm::vec3 creaseOf(std::uint32_t i) const {
        return level_.points.hasCrease() ? level_.points.crease[i] : glm::vec3(0.0f);
    }
    // The corner normals of the fan triangle (p, fan[a], fan[b]) (creases: creaseTriangleNormals).
    bool triangleNormals(std::uint32_t p, const NeighbourSet& fan, std::uint32_t a, std::uint32_t b,
                         glm::vec3 (&normals)[3]) const {
        normals[0] = level_.points.normal[p];
        normals[1] = fan.normal[a];
        normals[2] = fan.normal[b];
        return !level_.points.hasCrease() || creaseTriangleNormals(p, fan, a, b, normals);
    }
    bool creaseTriangleNormals(std::uint32_t p, const NeighbourSet& fan, std::uint32_t a, std::uint32_t b,
                               glm::vec3 (&normals)[3]) const;
    PNSPLAT_V3_CLONE void makeCandidates(std::uint32_t p, const TangentFrame& frame, WorkerScratch& s) const;
    [[gnu::always_inline]] float gapValue(glm::vec3 x, const RingMember& a, const RingMember& b,
                                          std::size_t ringSize) const;
    PNSPLAT_V3_CLONE NewPoint newPointFrom(std::uint32_t p, const NeighbourSet& fan,
                                           const Candidate& c) const;
    void insertIntoRing(std::vector<RingMember>& ring, const RingMember& m) const;
    void splitSegments(std::uint32_t p, std::uint32_t cell, std::uint32_t firstChild, WorkerScratch& s) const;
    NewPoint& newPoint(const RingMember& m) const { return out_.cellBase[m.cell][m.local]; }
    bool outsideRegion(glm::vec3 q) const { return level_.region && !level_.region->contains(q); }
    // Whether q may join N'_p: r' = kRadiusMargin·|q - p| stays within c_β,max·r (the convergence
    // bound of ALGORITHM.md §4.7, paper section 8.1), which the choices on Y_p's substitutes, the
    // segments' first points and the candidates of a wider second look rely on.
    bool withinConvergenceBound(std::uint32_t p, glm::vec3 q) const {
        return kRadiusMargin * glm::length(q - level_.points.position[p]) <=
               kCBetaMax * level_.levelRadius[p];
    }
    static bool coincidesWithNearby(glm::vec3 q, glm::vec3 x, const WorkerScratch& s);
    bool madeByCorner(glm::vec3 q, std::uint32_t corner) const;
    // Appends np, made from `source`, to `cell`, refined by the worker of `s`; returns its index in
    // the cell.
    std::uint32_t store(std::uint32_t cell, const NewPoint& np, const PointSource& source,
                        WorkerScratch& s) const {
        s.arena.append(out_.cellBase[cell], out_.cellCount[cell], np);
        if (!out_.cellSources.empty()) s.sources.append(out_.cellSources[cell], out_.cellCount[cell], source);
        return out_.cellCount[cell]++;
    }

    LevelView level_;
    NewLevel out_;
};

} // namespace pnsplat
