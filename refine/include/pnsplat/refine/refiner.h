// Interpolatory √3-like refinement of an oriented point set: paper sections 5 and 7,
// ALGORITHM.md §1, §4, §5, §7 and §10.
//
// P0 ⊂ P1 ⊂ P2 ⊂ ...: each level refines every point of P(l) once (local refinement, ALGORITHM.md §4) and
// appends the inserted points. Old points never move; only their radius changes. The output of a
// level is identical for any number of threads (ALGORITHM.md §5: a fixed spatial colouring, see refiner.cpp).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <numbers>
#include <span>
#include <vector>

#include "pnsplat/refine/angles.h"
#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/result.h"

namespace pnsplat {

enum class NeighbourhoodKind {
    Fuzzy,    // Nf: fuzzy BSP on the points themselves
    Accurate, // Ng: fuzzy BSP on geodesic projections (the full method's default)
};

// The paper's constants (section 5): λ1 = 1/√3 (scale of a √3 step), λ2 = 1/2 (discard balls),
// θc = π/2 (completeness of a new one-ring).
inline constexpr float kLambda1 = 0.57735026918962576f;
inline constexpr float kLambda2 = 0.5f;
inline constexpr float kThetaC = std::numbers::pi_v<float> / 2.0f;
// The convergence bound (section 8.1, eq. 14, ALGORITHM.md §4.7): c_β,max = max over β of
// (5/6 + 5/6 + cos(β/2) + 2/3 sin(β/2)) / 3 = (5 + √13) / 9, rounded down. Every radius of P(l)
// ends a level at most c_β,max times its value before; a point whose new one-ring stays empty
// (nothing found, nothing inserted: the paper's r' is undefined) gets exactly c_β,max · r.
inline constexpr float kCBetaMax = 0.956172f;
// The farthest a point's refinement looks: its neighbourhood is searched within r, and once more
// within kRetryReach · r when its fan is open (a possible boundary). The real-time refinement's
// context reaches as far (node_tree.h).
inline constexpr float kRetryReach = 1.5f;

// The points of a colour cell find their surroundings together, in sub-cells of about half the
// cell's largest radius (ALGORITHM.md §7.4); a point whose radius times this is below a sub-cell's
// side finds them through the hierarchy instead, as a large point does: the same points within
// reach. Where one cell mixes radii a tenth of its largest or less (a terrestrial scan's near
// field, in cells sized for its far field), a point otherwise reads a crowd of points far beyond
// its reach. Choice of 8: a 100,000-point terrain seen from its centre (ranges 0.5 to 200) refines
// 2 levels 3.0-3.3 times as fast, the fandisk 5-8 % faster; the bunny and the nefertiti use it for a
// few points, the sphere for none (4 and 16: within 10 % on the terrain, 16 slower).
inline constexpr float kFineReach = 8.0f;

// Choice (not in the paper): when more than RefineOptions::maxNeighbours points within a point's
// radius pass the validity cone, only that many nearest points within the radius are kept (and
// then checked against the cone). The natural first ring has about 6 members and a radius that
// reaches it holds some 6 to 30 points (up to about 200 at the largest radii of the irregular
// inputs in ../shared/data, none of which reaches the default bound); only radii far too large for
// the sampling (a whole model within one radius) give more, and then the filter would make a level
// take hours. LevelStats::cappedNeighbourhoods counts the points cut so.
inline constexpr std::size_t kMaxNeighbours = 256;
// Hole filling (enlargeAroundHole): a rim point's radius spans the hole, and its neighbourhood
// holds the whole ring of rim points around it, a thousand points and more. The nearest 256 all
// lie on its own side, so the bound must be well above that for the far rim to be seen.
inline constexpr std::size_t kHoleFillingMaxNeighbours = 4096;

struct RefineOptions {
    NeighbourhoodKind neighbourhood = NeighbourhoodKind::Accurate;
    float thetaF = std::numbers::pi_v<float> / 6.0f; // fuzzy-plane tolerance θf
    // Boundary gap θb ∈ (2π/3, π] (section 6): consecutive fan neighbours further apart than this
    // around p make no candidate, and mark p as a potential boundary point. Default 165°: wide
    // enough that interior fans are rarely taken for boundaries, narrow enough to find real ones.
    float thetaB = radians(165.0f);
    // Boundary segments (section 6): found among the potential boundary points of P0 at the first
    // step, each receives two points on its cubic curve at every odd step.
    bool boundaries = true;

    // The faster variants of section 7 ("Simplifications"), ALGORITHM.md §10, each a separate switch:
    bool euclideanGeodesic = false;  // (1) G(p0,p1) ≈ |p0 p1|
    bool plainAngle = false;         // (2) curved angle ≈ plain angle
                                     // (3) is neighbourhood = Fuzzy
    bool centroidCandidates = false; // (4) candidates at the centroid, smoothed only when inserted

    // Off: new points at the plain centroid with the mean normal (no PN displacement). Not part of
    // the method: a baseline that shows what the smoothing operator contributes.
    bool smoothing = true;

    // Adaptive refinement (0 = off, every point is refined at every level, as in the paper's
    // offline method): points whose radius is at most targetRadius are not refined, so sparse
    // regions keep being refined after dense ones have reached the target spacing. This is what
    // the paper's real-time renderer does with a screen-space size threshold (section 7).
    float targetRadius = 0.0f;

    std::size_t maxNeighbours = kMaxNeighbours; // see kMaxNeighbours
    float fineReach = kFineReach;               // see kFineReach; the output does not depend on it
    unsigned threads = 1;                       // 0 = all hardware threads; the output does not depend on it
    bool profile = false;                       // measure the time per phase (costs a few percent)

    // All four faster variants on.
    static RefineOptions fast();
};

// Time spent per phase of the local refinement, summed over the workers (paper section 8:
// neighbourhood, filtering, selection, interpolation and radii), in seconds.
struct PhaseTimes {
    double neighbourhood = 0, filtering = 0, selection = 0, interpolation = 0;
};

struct LevelStats {
    std::uint32_t level = 0; // the level built: P(level) from P(level-1)
    std::size_t pointsBefore = 0;
    std::size_t inserted = 0;
    std::size_t discarded = 0;            // candidates that fell in the discard space
    std::size_t retried = 0;              // points whose fan was open and was searched again wider
    std::size_t beyondBound = 0;          // candidates beyond c_β,max · r, left out (ALGORITHM.md §4.7)
    std::size_t coincident = 0;           // candidates not inserted: at the position of p or a point near it
                                          // (of P(l) within reach, of N'_p or of Y_p)
    std::size_t cappedNeighbourhoods = 0; // neighbourhoods cut to the maxNeighbours nearest
    std::size_t boundaryInserted = 0;     // points inserted on boundary and crease segments (section 6)
    std::size_t boundarySegments = 0;     // boundary and crease segments after this level
    double seconds = 0;                   // wall clock
    PhaseTimes phases;                    // filled when RefineOptions::profile
    std::size_t largePoints = 0;          // points above r_lim, refined in a colouring of their own
    std::size_t refinedPoints = 0;        // points of P(level-1) refined (all but adaptive skips)
    std::size_t outsideRegion = 0;        // refineRegion: candidates and segment points outside the
                                          // region, not inserted
    std::size_t scannedCandidates = 0;    // candidates looked at for Nε_p, over every gathering of
                                          // every refined point (neighbourhood cost; bench refine)
    std::size_t neighbourhoodPoints = 0;  // |Nε_p| of each refined point's last gathering, summed
};

// Called as progress(done, total) with points refined so far in the current level, from the
// thread that called refineLevel, at most a few hundred times per level.
using ProgressFn = std::function<void(std::size_t done, std::size_t total)>;

// A hole to fill: a ball that holds no input point (hole filling, below).
struct Hole {
    glm::vec3 centre{0.0f};
    float radius = 0.0f;
};

struct SegmentEnds;
struct RegionLevel;
struct RegionResult;

class Refiner {
  public:
    // `input` must be non-empty with unit normals and positive radii (estimateRadii supplies them).
    Refiner(PointSet input, const RefineOptions& options);
    ~Refiner();
    Refiner(Refiner&&) noexcept;
    Refiner& operator=(Refiner&&) noexcept;

    // Builds the next level. Not thread-safe; uses the options' worker threads internally.
    LevelStats refineLevel(const ProgressFn& progress = {});
    // RefineOptions::targetRadius for the levels that follow, and its current value.
    void setTargetRadius(float radius);
    float targetRadius() const;
    // For the levels that follow; fillHoles sets both for its levels and clears them after. On, a
    // new point's normal is the mean of its triangle's corner normals (meanNormal), not the
    // patch's at its centre. With balls, only the points inside one of them are refined (and
    // only those the target radius leaves); without, every point the target radius leaves.
    void setMeanNormals(bool on);
    void setRefinedBalls(std::vector<Hole> balls);
    // The length of the longest boundary or crease segment (section 6), 0 without segments. They
    // are found at the first level; before it there are none.
    float longestSegment() const;
    // The boundary and crease segments of the last level built, by the positions of their ends:
    // what refineRegion takes to go on from this level in a region (empty before the first level).
    std::vector<SegmentEnds> segmentEnds() const;

    // All points so far, level by level: P0 (the input points, unchanged but for their radii)
    // first, in a spatial (Morton) order that keeps neighbours close in memory, then the points
    // of each level grouped by the point that inserted them.
    const PointSet& points() const;
    // inputOrder()[i] is the index in the input of point i of P0 (i < levelEnd(0)).
    std::span<const std::uint32_t> inputOrder() const;
    std::uint32_t levels() const;                // 0 before the first refineLevel
    std::size_t levelEnd(std::uint32_t l) const; // |P(l)|
    // Children of point i inserted at the transition l → l+1: [childBegin, childEnd).
    std::size_t childBegin(std::uint32_t l, std::size_t i) const;
    std::size_t childEnd(std::uint32_t l, std::size_t i) const;

    PointSet takePoints() &&;

  private:
    friend std::vector<SegmentEnds> findSegments(const PointSet&, const RefineOptions&);
    friend RegionResult refineRegion(RegionLevel, const RefineOptions&);
    struct State;
    std::unique_ptr<State> state_;
};

// Evening out (beyond the paper; a choice). Uniform levels keep the input's density contrasts: a
// region that a random input sampled sparsely stays sparser than its surroundings by the same
// factor after any number of levels, and its largest gaps show as holes. evenOut refines
// adaptively (RefineOptions::targetRadius) the points whose radius is above `factor` times the
// median radius of the set, and those owning a segment longer than that, level after level, until
// none is left, a level inserts nothing, or `maxLevels` levels were built; the target radius then
// returns to its previous value. A factor <= 0 builds nothing. Returns the statistics of the
// levels built. Deterministic like refineLevel. Not for inputs with
// openings that the uniform levels bridged (undetected boundaries): the largest radii sit across
// them, and evening out fills them further.
std::vector<LevelStats> evenOut(Refiner& refiner, float factor, unsigned maxLevels,
                                const ProgressFn& progress = {});
inline constexpr float kEvenOutFactor = 2.0f; // the suggested factor (tests, `--even-out` help, hole filling)
inline constexpr unsigned kEvenOutMaxLevels = 4; // the tools' level budget

// The adaptive levels of evenOut for a given target radius: points whose radius is above it (or
// that own a longer segment) are refined until none is left, a level inserts nothing, or
// `maxLevels` levels were built.
std::vector<LevelStats> refineDownTo(Refiner& refiner, float targetRadius, unsigned maxLevels,
                                     const ProgressFn& progress = {});

// Hole filling (paper figure 9, ALGORITHM.md §9.6): "the radii of the boundary points are adjusted such that
// they are greater than the hole", then the refinement is applied several times. A hole is given
// as a ball that holds no input point.
//  - Choice: the boundary points of a hole are those whose ball reaches the hole's
//    (|p - c| < R + r_p), and each gets r_p = max(r_p, |p - c| + R), which reaches across the
//    hole to its far rim, so that its neighbourhood spans it and its fan triangles cross it.
//    Every hole is measured against the radii as given, so their order does not matter.
//  - Refine with RefineOptions::maxNeighbours = kHoleFillingMaxNeighbours, and fill (fillHoles)
//    before any uniform level: only the rim and the points it inserts into the hole are refined,
//    level after level, until their radii are down to `fillTarget`. Refined within a uniform level
//    instead, a rim point finds its new one-ring complete with its many neighbours' children and
//    inserts almost nothing.
//  - Choice: fillTarget = max(kEvenOutFactor times the median radius, the largest radius of the
//    points not enlarged): no other point is refined on the way (the fill evens out nothing else).
//    After the uniform levels the hole would hold about half its surroundings' density (0.56 on
//    the data's two holes).
//  - Choice: the points inserted by the filling levels take the mean of their triangle's corner
//    normals (Refiner::setMeanNormals), not the patch's normal at its centre. An enlarged rim
//    point's fan triangles are slivers (two corners side by side on one rim, the third across the
//    hole), whose centre normal is ill-conditioned: 30 to 56 degrees off the true one on the
//    igea's hole, and the points made from those normals lay up to a third of the hole's radius
//    inside the surface.
//  - Choice: then the density levels: only the points inside a hole's ball are refined
//    (Refiner::setRefinedBalls), with the radii the filling left them, until their radii are down
//    to densityTarget = kHoleDensityFactor times the median radius (at most kHoleFillingLevels
//    levels): the fill's new points come from small triangles of fill and rim points.
//    kHoleDensityFactor = √2: the last level takes the fill's radii well past the target (their
//    median ends at 0.6 times it on the data's holes), and after the uniform levels the data's two
//    holes ended 1.59 and 1.47 times as dense as their surroundings with the median radius as the
//    target, 1.14 and 1.20 with 1.2 times it, 0.92 and 0.92 with √2 times it, 0.71 and 0.72 with
//    1.7 times it, 0.53 and 0.60 with twice it (igea, bunny; ALGORITHM.md §9.6).
struct HoleRims {
    std::size_t enlarged = 0; // radii that grew
    float fillTarget = 0.0f;
    std::vector<Hole> holes;    // the holes, for the density levels
    float densityTarget = 0.0f; // kHoleDensityFactor times the median radius
};
// Errors, with `points` unchanged: a centre or radius that is not finite, a radius that is not
// positive, an input point inside a hole, a hole that no point's ball reaches. (A point whose
// distance to a centre is finite is within 2^64 of it, so an enlarged radius never overflows.)
// Single-threaded, O(points × holes).
Result<HoleRims> enlargeAroundHoles(PointSet& points, std::span<const Hole> holes);
// The filling levels (refineDownTo to rims.fillTarget, at most kHoleFillingLevels, with mean
// normals), then the density levels (inside rims.holes, down to rims.densityTarget, at most
// kHoleFillingLevels).
std::vector<LevelStats> fillHoles(Refiner& refiner, const HoleRims& rims, const ProgressFn& progress = {});
inline constexpr unsigned kHoleFillingLevels = 12;
inline constexpr float kHoleDensityFactor = 1.41421356f; // √2

// A region of space for the real-time refinement (node_tree.h): [lo, hi) on each axis, so that
// the regions of one level partition space and a point lies in exactly one of them. Sides may be
// infinite.
struct Region {
    glm::vec3 lo{-std::numeric_limits<float>::infinity()};
    glm::vec3 hi{std::numeric_limits<float>::infinity()};
    bool contains(glm::vec3 p) const {
        return lo.x <= p.x && p.x < hi.x && lo.y <= p.y && p.y < hi.y && lo.z <= p.z && p.z < hi.z;
    }
};

// A boundary or crease segment (section 6) by the positions of its ends (positions are distinct
// within a level, so they name points across the separate runs of refineRegion). The refinement
// of its first point `a` splits it at every odd step.
struct SegmentEnds {
    glm::vec3 a{0.0f}, b{0.0f};
    bool crease = false;
};

// The boundary and crease segments that the first level finds on P0 (section 6): what
// refineLevel finds at its first step, for the callers of refineRegion, which never look for
// segments themselves. `points` as for Refiner; options.threads workers. Any thread.
std::vector<SegmentEnds> findSegments(const PointSet& points, const RefineOptions& options);

// One level of the refinement of one region of space (real-time refinement, paper section 7;
// docs/ARCHITECTURE.md, "Real-time refinement"): the points of P(l) in `region` are refined once,
// in the order refineLevel would refine `points`, seeing the other points of P(l) as context.
//  - Context points are neighbours, fan corners and candidates' corners like any point of P(l).
//    Choice: those within kRetryReach · r of `region` (r their own radius) are refined too, as the
//    whole level would refine them; the rest are not (they insert nothing, their children are not
//    seen). What the points beyond the border insert on this side is then inserted here, and the
//    rings, hence the radii, of the region's points near the border see it. (With every context
//    point frozen, a gap of P(l) across a border was filled by neither side: each side's
//    candidates beyond the border were dropped and the other side's fans made others; the gap
//    stayed empty at every level while the radii around it shrank: a hole, docs/ALGORITHM.md §8.2.)
//  - Choice: no point is inserted outside `region` (a candidate or segment point there is dropped,
//    LevelStats::outsideRegion), the context points' included: the neighbouring region inserts
//    it when it refines its own points (and, near the border, ours), so a new point is inserted
//    by the region that holds it; and every point of a region lies in it, which makes the context
//    of a region exactly the points of the regions within reach of it. Such a candidate joins N'_p
//    all the same, unstored: the radius of the point that made it reaches it, and the ring's
//    members beside it grow to reach it, not each other across the gap it would leave (which made
//    the radii near borders larger than the whole level's, and nodes refined deeper than needed).
//  - Segments (section 6) are given, by position, with `a` among the region's points and `b`
//    among `points` (others are dropped); they are split when level l+1 is odd, as in refineLevel.
// The result depends only on the input (its order included), never on the threads or the history:
// the real-time refinement relies on it. Runs with RegionLevel::threads as RefineOptions::threads
// (one: on the calling thread alone, as the engine's jobs do). Preconditions: `points` as for
// Refiner, owned <= points.size(), the owned points lie in `region`.
struct RegionLevel {
    PointSet points; // the region's points of P(l) (the first `owned`), then context
    std::size_t owned = 0;
    Region region;
    std::uint32_t level = 0; // l: level l+1 is built
    std::vector<SegmentEnds> segments;
    bool recordParents = false; // fill RegionResult::parents (tests: levels stay separated)
    unsigned threads = 1;       // as RefineOptions::threads; the result is the same for any
};
struct RegionResult {
    // The owned points in their given order with their radii of P(l+1), then the new points,
    // grouped by the point that inserted them.
    PointSet points;
    std::vector<SegmentEnds> segments; // of P(l+1), first points among `points`
    // With recordParents, per new point: the corners of the fan triangle it was made from (the
    // refined point first), or a segment's ends (a, b, b). All are points of P(l).
    std::vector<std::array<glm::vec3, 3>> parents;
    LevelStats stats;
};
RegionResult refineRegion(RegionLevel input, const RefineOptions& options);

// Radii the refinement accepts: each is squared in single precision, below kMinRadius into a
// denormal (and a radius cannot shrink by c_β,max any more), above kMaxRadius with the reach of a
// colour cell towards overflow. Between them any scale works alike: each level runs rescaled by a
// power of two where its radii would take the squares of squared distances out of range.
inline constexpr float kMinRadius = 1.1e-19f;
inline constexpr float kMaxRadius = 1e18f;

// Checks that a point set can be refined: non-empty, finite, unit normals, radii within
// [kMinRadius, kMaxRadius], distinct positions (removeCoincident), and no two closer than 2^-63 at
// the scale the first level runs at (squared distances in single precision).
Result<void> validateForRefinement(const PointSet& points);

} // namespace pnsplat
