// Levels of refinement on worker threads: paper sections 5 and 7, ALGORITHM.md §4, §5 and §7.
//
// Parallel scheme (ALGORITHM.md §5). The result of a level depends on the order in which its points are
// refined, so the order is fixed independently of the thread count:
//  - Space is cut into cubic cells of side s = kCellFactor · r_lim, r_lim the 99th percentile of
//    the radii of P(l), and the cells into tiles, cubes of 2^t cells a side (t at most
//    kMaxTileShift: the largest that leaves at least kMinTiles tiles, a choice of the data alone).
//    Tiles are coloured by the parity of their integer coordinates (2×2×2 = 8 colours): two
//    adjacent tiles (the 26 around one) differ in colour, and two of one colour are at least a
//    tile, so at least s, apart.
//  - Refining p reads the points of P(l) closer than its reach (r_p, or kRetryReach·r_p for an
//    open fan) with their `refined` flags and children, and the radii of new points closer than
//    r_p; it writes its own flag and children (stored with its cell) and the radii of new points
//    closer than r_p. Every reach is at most 1.5·r_lim < s and every radius written within
//    r_lim < s, so refining the points of a tile reads and writes the tile and its adjacent tiles
//    only, and never storage that another worker is appending to.
//  - So one worker refines a tile, its cells in key order and each cell's points in increasing
//    index order, once every adjacent tile of a lower colour is done (runGraph); tiles that are
//    not adjacent run concurrently. This is the order "colour 0, then 1, ..., 7, the tiles of a
//    colour in any order", without waiting for the whole colour: tiles of one colour never touch
//    each other's points, and a tile waits only for the lower-colour tiles it touches.
//  - Large tiles keep the surroundings of a tile in cache while all its cells are refined (with
//    colour phases over single cells, each phase swept the whole level through memory).
//  - Points with r > r_lim (about 1 %) are refined first, in tiles of one cell of their own made
//    the same way with s_L = kCellFactor · r_max (r_max their largest radius), and the same
//    reasoning. One huge radius makes s_L huge and the large points few cells: slower, never wrong.
// Every point sees exactly the points that the same sequential order would show it, whatever the
#include "pnsplat/refine/refiner.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cassert>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include "kd_tree.h"
#include "level_cells.h"
#include "pnsplat/refine/hierarchy.h"
#include "pnsplat/refine/huge_pages.h"
#include "pnsplat/refine/worker_pool.h"
#include "point_step.h"
#include "segments.h"

namespace pnsplat {

namespace {

constexpr float kLargeQuantile = 0.99f;
constexpr float kMinCreaseCos = -0.98480775f; // cos 170°

using Clock = std::chrono::steady_clock;

// Whether x lies inside one of the balls, their centres and radii times `scale` (a level's
// rescaling, ALGORITHM.md §5.4: a power of two, exact).
bool insideAny(std::span<const Hole> balls, glm::vec3 x, float scale) {
    return std::ranges::any_of(
        balls, [&](const Hole& ball) { return glm::length(x - ball.centre * scale) < ball.radius * scale; });
}

// The value of an attribute at a new point (ALGORITHM.md §2.6): the mean of its triangle's corners,
// or on a segment (a, b) the interpolation at t, as for colour; rounded to the attribute's type.
inline double sourcedValue(const Attribute& attribute, const PointSource& source) {
    const auto& v = attribute.values;
    const std::array<std::uint32_t, 3>& c = source.corners;
    const double value = source.t < 0.0f ? (v[c[0]] + v[c[1]] + v[c[2]]) / 3.0
                                         : v[c[0]] * (1.0 - double(source.t)) + v[c[1]] * double(source.t);
    return representable(attribute.type, value);
}

// P0 sorted along a Morton curve. Children are stored grouped by parent in parent order, so every
// level inherits the order: points close in space are close in memory, and the hierarchy walks
// and neighbourhood gathers touch few cache lines. Ties keep the input order.
PointSet spatialOrder(PointSet input, std::vector<std::uint32_t>& order) {
    const auto count = static_cast<std::uint32_t>(input.size());
    order = mortonOrder(input.position);
    PointSet sorted;
    sorted.position.resize(count);
    sorted.normal.resize(count);
    sorted.radius.resize(count);
    if (input.hasColour()) sorted.colour.resize(count);
    if (input.hasCrease()) sorted.crease.resize(count);
    sorted.attributes = emptyAttributesLike(input);
    for (Attribute& a : sorted.attributes) a.values.resize(count);
    for (std::uint32_t k = 0; k < count; ++k) {
        const std::uint32_t i = order[k];
        sorted.position[k] = input.position[i];
        sorted.normal[k] = input.normal[i];
        sorted.radius[k] = input.radius[i];
        if (input.hasColour()) sorted.colour[k] = input.colour[i];
        if (input.hasCrease()) sorted.crease[k] = input.crease[i];
    }
    for (std::size_t a = 0; a < sorted.attributes.size(); ++a)
        for (std::uint32_t k = 0; k < count; ++k)
            sorted.attributes[a].values[k] = input.attributes[a].values[order[k]];
    return sorted;
}

// Grows every array of `points`, and the hierarchy's, to n points, the arrays side by side on the
// pool's workers: growing is mostly page faults on fresh memory (huge pages where offered), which
// the workers take in parallel.
void growInParallel(PointSet& points, PointHierarchy& hierarchy, std::uint32_t n, WorkerPool& pool) {
    const bool withRadius = points.hasRadius(), withColour = points.hasColour(),
               withCrease = points.hasCrease();
    pool.parallelFor(6 + points.attributes.size(), [&](std::size_t array, unsigned) {
        switch (array) {
        case 0:
            points.position.resize(n);
            break;
        case 1:
            points.normal.resize(n);
            break;
        case 2:
            if (withRadius) points.radius.resize(n);
            break;
        case 3:
            if (withColour) points.colour.resize(n);
            break;
        case 4:
            if (withCrease) points.crease.resize(n);
            break;
        case 5:
            hierarchy.growTo(n);
            break;
        default:
            points.attributes[array - 6].values.resize(n);
            break;
        }
    });
}

// Choice (not in the paper): a level runs at a scale that keeps its arithmetic in single
// precision's normal range. The refinement computes squares and fourth powers of distances
// (angle tests, pn_triangle.h), which underflow for distances below about 1e-9 and overflow
// above about 1e9; everything else is relative. Scaling by a power of two is exact, and within
// that range the output is exactly scale-invariant (RefinerScale). The distances measured are
// those within a point's ball, so their size is that of the radii (the 99th percentile r_lim),
// or of the set's extent where radii exceed it. A level whose `size`, the smaller of the two,
// lies outside [2^-20, 2^20] is computed on the points scaled by 2^e, e chosen to bring it into
// [1, 2), and scaled back: the same bits as refining a copy scaled by hand.
// Elsewhere e = 0 and this costs nothing. e is limited so that the input comes back bit for bit:
// scaled down, no coordinate or radius may become a denormal (it would lose bits), and scaled
// up, no coordinate may pass 2^100 (extents and cell keys stay finite).
constexpr int kUnscaledExponent = 20;
constexpr int kLargestScaledExponent = 100;
int scaleExponent(const PointSet& points, float size) {
    const int rlim = std::ilogb(size);
    if (rlim >= -kUnscaledExponent && rlim < kUnscaledExponent) return 0;
    float largest = 0.0f, smallest = std::numeric_limits<float>::max(); // |coordinates| and radii
    for (const glm::vec3& x : points.position) {
        for (int k = 0; k < 3; ++k) {
            const float c = std::abs(x[k]);
            largest = std::max(largest, c);
            if (c > 0.0f) smallest = std::min(smallest, c);
        }
    }
    for (const float r : points.radius) smallest = std::min(smallest, r);
    const int wanted = -rlim;
    if (wanted < 0)
        return std::max(wanted,
                        std::min(0, std::numeric_limits<float>::min_exponent - 1 - std::ilogb(smallest)));
    return std::min(wanted, std::max(0, kLargestScaledExponent - (largest > 0.0f ? std::ilogb(largest) : 0)));
}

// r_lim of a level (see the top of this file): the kLargeQuantile quantile of its radii, found by
// reordering `radii`, a copy.
template <typename Radii>
float radiusLimitOf(Radii& radii) {
    const auto k = static_cast<std::size_t>(kLargeQuantile * static_cast<float>(radii.size() - 1));
    std::nth_element(radii.begin(), radii.begin() + static_cast<std::ptrdiff_t>(k), radii.end());
    return radii[k];
}

// Multiplies every position and radius by `factor`, a power of two (exact).
void scalePoints(PointSet& points, float factor, WorkerPool& pool) {
    parallelForRanges(pool, points.size(), 65536, [&](std::size_t begin, std::size_t end, unsigned) {
        for (std::size_t i = begin; i < end; ++i) {
            points.position[i] *= factor;
            points.radius[i] *= factor;
        }
    });
}

} // namespace

RefineOptions RefineOptions::fast() {
    RefineOptions o;
    o.neighbourhood = NeighbourhoodKind::Fuzzy;
    o.euclideanGeodesic = true;
    o.plainAngle = true;
    o.centroidCandidates = true;
    return o;
}

// A level is a script of phases over explicit data: the scale (beginLevel), the segments
// (segments.h), the points skipped, the cells and tiles (level_cells.h), the one-point step of
// every point refined (point_step.h), run tile by tile on the workers (refineCells), and the new
// points appended (appendChildren). The state between levels is P(l), its hierarchy and segments.
struct Refiner::State {
    RefineOptions options;
    WorkerPool pool;
    std::vector<std::uint32_t> inputOrder; // inputOrder[i] = index in the input of P0 point i
    PointSet points;
    PointHierarchy hierarchy;
    Segments segments;
    std::vector<WorkerScratch> scratch; // one per worker

    // The level being built (NewLevel): arrays of one entry per point of P(l) (huge_pages.h), and
    // of one per cell.
    HugePageVector<float> levelRadius; // radii of P(l) at the start of the level (read-only during it)
    HugePageVector<std::uint8_t> refined;
    HugePageVector<ChildRange> childRange;
    HugePageVector<NewPoint*> cellBase;
    std::vector<std::uint32_t> cellCount;
    HugePageVector<PointSource*> cellSources; // when recordsSources()

    // refineRegion: its one level refines only the region's points (not the context points), inserts
    // no point outside the region (scaled with the points during the level), and splits segments
    // at the parity of the global level: levelOffset is the level of P0 here.
    struct RegionRun {
        Region region;
        std::uint32_t levelOffset = 0;
        bool recordParents = false;
        std::vector<std::uint8_t> frozen; // per point of P0: a context point that is not refined
    };
    std::optional<RegionRun> regionRun;
    bool meanNormals = false;                                  // Refiner::setMeanNormals
    std::vector<Hole> refinedBalls;                            // Refiner::setRefinedBalls
    std::vector<std::array<std::uint32_t, 3>> newPointParents; // recordParents: per new point (PointSource)

    State(PointSet input, const RefineOptions& o)
        : options(o), pool(o.threads), points(spatialOrder(std::move(input), inputOrder)),
          hierarchy(points.position), scratch(pool.size()) {}

    LevelStats refineLevel(const ProgressFn& progress);
    // The first steps of a level: its scale applied, levelRadius and the per-point arrays set.
    LevelScale beginLevel();
    // The one-point step over this level (cells: the grid its groups search; none before the cells
    // are made, for findSegmentsOf).
    PointStep pointStep(const LevelScale& level, const LevelCells* cells);
    bool splitsSegments() const {
        const std::uint32_t offset = regionRun ? regionRun->levelOffset : 0;
        return !segments.list.empty() && (hierarchy.levels() + offset) % 2 == 1;
    }

  private:
    // Whether this level stores the source of every new point (NewLevel::cellSources): for the
    // attributes' values, or refineRegion's recordParents.
    bool recordsSources() const { return points.hasAttributes() || (regionRun && regionRun->recordParents); }
    std::vector<std::uint8_t> skippedPoints(float scale) const;
    void refineCells(const PointStep& step, const LevelCells& cells, const ProgressFn& progress);
    HugePageVector<std::uint32_t> appendChildren();
    void addWorkerStats(LevelStats& stats) const;
};

LevelScale Refiner::State::beginLevel() {
    const auto count = static_cast<std::uint32_t>(points.size());
    HugePageVector<float> sortedRadii = points.radius;
    const float unscaledLimit = radiusLimitOf(sortedRadii);
    const Bounds bounds = boundsOf(points.position);
    LevelScale level;
    level.exponent = scaleExponent(points, std::min(unscaledLimit, bounds.extent()));
    level.scale = std::ldexp(1.0f, level.exponent);
    if (level.exponent != 0) scalePoints(points, level.scale, pool);
    level.lo = bounds.lo * level.scale; // exact, as the points'
    level.extent = bounds.extent() * level.scale;
    level.radiusLimit = unscaledLimit * level.scale;
    levelRadius = points.radius;
    hierarchy.updateBounds(points.position);
    refined.assign(count, 0);
    childRange.assign(count, ChildRange{});
    return level;
}

PointStep Refiner::State::pointStep(const LevelScale& level, const LevelCells* cells) {
    LevelView view{options, points,       hierarchy,        levelRadius, {},
                   {},      std::nullopt, splitsSegments(), meanNormals};
    if (cells) {
        view.gridKey = cells->gridKey;
        view.gridPoint = cells->gridPoint;
    }
    if (regionRun)
        view.region = Region{regionRun->region.lo * level.scale, regionRun->region.hi * level.scale};
    return PointStep(
        view, NewLevel{points.radius, refined, childRange, cellBase, cellCount, cellSources, &segments});
}

// Which points of P(l) the level leaves as they are: refineRegion's context points, points outside
// setRefinedBalls' balls, and (adaptive) points within the target radius that own no longer
// segment: their radius covers their new ring, not the segment, which only their refinement splits.
std::vector<std::uint8_t> Refiner::State::skippedPoints(float scale) const {
    const float target = options.targetRadius * scale;
    std::vector<float> longestOwned; // per point, its longest segment (adaptive, with segments)
    if (target > 0.0f && !segments.list.empty()) {
        longestOwned.assign(points.size(), 0.0f);
        for (const Segment& segment : segments.list)
            longestOwned[segment.a] =
                std::max(longestOwned[segment.a], segmentLength(segment, points.position));
    }
    std::vector<std::uint8_t> skipped(points.size());
    for (std::size_t i = 0; i < points.size(); ++i)
        skipped[i] = (regionRun && regionRun->frozen[i]) ||
                     (!refinedBalls.empty() && !insideAny(refinedBalls, points.position[i], scale)) ||
                     (levelRadius[i] <= target && (longestOwned.empty() || longestOwned[i] <= target));
    return skipped;
}

void Refiner::State::refineCells(const PointStep& step, const LevelCells& cells, const ProgressFn& progress) {
    const LevelTiles tiles = tilesOf(cells);
    for (WorkerScratch& s : scratch) {
        s.arena.clear();
        s.sources.clear();
        s.times = {};
        s.inserted = s.discarded = s.retried = s.beyondBound = s.coincident = s.boundaryInserted = s.capped =
            s.outsideRegion = s.scanned = s.neighbours = 0;
        s.columnsOf = kNoCell;
    }
    std::atomic<std::size_t> processed{0};
    // The large points first, then the others; a tile's cells one after the other by one worker.
    for (const bool largeCells : {true, false}) {
        const Tiles& tiled = largeCells ? tiles.large : tiles.small;
        runGraph(pool, tiled.graph, [&](std::uint32_t tile, unsigned worker) {
            std::size_t done = 0;
            for (std::uint32_t k = tiled.cellBegin[tile]; k < tiled.cellBegin[tile + 1]; ++k) {
                step.refineCell(cells, tiled.cells[k], largeCells, scratch[worker]);
                done += cells.cells[tiled.cells[k]].end - cells.cells[tiled.cells[k]].begin;
            }
            const std::size_t total = processed.fetch_add(done, std::memory_order_relaxed) + done;
            if (worker == 0 && progress) progress(total, cells.refinedPoints);
        });
    }
    if (progress) progress(processed.load(), cells.refinedPoints);
}

HugePageVector<std::uint32_t> Refiner::State::appendChildren() {
    const auto count = static_cast<std::uint32_t>(points.size());
    HugePageVector<std::uint32_t> childBegin(count + 1);
    std::uint32_t offset = count;
    for (std::uint32_t i = 0; i < count; ++i) {
        childBegin[i] = offset;
        offset += childRange[i].count;
    }
    childBegin[count] = offset;
    growInParallel(points, hierarchy, offset, pool);
    // Ranges of parents: each writes the children's own range of the arrays.
    parallelForRanges(pool, count, 4096, [&](std::size_t begin, std::size_t end, unsigned) {
        for (auto i = static_cast<std::uint32_t>(begin); i < end; ++i) {
            const ChildRange range = childRange[i];
            for (std::uint32_t k = 0; k < range.count; ++k) {
                const NewPoint& np = cellBase[range.cell][range.begin + k];
                const std::uint32_t o = childBegin[i] + k;
                points.position[o] = np.position;
                points.normal[o] = np.normal;
                points.radius[o] = np.radius;
                if (points.hasColour()) points.colour[o] = np.colour;
                if (points.hasCrease()) points.crease[o] = np.crease;
            }
            // The attributes from the points of P(l) (below `count`, read only here).
            for (Attribute& attribute : points.attributes)
                for (std::uint32_t k = 0; k < range.count; ++k)
                    attribute.values[childBegin[i] + k] =
                        sourcedValue(attribute, cellSources[range.cell][range.begin + k]);
        }
    });
    if (regionRun && regionRun->recordParents) {
        newPointParents.assign(offset - count, {});
        for (std::uint32_t i = 0; i < count; ++i) {
            const ChildRange range = childRange[i];
            for (std::uint32_t k = 0; k < range.count; ++k)
                newPointParents[childBegin[i] + k - count] = cellSources[range.cell][range.begin + k].corners;
        }
    }
    return childBegin;
}

void Refiner::State::addWorkerStats(LevelStats& stats) const {
    for (const WorkerScratch& s : scratch) {
        stats.inserted += s.inserted;
        stats.discarded += s.discarded;
        stats.retried += s.retried;
        stats.beyondBound += s.beyondBound;
        stats.coincident += s.coincident;
        stats.cappedNeighbourhoods += s.capped;
        stats.boundaryInserted += s.boundaryInserted;
        stats.outsideRegion += s.outsideRegion;
        stats.scannedCandidates += s.scanned;
        stats.neighbourhoodPoints += s.neighbours;
        stats.phases.neighbourhood += s.times.neighbourhood;
        stats.phases.filtering += s.times.filtering;
        stats.phases.selection += s.times.selection;
        stats.phases.interpolation += s.times.interpolation;
    }
}

LevelStats Refiner::State::refineLevel(const ProgressFn& progress) {
    const Clock::time_point start = Clock::now();
    const auto count = static_cast<std::uint32_t>(points.size());
    LevelStats stats;
    stats.level = hierarchy.levels();
    stats.pointsBefore = count;
    // The level's scale, then its colouring (see the top of this file).
    const LevelScale level = beginLevel();
    if (stats.level == 1 && !regionRun && (options.boundaries || points.hasCrease()))
        segments.list = findSegmentsOf(pointStep(level, nullptr), count, pool, scratch);
    if (splitsSegments()) segments.indexByFirstPoint(count);
    const std::vector<std::uint8_t> skipped = skippedPoints(level.scale);
    const LevelCells cells = sortIntoCells(points.position, levelRadius, skipped, level, pool);
    stats.refinedPoints = cells.refinedPoints;
    stats.largePoints = cells.largePoints;
    cellBase.assign(cells.cells.size(), nullptr);
    cellCount.assign(cells.cells.size(), 0);
    cellSources.assign(recordsSources() ? cells.cells.size() : 0, nullptr);
    refineCells(pointStep(level, &cells), cells, progress);
    // The new points appended grouped by parent, parents in index order (section 7).
    HugePageVector<std::uint32_t> childBegin = appendChildren();
    if (splitsSegments()) segments.split(childBegin, skipped);
    stats.boundarySegments = segments.list.size();
    hierarchy.addLevel(std::move(childBegin));
    if (level.exponent != 0) scalePoints(points, std::ldexp(1.0f, -level.exponent), pool);
    addWorkerStats(stats);
    stats.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    return stats;
}

Refiner::Refiner(PointSet input, const RefineOptions& options)
    : state_(std::make_unique<State>(std::move(input), options)) {
    assert(validateForRefinement(state_->points).ok());
}

Refiner::~Refiner() = default;
Refiner::Refiner(Refiner&&) noexcept = default;
Refiner& Refiner::operator=(Refiner&&) noexcept = default;

LevelStats Refiner::refineLevel(const ProgressFn& progress) {
    return state_->refineLevel(progress);
}
void Refiner::setTargetRadius(float radius) {
    state_->options.targetRadius = radius;
}
void Refiner::setMeanNormals(bool on) {
    state_->meanNormals = on;
}
void Refiner::setRefinedBalls(std::vector<Hole> balls) {
    state_->refinedBalls = std::move(balls);
}
float Refiner::targetRadius() const {
    return state_->options.targetRadius;
}
const PointSet& Refiner::points() const {
    return state_->points;
}
std::uint32_t Refiner::levels() const {
    return state_->hierarchy.levels() - 1;
}
std::size_t Refiner::levelEnd(std::uint32_t l) const {
    return state_->hierarchy.levelEnd(l);
}
std::size_t Refiner::childBegin(std::uint32_t l, std::size_t i) const {
    return state_->hierarchy.childBegin(l, static_cast<std::uint32_t>(i));
}
std::size_t Refiner::childEnd(std::uint32_t l, std::size_t i) const {
    return state_->hierarchy.childEnd(l, static_cast<std::uint32_t>(i));
}
PointSet Refiner::takePoints() && {
    return std::move(state_->points);
}
std::span<const std::uint32_t> Refiner::inputOrder() const {
    return state_->inputOrder;
}

float Refiner::longestSegment() const {
    float longest = 0.0f;
    for (const Segment& segment : state_->segments.list)
        longest = std::max(longest, segmentLength(segment, state_->points.position));
    return longest;
}

namespace {

// A segment by the positions of its ends (segments between the separate runs of refineRegion).
SegmentEnds endsOf(const Segment& segment, std::span<const glm::vec3> position) {
    return {position[segment.a], position[segment.b], segment.crease};
}

} // namespace

std::vector<SegmentEnds> Refiner::segmentEnds() const {
    std::vector<SegmentEnds> ends;
    ends.reserve(state_->segments.list.size());
    for (const Segment& segment : state_->segments.list)
        ends.push_back(endsOf(segment, state_->points.position));
    return ends;
}

namespace {

// The upper median of `radii`.
float medianRadius(HugePageVector<float> radii) {
    const auto middle = radii.begin() + static_cast<std::ptrdiff_t>(radii.size() / 2);
    std::nth_element(radii.begin(), middle, radii.end());
    return *middle;
}

} // namespace

std::vector<LevelStats> refineDownTo(Refiner& refiner, float targetRadius, unsigned maxLevels,
                                     const ProgressFn& progress) {
    const float previous = refiner.targetRadius();
    refiner.setTargetRadius(targetRadius);
    std::vector<LevelStats> levels;
    while (levels.size() < maxLevels && (std::ranges::max(refiner.points().radius) > targetRadius ||
                                         refiner.longestSegment() > targetRadius)) {
        levels.push_back(refiner.refineLevel(progress));
        if (levels.back().inserted == 0) break;
    }
    refiner.setTargetRadius(previous);
    return levels;
}

std::vector<LevelStats> evenOut(Refiner& refiner, float factor, unsigned maxLevels,
                                const ProgressFn& progress) {
    if (!(factor > 0.0f)) return {};
    return refineDownTo(refiner, factor * medianRadius(refiner.points().radius), maxLevels, progress);
}

Result<HoleRims> enlargeAroundHoles(PointSet& points, std::span<const Hole> holes) {
    assert(points.hasRadius());
    for (std::size_t k = 0; k < holes.size(); ++k) {
        const Hole& hole = holes[k];
        if (!std::isfinite(hole.centre.x) || !std::isfinite(hole.centre.y) || !std::isfinite(hole.centre.z) ||
            !std::isfinite(hole.radius) || !(hole.radius > 0.0f))
            return Error{"hole " + std::to_string(k + 1) +
                         " needs a finite centre and a finite positive radius"};
    }
    HugePageVector<float> radius = points.radius;
    std::vector<bool> reached(holes.size(), false);
    HoleRims rims;
    float largestKept = 0.0f;
    for (std::size_t i = 0; i < points.size(); ++i) {
        for (std::size_t k = 0; k < holes.size(); ++k) {
            const float distance = glm::length(points.position[i] - holes[k].centre);
            if (distance < holes[k].radius)
                return Error{"point " + std::to_string(i) + " lies inside hole " + std::to_string(k + 1) +
                             ", whose ball must hold no input point"};
            if (!(distance < holes[k].radius + points.radius[i])) continue;
            reached[k] = true;
            radius[i] = std::max(radius[i], distance + holes[k].radius);
        }
        if (radius[i] > points.radius[i]) {
            ++rims.enlarged;
        } else {
            largestKept = std::max(largestKept, radius[i]);
        }
    }
    for (std::size_t k = 0; k < holes.size(); ++k)
        if (!reached[k])
            return Error{"hole " + std::to_string(k + 1) +
                         " reaches no point's ball: nothing around it to fill it from"};
    const float median = medianRadius(points.radius);
    rims.fillTarget = std::max(kEvenOutFactor * median, largestKept);
    rims.densityTarget = kHoleDensityFactor * median;
    rims.holes.assign(holes.begin(), holes.end());
    points.radius = std::move(radius);
    return rims;
}

std::vector<LevelStats> fillHoles(Refiner& refiner, const HoleRims& rims, const ProgressFn& progress) {
    refiner.setMeanNormals(true);
    std::vector<LevelStats> levels = refineDownTo(refiner, rims.fillTarget, kHoleFillingLevels, progress);
    refiner.setMeanNormals(false);
    const float previous = refiner.targetRadius();
    refiner.setTargetRadius(rims.densityTarget);
    refiner.setRefinedBalls(rims.holes);
    const auto largestInside = [&] {
        const PointSet& points = refiner.points();
        float largest = 0.0f;
        for (std::size_t i = 0; i < points.size(); ++i)
            if (insideAny(rims.holes, points.position[i], 1.0f))
                largest = std::max(largest, points.radius[i]);
        return largest;
    };
    for (unsigned level = 0; level < kHoleFillingLevels && largestInside() > rims.densityTarget; ++level) {
        levels.push_back(refiner.refineLevel(progress));
        if (levels.back().inserted == 0) break;
    }
    refiner.setRefinedBalls({});
    refiner.setTargetRadius(previous);
    return levels;
}

namespace {

// Positions as bit patterns, ordered: the points of a level have distinct positions, so a position
// names a point (segments between the separate runs of refineRegion).
using PositionKey = std::array<std::uint32_t, 3>;
PositionKey positionKey(glm::vec3 p) {
    return {std::bit_cast<std::uint32_t>(p.x), std::bit_cast<std::uint32_t>(p.y),
            std::bit_cast<std::uint32_t>(p.z)};
}

} // namespace

std::vector<SegmentEnds> findSegments(const PointSet& input, const RefineOptions& options) {
    if (!options.boundaries && !input.hasCrease()) return {};
    Refiner refiner(input, options);
    Refiner::State& state = *refiner.state_;
    // refineLevel's first level, up to its search for segments.
    const LevelScale level = state.beginLevel();
    const std::vector<Segment> found =
        findSegmentsOf(state.pointStep(level, nullptr), static_cast<std::uint32_t>(state.points.size()),
                       state.pool, state.scratch);
    const int exponent = level.exponent;
    if (exponent != 0) scalePoints(state.points, std::ldexp(1.0f, -exponent), state.pool);
    std::vector<SegmentEnds> segments;
    segments.reserve(found.size());
    for (const Segment& segment : found) segments.push_back(endsOf(segment, state.points.position));
    return segments;
}

RegionResult refineRegion(RegionLevel input, const RefineOptions& options) {
    RegionResult result;
    const std::size_t owned = input.owned;
    assert(owned <= input.points.size());
    if (owned == 0) return result;
    RefineOptions local = options;
    local.threads = input.threads;
    local.targetRadius = 0.0f;
    local.profile = false;
    Refiner refiner(std::move(input.points), local);
    Refiner::State& state = *refiner.state_;
    const auto count = static_cast<std::uint32_t>(state.points.size());
    Refiner::State::RegionRun run{input.region, input.level, input.recordParents, {}};
    std::vector<std::uint8_t> context(count);
    run.frozen.resize(count);
    std::vector<std::uint32_t> sortedIndexOf(owned);
    for (std::uint32_t i = 0; i < count; ++i) {
        const std::uint32_t k = state.inputOrder[i];
        context[i] = k >= owned;
        if (k < owned) sortedIndexOf[k] = i;
        assert(k >= owned || input.region.contains(state.points.position[i]));
        // Choice (refiner.h): a context point is refined too where it lies within kRetryReach · r of
        // the region; its candidates lie within c_β,max · r of it (section 8.1), and so do its
        // children that the region's points would see. Farther ones stay frozen.
        const glm::vec3 x = state.points.position[i];
        const float distance = glm::length(x - glm::clamp(x, input.region.lo, input.region.hi));
        run.frozen[i] = context[i] && !(distance <= kRetryReach * state.points.radius[i]);
    }
    // The segments by index: a among the owned points, b anywhere in the set (others are dropped).
    std::vector<std::pair<PositionKey, std::uint32_t>> byPosition(count);
    for (std::uint32_t i = 0; i < count; ++i) byPosition[i] = {positionKey(state.points.position[i]), i};
    std::sort(byPosition.begin(), byPosition.end());
    const auto find = [&](glm::vec3 p) -> std::optional<std::uint32_t> {
        const PositionKey key = positionKey(p);
        const auto at = std::lower_bound(byPosition.begin(), byPosition.end(), std::pair{key, 0u});
        if (at == byPosition.end() || at->first != key) return std::nullopt;
        return at->second;
    };
    for (const SegmentEnds& segment : input.segments) {
        const auto a = find(segment.a), b = find(segment.b);
        if (a && b && !context[*a]) state.segments.list.push_back({*a, *b, segment.crease});
    }
    state.regionRun = std::move(run);
    result.stats = state.refineLevel({});

    const PointSet& all = state.points;
    const std::size_t firstNew = state.hierarchy.levelEnd(0);
    result.points.reserve(owned + all.size() - firstNew);
    for (std::size_t k = 0; k < owned; ++k) result.points.appendFrom(all, sortedIndexOf[k]);
    for (std::size_t i = firstNew; i < all.size(); ++i) result.points.appendFrom(all, i);
    for (const Segment& segment : state.segments.list)
        if (segment.a >= firstNew || !context[segment.a])
            result.segments.push_back(endsOf(segment, all.position));
    result.parents.reserve(state.newPointParents.size());
    for (const auto& corners : state.newPointParents)
        result.parents.push_back(
            {all.position[corners[0]], all.position[corners[1]], all.position[corners[2]]});
    return result;
}

namespace {

// Choice: distinct points too close to tell apart at the first level's scale count as coincident
// too. A level runs scaled by 2^e (scaleExponent), and two points closer than 2^-63 there have a
// squared distance below single precision's smallest normal, 2^-126: the new points between them
// got radii of 0 (fuzz_refine: points 1e-43 apart near the origin, in a set of unit size).
// Let S = 2^24·`separation`. Where two such points differ in a coordinate, both values lie below S:
// distinct floats at or above S in magnitude are an ulp, at least 2^-24 of their magnitude, apart;
// and a float at or above S and one below it are at least the gap below the power of two between
// them apart, which is no less. So one of the two has a nonzero coordinate below S (it is looked
// up), and the other a coordinate below S (it is in the k-d tree, in double precision, of the
// points with one). A set without such points costs one pass. A pair (the one found from the
// looked-up point of smallest index), or nothing.
std::optional<CoincidentPair> findTooClose(const PointSet& points, double separation) {
    const double small = 0x1p24 * separation;
    const auto below = [&](float c) { return std::abs(double{c}) < small; };
    std::vector<std::uint32_t> candidates; // a coordinate below `small`
    std::vector<glm::vec3> positions;
    std::vector<std::uint32_t> queries; // a nonzero one: entries of `candidates`
    for (std::uint32_t i = 0; i < points.size(); ++i) {
        const glm::vec3 x = points.position[i];
        if (!below(x.x) && !below(x.y) && !below(x.z)) continue;
        const auto tiny = [&](float c) { return c != 0.0f && below(c); };
        if (tiny(x.x) || tiny(x.y) || tiny(x.z))
            queries.push_back(static_cast<std::uint32_t>(candidates.size()));
        candidates.push_back(i);
        positions.push_back(x);
    }
    if (queries.empty()) return std::nullopt;
    const KdCloudDouble cloud{positions};
    KdTreeDouble tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    tree.buildIndex();
    for (const std::uint32_t k : queries) {
        const glm::dvec3 x(positions[k]);
        std::uint32_t index[2];
        double distance2[2];
        const std::size_t n = tree.knnSearch(&x.x, 2, index, distance2);
        for (std::size_t m = 0; m < n; ++m) {
            if (index[m] == k || !(distance2[m] < separation * separation)) continue;
            const std::size_t a = candidates[k], b = candidates[index[m]];
            return CoincidentPair{std::min(a, b), std::max(a, b)};
        }
    }
    return std::nullopt;
}

} // namespace

Result<void> validateForRefinement(const PointSet& points) {
    if (points.empty()) return Error{"the point set is empty"};
    if (!points.hasRadius()) return Error{"the point set has no radii"};
    if (points.size() >= (1u << 31)) return Error{"too many points (at most 2^31)"};
    if (points.hasCrease() && points.crease.size() != points.size())
        return Error{"crease normals do not match the points"};
    if (points.normal.size() != points.size()) return Error{"the point set has no normals"};
    for (std::size_t i = 0; i < points.size(); ++i) {
        const glm::vec3 x = points.position[i], n = points.normal[i];
        if (!std::isfinite(x.x) || !std::isfinite(x.y) || !std::isfinite(x.z))
            return Error{"point " + std::to_string(i) + " has a non-finite coordinate"};
        const float length = glm::length(n);
        if (!(std::abs(length - 1.0f) < 1e-3f))
            return Error{"point " + std::to_string(i) + " has a normal that is not of unit length"};
        if (!(points.radius[i] > 0.0f) || !std::isfinite(points.radius[i]))
            return Error{"point " + std::to_string(i) + " has a radius that is not positive and finite"};
        if (!(points.radius[i] >= kMinRadius && points.radius[i] <= kMaxRadius)) {
            const bool small = points.radius[i] < kMinRadius;
            return Error{fmt::format("point {} has a radius of {}, too {} to refine (radii from {} to {} can "
                                     "be): scale the model {}",
                                     i, points.radius[i], small ? "small" : "large", kMinRadius, kMaxRadius,
                                     small ? "up" : "down")};
        }
        if (points.isCrease(i)) {
            const glm::vec3 c = points.crease[i];
            if (!(std::abs(glm::length(c) - 1.0f) < 1e-3f))
                return Error{"point " + std::to_string(i) +
                             " has a crease normal that is neither zero nor of unit length"};
            // Choice: a crease sharper than 170° has no usable bisector plane to refine in.
            if (!(glm::dot(n, c) > kMinCreaseCos))
                return Error{"point " + std::to_string(i) +
                             " has crease normals more than 170 degrees apart"};
        }
    }
    // Cell keys and Morton codes divide by the extent of the set.
    const float extent = boundsOf(points.position).extent();
    if (!std::isfinite(extent))
        return Error{"the points span more than 3.4e38 (coordinates of both signs beyond 1.7e38): scale the "
                     "model down"};
    // Two copies of a point would each insert the same new points (removeCoincident merges them).
    if (const auto pair = findCoincident(points))
        return Error{"points " + std::to_string(pair->first) + " and " + std::to_string(pair->second) +
                     " coincide: the refinement needs distinct positions"};
    std::vector<float> radii(points.radius.begin(), points.radius.end());
    const int exponent = scaleExponent(points, std::min(radiusLimitOf(radii), extent));
    const double separation = std::ldexp(1.0, -63 - exponent);
    if (const auto pair = findTooClose(points, separation))
        return Error{fmt::format("points {} and {} are {:.3g} apart, too close to tell apart at the set's "
                                 "scale (they must be {:.3g} apart): merge them, or remove one",
                                 pair->first, pair->second,
                                 glm::distance(glm::dvec3(points.position[pair->first]),
                                               glm::dvec3(points.position[pair->second])),
                                 separation)};
    return {};
}

} // namespace pnsplat
