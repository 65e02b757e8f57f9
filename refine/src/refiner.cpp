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
// number of threads, so the output is identical for any thread count.
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
#include "pnsplat/refine/hierarchy.h"
#include "pnsplat/refine/huge_pages.h"
#include "pnsplat/refine/morton.h"
#include "pnsplat/refine/neighbourhood.h"
#include "pnsplat/refine/pn_triangle.h"
#include "pnsplat/refine/worker_pool.h"
#include "simd_clone.h"

namespace pnsplat {

namespace {

constexpr float kPi = std::numbers::pi_v<float>;
constexpr float kTwoPi = 2.0f * kPi;
// > 2 and > kRetryReach, see above. Larger cells gather the surroundings of more points at once;
// each point then scans the sub-cells around it (CandidateGrid): 4.5 was the fastest of 2.25, 3,
// 4, 4.5, 5, 6 and 9 (1.06x over 2.25 on the faster variants, 1.04x on the full method; pinned A/B),
// and with the sub-cells still over 3 (sparse bunny, 6 levels, one thread: 2.54 s against 2.63 s).
constexpr float kCellFactor = 4.5f;
constexpr float kLargeQuantile = 0.99f;
constexpr std::size_t kPrefetchAhead =
    16; // grid entries between a point's prefetch and its read: 1.03x over 8 (pinned A/B)
constexpr unsigned kMaxTileShift = 4;         // tiles of at most 16³ cells
constexpr std::size_t kMinTiles = 64;         // tiles of a level, at least (where the cells allow)
constexpr float kMinCreaseCos = -0.98480775f; // cos 170°
// Choice: radii are set a hair above the distances they must reach. Neighbourhoods are open balls
// (|p - p_i| < r, eq. 7) while r' is the distance of the farthest new neighbour, which must stay a
// neighbour at the next level; without the margin it would drop out by rounding.
constexpr float kRadiusMargin = 1.0f + 1.0f / 4096.0f;
// Choice: a candidate competes for a gap of N'_p only if it splits it into two parts of at least
// this angle. Every fan triangle is shared by the fans of its three corners, so its candidate is
// computed up to three times (with rounding noise); once inserted by one corner it is a member of
// the others' N'_p, and its twins, a few ulps away in angle, must not be inserted again.
constexpr float kMinSplitAngle = kThetaC / 8.0f;

using Clock = std::chrono::steady_clock;

// Whether x lies inside one of the balls, their centres and radii times `scale` (a level's
// rescaling, ALGORITHM.md §5.4: a power of two, exact).
bool insideAny(std::span<const Hole> balls, glm::vec3 x, float scale) {
    return std::ranges::any_of(
        balls, [&](const Hole& ball) { return glm::length(x - ball.centre * scale) < ball.radius * scale; });
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
    BlockArena<PointSource> sources;            // beside `arena` when recordSources
    std::size_t inserted = 0, discarded = 0, retried = 0, beyondBound = 0, coincident = 0,
                boundaryInserted = 0, capped = 0, outsideRegion = 0;
    // LevelStats::scannedCandidates and neighbourhoodPoints
    std::size_t scanned = 0, neighbours = 0;
};

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

inline double secondsSince(Clock::time_point& t) {
    const Clock::time_point now = Clock::now();
    const double s = std::chrono::duration<double>(now - t).count();
    t = now;
    return s;
}

// The PN triangle (p, fan[a], fan[b]) without the control points of the edge fan[a] fan[b]
// (b021, b012); those on the edges from p come with the fan when the filter computed them.
inline PnTriangle fanTriangleFromP(glm::vec3 p, glm::vec3 n, const NeighbourSet& fan, std::uint32_t a,
                                   std::uint32_t b) {
    PnTriangle t;
    t.b300 = p;
    t.b030 = fan.position[a];
    t.b003 = fan.position[b];
    if (!fan.nearControl.empty()) {
        t.b210 = fan.nearControl[a];
        t.b120 = fan.farControl[a];
        t.b102 = fan.farControl[b];
        t.b201 = fan.nearControl[b];
        return t;
    }
    const EdgeControls ea = edgeControlPoints(p, n, fan.position[a], fan.normal[a]);
    const EdgeControls eb = edgeControlPoints(p, n, fan.position[b], fan.normal[b]);
    t.b210 = ea.ab;
    t.b120 = ea.ba;
    t.b102 = eb.ba;
    t.b201 = eb.ab;
    return t;
}

// The whole PN triangle (p, fan[a], fan[b]).
inline PnTriangle fanTriangle(glm::vec3 p, glm::vec3 n, const NeighbourSet& fan, std::uint32_t a,
                              std::uint32_t b) {
    PnTriangle t = fanTriangleFromP(p, n, fan, a, b);
    const EdgeControls e = edgeControlPoints(fan.position[a], fan.normal[a], fan.position[b], fan.normal[b]);
    t.b021 = e.ab;
    t.b012 = e.ba;
    return t;
}

// Crease points (section 6) carry two normals (`crease` is zero for an ordinary point). Seen from a
// surface of normal `towards`, a crease point shows the normal of its own side of the crease: the
// one closer to `towards`.
inline glm::vec3 facing(glm::vec3 normal, glm::vec3 crease, glm::vec3 towards) {
    if (crease == glm::vec3(0.0f)) return normal;
    return glm::dot(crease, towards) > glm::dot(normal, towards) ? crease : normal;
}

// Choice: two crease points lie on the same crease when their normals pair up within 45° (the
// paper defers to its dyadic predecessor, which compares normals too).
constexpr float kCreaseMatch = 0.70710678f; // cos 45°
inline bool sameCrease(glm::vec3 n1, glm::vec3 n2, glm::vec3 m1, glm::vec3 m2) {
    return (glm::dot(n1, m1) > kCreaseMatch && glm::dot(n2, m2) > kCreaseMatch) ||
           (glm::dot(n1, m2) > kCreaseMatch && glm::dot(n2, m1) > kCreaseMatch);
}

// The crease direction n1 × n2 of a crease point, of unit length; zero where its two normals are
// less than 1° apart and the direction is undefined (validateForRefinement takes no pair more than
// 170° apart, so nearly opposite normals do not arise). Choice: such a point looks for no crease
// neighbours of its own (creaseNeighbours), and a segment that ends at it leaves it along the
// chord (splitSegments; fuzz_refine: a crease point whose second normal equalled its first gave
// NaN points).
inline glm::vec3 creaseDirection(glm::vec3 n1, glm::vec3 n2) {
    const glm::vec3 d = glm::cross(n1, n2);
    const float length2 = glm::dot(d, d);
    return length2 > kSin2Of1Degree ? d * (1.0f / std::sqrt(length2)) : glm::vec3(0.0f);
}

inline glm::u8vec3 meanColour(glm::u8vec3 a, glm::u8vec3 b, glm::u8vec3 c) {
    const glm::uvec3 sum = glm::uvec3(a) + glm::uvec3(b) + glm::uvec3(c);
    return glm::u8vec3((sum + glm::uvec3(1)) / 3u);
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

// Colour cells (see the top of this file): integer coordinates of 21 bits each, packed x, y, z from
// the most significant bits, so that keys sort by x, then y, then z.
constexpr std::uint64_t kCellCoordinateMask = (1u << 21) - 1;
inline std::uint64_t packCell(std::uint64_t x, std::uint64_t y, std::uint64_t z) {
    return x << 42 | y << 21 | z;
}
inline std::uint64_t cellKeyOf(glm::vec3 x, glm::vec3 lo, float cellSize) {
    const glm::uvec3 c =
        glm::uvec3(glm::clamp((x - lo) / cellSize, glm::vec3(0.0f), glm::vec3(float(kCellCoordinateMask))));
    return packCell(c.x, c.y, c.z);
}

// The axis-aligned bounding box of `positions`, and its longest side.
struct Bounds {
    glm::vec3 lo{std::numeric_limits<float>::max()}, hi{std::numeric_limits<float>::lowest()};
    float extent() const { return std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z}); }
};
Bounds boundsOf(std::span<const glm::vec3> positions) {
    Bounds b;
    for (const glm::vec3& x : positions) {
        b.lo = glm::min(b.lo, x);
        b.hi = glm::max(b.hi, x);
    }
    return b;
}

// P0 sorted along a Morton curve. Children are stored grouped by parent in parent order, so every
// level inherits the order: points close in space are close in memory, and the hierarchy walks
// and neighbourhood gathers touch few cache lines. Ties keep the input order.
PointSet spatialOrder(PointSet input, std::vector<std::uint32_t>& order) {
    const auto count = static_cast<std::uint32_t>(input.size());
    const Bounds bounds = boundsOf(input.position);
    const glm::vec3 lo = bounds.lo;
    const float extent = std::max(bounds.extent(), std::numeric_limits<float>::min());
    const float scale = float((1u << kMortonBits) - 1) / extent;
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(count);
    for (std::uint32_t i = 0; i < count; ++i) {
        const glm::uvec3 q((input.position[i] - lo) * scale);
        keyed[i] = {mortonCode(q.x, q.y, q.z), i};
    }
    std::sort(keyed.begin(), keyed.end());
    order.resize(count);
    PointSet sorted;
    sorted.position.resize(count);
    sorted.normal.resize(count);
    sorted.radius.resize(count);
    if (input.hasColour()) sorted.colour.resize(count);
    if (input.hasCrease()) sorted.crease.resize(count);
    sorted.attributes = emptyAttributesLike(input);
    for (Attribute& a : sorted.attributes) a.values.resize(count);
    for (std::uint32_t k = 0; k < count; ++k) {
        const std::uint32_t i = keyed[k].second;
        order[k] = i;
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

// Sorts (cell key, index) pairs given in increasing index order by key, then index: the order
// std::sort gives them. A stable least-significant-digit radix sort over the bits the keys use,
// in digits of at most 11 bits within each coordinate: typically three passes over the array
// where a comparison sort makes log2(n).
using CellKeys = HugePageVector<std::pair<std::uint64_t, std::uint32_t>>;
void sortCellKeys(CellKeys& keyed) {
    constexpr unsigned kDigitBits = 11;
    std::uint64_t used = 0;
    for (const auto& entry : keyed) used |= entry.first;
    CellKeys buffer(keyed.size());
    for (unsigned field = 0; field < 3; ++field) { // z, y, x
        const auto width =
            static_cast<unsigned>(std::bit_width((used >> (21 * field)) & kCellCoordinateMask));
        for (unsigned low = 0; low < width; low += kDigitBits) {
            const unsigned shift = 21 * field + low;
            const std::uint64_t mask = (std::uint64_t{1} << std::min(kDigitBits, width - low)) - 1;
            std::array<std::uint32_t, std::size_t{1} << kDigitBits> start{}; // counts, then first slots
            for (const auto& entry : keyed) ++start[(entry.first >> shift) & mask];
            std::uint32_t offset = 0;
            for (std::uint32_t& slot : start) offset += std::exchange(slot, offset);
            for (const auto& entry : keyed) buffer[start[(entry.first >> shift) & mask]++] = entry;
            keyed.swap(buffer);
        }
    }
}

// The cells of a level in tiles (see the top of this file): cubes of 2^tileShift cells a side,
// coloured by the parity of their integer coordinates, tiles in key order and a tile's cells in
// key order. Tile k of the task graph waits for its adjacent tiles of lower colours.
struct Cell {
    std::uint32_t begin, end; // into the level's sorted (cell key, point) pairs
};
struct Tiles {
    std::vector<std::uint32_t> cells;     // cell indices, tile after tile
    std::vector<std::uint32_t> cellBegin; // per tile, into cells; tiles + 1 entries
    TaskGraph graph;
};
inline unsigned colourOf(std::uint64_t key) {
    return unsigned((key >> 42) & 1u) << 2 | unsigned((key >> 21) & 1u) << 1 | unsigned(key & 1u);
}
inline std::uint64_t tileKeyOf(std::uint64_t cellKey, unsigned tileShift) {
    return packCell((cellKey >> 42) >> tileShift, ((cellKey >> 21) & kCellCoordinateMask) >> tileShift,
                    (cellKey & kCellCoordinateMask) >> tileShift);
}
// The largest tile shift, at most kMaxTileShift, that leaves at least kMinTiles tiles (0 when
// none does): counted before the task graph is built, once.
unsigned chooseTileShift(const CellKeys& keyed, std::span<const Cell> cells) {
    std::vector<std::uint64_t> tileKeys(cells.size());
    for (unsigned shift = kMaxTileShift; shift > 0; --shift) {
        for (std::size_t c = 0; c < cells.size(); ++c)
            tileKeys[c] = tileKeyOf(keyed[cells[c].begin].first, shift);
        std::sort(tileKeys.begin(), tileKeys.end());
        if (static_cast<std::size_t>(std::unique(tileKeys.begin(), tileKeys.end()) - tileKeys.begin()) >=
            kMinTiles)
            return shift;
    }
    return 0;
}
Tiles makeTiles(const CellKeys& keyed, std::span<const Cell> cells, std::uint32_t firstCell,
                std::uint32_t endCell, unsigned tileShift) {
    std::vector<std::pair<std::uint64_t, std::uint32_t>> tiled; // (tile key, cell), cells in key order
    tiled.reserve(endCell - firstCell);
    for (std::uint32_t c = firstCell; c < endCell; ++c)
        tiled.emplace_back(tileKeyOf(keyed[cells[c].begin].first, tileShift), c);
    std::sort(tiled.begin(), tiled.end());
    Tiles tiles;
    std::vector<std::uint64_t> tileKey;
    for (std::size_t k = 0; k < tiled.size(); ++k) {
        if (k == 0 || tiled[k].first != tiled[k - 1].first) {
            tiles.cellBegin.push_back(static_cast<std::uint32_t>(k));
            tileKey.push_back(tiled[k].first);
        }
        tiles.cells.push_back(tiled[k].second);
    }
    tiles.cellBegin.push_back(static_cast<std::uint32_t>(tiled.size()));
    // Adjacent tiles (the 26 around) differ in colour: the lower colour runs first.
    TaskGraph& graph = tiles.graph;
    graph.waitCount.assign(tileKey.size(), 0);
    graph.successorBegin.push_back(0);
    const std::uint64_t last = kCellCoordinateMask >> tileShift;
    for (std::size_t t = 0; t < tileKey.size(); ++t) {
        const std::uint64_t x = tileKey[t] >> 42, y = (tileKey[t] >> 21) & kCellCoordinateMask;
        const std::uint64_t z = tileKey[t] & kCellCoordinateMask;
        for (std::uint64_t nx = x > 0 ? x - 1 : 0; nx <= std::min(x + 1, last); ++nx)
            for (std::uint64_t ny = y > 0 ? y - 1 : 0; ny <= std::min(y + 1, last); ++ny)
                for (std::uint64_t nz = z > 0 ? z - 1 : 0; nz <= std::min(z + 1, last); ++nz) {
                    const std::uint64_t key = packCell(nx, ny, nz);
                    const auto found = std::lower_bound(tileKey.begin(), tileKey.end(), key);
                    if (found == tileKey.end() || *found != key || colourOf(key) <= colourOf(tileKey[t]))
                        continue;
                    graph.successors.push_back(static_cast<std::uint32_t>(found - tileKey.begin()));
                    ++graph.waitCount[graph.successors.back()];
                }
        graph.successorBegin.push_back(static_cast<std::uint32_t>(graph.successors.size()));
    }
    return tiles;
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

// A level's scale (ALGORITHM.md §5.4; the points are multiplied by `scale` during the level) and
// its extent and r_lim, scaled.
struct LevelScale {
    int exponent = 0;
    float scale = 1.0f;
    glm::vec3 lo{0.0f};
    float extent = 0.0f;
    float radiusLimit = 0.0f;
};

// Which points of P(l) a level leaves as they are (Refiner::State::skips): refineRegion's context
// points, points outside setRefinedBalls' balls, and (adaptive) points within the target radius
// that own no longer segment.
struct LevelSkip {
    float scale = 1.0f;
    float targetRadius = 0.0f;
    std::vector<float> longestOwned; // per point, its longest segment (adaptive, with segments)
};

// The points a level refines, by cell: (cell key, point) pairs, the small points' cells in key
// order, then the large points' (a colouring of their own); `cells` index into `keyed`.
struct LevelCells {
    CellKeys keyed;
    HugePageVector<Cell> cells;
    std::uint32_t smallCells = 0;
};

} // namespace

RefineOptions RefineOptions::fast() {
    RefineOptions o;
    o.neighbourhood = NeighbourhoodKind::Fuzzy;
    o.euclideanGeodesic = true;
    o.plainAngle = true;
    o.centroidCandidates = true;
    return o;
}

struct Refiner::State {
    RefineOptions options;
    WorkerPool pool;
    std::vector<std::uint32_t> inputOrder; // inputOrder[i] = index in the input of P0 point i
    PointSet points;
    PointHierarchy hierarchy;

    // The level being built.
    // Arrays of one entry per point of P(l) (huge_pages.h).
    HugePageVector<float> levelRadius; // radii of P(l) at the start of the level (read-only during it)
    HugePageVector<std::uint8_t> refined;
    HugePageVector<ChildRange> childRange;
    // The points inserted in each cell, contiguous: cellBase[c][0, cellCount[c]), in the arena of
    // the worker that refines the cell.
    HugePageVector<NewPoint*> cellBase;
    std::vector<std::uint32_t> cellCount;
    // Every point of P(l) by colour cell: cell keys in increasing order and the points, (key, index)
    // sorted. A group of points of one cell finds its surroundings here (gatherNearby).
    HugePageVector<std::uint64_t> gridKey;
    HugePageVector<std::uint32_t> gridPoint;
    std::vector<WorkerScratch> scratch;

    // Boundary and crease segments (section 6), found at the first step and kept explicitly. A
    // segment is split by the refinement of its first point, `a`, at every odd step.
    struct Segment {
        std::uint32_t a, b;
        bool crease = false;
    };
    std::vector<Segment> segments;
    std::vector<std::uint32_t> segmentsOf;      // segment indices grouped by first point (this level)
    std::vector<std::uint32_t> segmentsOfBegin; // per point of P(l): range into segmentsOf
    std::vector<std::uint32_t> segmentChild; // per segment: offset of its first new point among a's children
    std::vector<std::uint8_t>
        segmentInserted; // per segment: bit t set when its point at third t+1 was inserted

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
    Region scaledRegion;                                       // regionRun's region during the level
    bool outsideRegion(glm::vec3 q) const { return regionRun && !scaledRegion.contains(q); }
    // Whether this level stores the source of every new point (cellSources): for the attributes'
    // values, or refineRegion's recordParents.
    bool recordSources = false;
    HugePageVector<PointSource*> cellSources; // beside cellBase: cellSources[c][0, cellCount[c])

    State(PointSet input, const RefineOptions& o)
        : options(o), pool(o.threads), points(spatialOrder(std::move(input), inputOrder)),
          hierarchy(points.position), scratch(pool.size()) {}

    PNSPLAT_V3_CLONE void refinePoint(std::uint32_t p, std::uint32_t cell, WorkerScratch& s);
    LevelStats refineLevel(const ProgressFn& progress);
    // The first steps of a level: its scale applied, levelRadius and the per-point arrays set.
    LevelScale beginLevel();
    void findSegments();
    bool splitsSegments() const {
        const std::uint32_t offset = regionRun ? regionRun->levelOffset : 0;
        return !segments.empty() && (hierarchy.levels() + offset) % 2 == 1;
    }
    float segmentLength(const Segment& segment) const {
        return glm::length(points.position[segment.b] - points.position[segment.a]);
    }
    // The neighbourhood filter of the options; `edgeControls`: keep the fan's edge control points.
    FuzzyParams fuzzyParams(bool edgeControls) const {
        FuzzyParams fuzzy;
        fuzzy.thetaF = options.thetaF;
        fuzzy.geodesicProjection = options.neighbourhood == NeighbourhoodKind::Accurate;
        fuzzy.euclideanGeodesic = options.euclideanGeodesic;
        fuzzy.edgeControls = edgeControls;
        return fuzzy;
    }

  private:
    // The steps of refineLevel, in order.
    void indexSegments();
    LevelSkip skipRule(float scale) const;
    bool skips(std::uint32_t i, const LevelSkip& skip) const;
    LevelCells sortIntoCells(const LevelScale& level, const LevelSkip& skip, LevelStats& stats);
    void refineCells(const LevelCells& level, const ProgressFn& progress, std::size_t refinedPoints);
    void refineCell(const LevelCells& level, std::uint32_t c, bool largeCell, WorkerScratch& s);
    HugePageVector<std::uint32_t> appendChildren();
    void splitAllSegments(std::span<const std::uint32_t> childBegin, const LevelSkip& skip);
    void addWorkerStats(LevelStats& stats) const;

    void gatherNearby(std::span<const std::uint32_t> group, std::optional<std::uint64_t> cell,
                      float reachFactor, std::vector<NearbyPoint>& nearby, WorkerScratch& s);
    bool gatherNeighbourhood(std::uint32_t p, const TangentFrame& frame, float reach,
                             std::span<const NearbyPoint> candidates, WorkerScratch& s);
    PNSPLAT_V3_CLONE void collectNeighbourhood(std::uint32_t p, const TangentFrame& frame, float reach,
                                               std::span<const NearbyPoint> candidates, WorkerScratch& s);
    bool fanIsOpen(const NeighbourSet& fan) const;
    glm::vec3 creaseOf(std::uint32_t i) const {
        return points.hasCrease() ? points.crease[i] : glm::vec3(0.0f);
    }
    glm::vec3 planeNormal(std::uint32_t p) const;
    // The corner normals of the fan triangle (p, fan[a], fan[b]) (creases: creaseTriangleNormals).
    bool triangleNormals(std::uint32_t p, const NeighbourSet& fan, std::uint32_t a, std::uint32_t b,
                         glm::vec3 (&normals)[3]) const {
        normals[0] = points.normal[p];
        normals[1] = fan.normal[a];
        normals[2] = fan.normal[b];
        return !points.hasCrease() || creaseTriangleNormals(p, fan, a, b, normals);
    }
    bool creaseTriangleNormals(std::uint32_t p, const NeighbourSet& fan, std::uint32_t a, std::uint32_t b,
                               glm::vec3 (&normals)[3]) const;
    std::array<std::uint32_t, 2> creaseNeighbours(std::uint32_t p, std::span<const NearbyPoint> nearby) const;
    PNSPLAT_V3_CLONE void makeCandidates(std::uint32_t p, const TangentFrame& frame, WorkerScratch& s) const;
    [[gnu::always_inline]] float gapValue(glm::vec3 x, const RingMember& a, const RingMember& b,
                                          std::size_t ringSize) const;
    PNSPLAT_V3_CLONE NewPoint newPointFrom(std::uint32_t p, const NeighbourSet& fan,
                                           const Candidate& c) const;
    void insertIntoRing(std::vector<RingMember>& ring, const RingMember& m) const;
    void splitSegments(std::uint32_t p, std::uint32_t cell, std::uint32_t firstChild, WorkerScratch& s);
    NewPoint& newPoint(const RingMember& m) { return cellBase[m.cell][m.local]; }
    // Whether q may join N'_p: r' = kRadiusMargin·|q - p| stays within c_β,max·r (the convergence
    // bound of ALGORITHM.md §4.7, paper section 8.1), which the choices on Y_p's substitutes, the segments'
    // first points and the candidates of a wider second look rely on.
    bool withinConvergenceBound(std::uint32_t p, glm::vec3 q) const {
        return kRadiusMargin * glm::length(q - points.position[p]) <= kCBetaMax * levelRadius[p];
    }
    // Whether q is the position of the point x being refined or of a point near it: of P(l) within
    // its reach (the last collectNeighbourhood), or of N'_p or Y_p.
    static bool coincidesWithNearby(glm::vec3 q, glm::vec3 x, const WorkerScratch& s) {
        if (q == x) return true;
        for (std::size_t j = 0; j < s.reachable; ++j)
            if (s.reachableFrom[s.inReach[j]].position == q) return true;
        const auto at = [&](const RingMember& m) { return m.position == q; };
        return std::any_of(s.ring.begin(), s.ring.end(), at) ||
               std::any_of(s.outer.begin(), s.outer.end(), at);
    }
    // Whether q is the position of a child of `corner`, a corner of the fan triangle that made q:
    // the same triangle in the corner's own fan makes the same PN centre, and the corner's children
    // are not always among Y_p (p within the corner's fan reach, the corner not within p's).
    // A corner within reach was refined before p or is refined after it, never at the same time
    // (ALGORITHM.md §5.2), so its children are read whole.
    bool madeByCorner(glm::vec3 q, std::uint32_t corner) const {
        if (!refined[corner]) return false;
        const ChildRange range = childRange[corner];
        const NewPoint* children = cellBase[range.cell] + range.begin;
        return std::any_of(children, children + range.count,
                           [&](const NewPoint& c) { return c.position == q; });
    }
    // Appends np, made from `source`, to `cell`, refined by the worker of `s`; returns its index in
    // the cell.
    std::uint32_t store(std::uint32_t cell, const NewPoint& np, const PointSource& source, WorkerScratch& s) {
        s.arena.append(cellBase[cell], cellCount[cell], np);
        if (recordSources) s.sources.append(cellSources[cell], cellCount[cell], source);
        return cellCount[cell]++;
    }
};

// The points of P(l) that the refinement of a group of points (one cell, or one large point) may
// need: every point within reachFactor·r_max of the group's box, found once, into `nearby`. Each
// point of the group then picks its Euclidean neighbourhood from this short list, which costs far
// less than one search per point. reachFactor is 1 for the first search and kRetryReach for a
// point searched again wider (rare: a group of its own then). The points of one colour cell (key
// `cell`) have r <= r_lim, so the box grown by kRetryReach·r_max < s stays within the 3×3×3 cells
// around theirs, read from the grid; a single large point is found through the bounding-sphere
// hierarchy (section 7). Both give the same set; its order does not matter (the neighbourhoods
// are sorted, and Y_p breaks ties in distance by storage position).
void Refiner::State::gatherNearby(std::span<const std::uint32_t> group, std::optional<std::uint64_t> cell,
                                  float reachFactor, std::vector<NearbyPoint>& nearby, WorkerScratch& s) {
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(std::numeric_limits<float>::lowest());
    float largest = 0.0f;
    for (const std::uint32_t p : group) {
        lo = glm::min(lo, points.position[p]);
        hi = glm::max(hi, points.position[p]);
        largest = std::max(largest, levelRadius[p]);
    }
    const float margin = reachFactor * largest;
    Clock::time_point t0;
    if (options.profile) t0 = Clock::now();
    nearby.clear();
    if (!cell) {
        hierarchy.queryBox(lo, hi, margin, s.stack, [&](std::uint32_t i, float d2) {
            if (d2 <= margin * margin) nearby.push_back(NearbyPoint{points.position[i], i, points.normal[i]});
        });
    } else {
        const std::uint64_t cx = *cell >> 42, cy = (*cell >> 21) & kCellCoordinateMask;
        const std::uint64_t cz = *cell & kCellCoordinateMask;
        const std::uint64_t z0 = cz > 0 ? cz - 1 : 0, z1 = std::min(cz + 1, kCellCoordinateMask);
        // Each column's start only moves forward from one cell to the next of larger key (with the
        // same offsets, a larger key gives larger column keys): search forward from the last one,
        // in steps that double, then by halves.
        if (s.columnsOf == kNoCell || *cell < s.columnsOf) s.columnStart.fill(0);
        s.columnsOf = *cell;
        const auto seek = [&](std::size_t from, std::uint64_t key) {
            std::size_t below = from, above = from; // gridKey[k] < key for every k < below
            for (std::size_t step = 1; above < gridKey.size() && gridKey[above] < key; step *= 2) {
                below = above + 1;
                above += step;
            }
            const auto end = gridKey.begin() + static_cast<std::ptrdiff_t>(std::min(above, gridKey.size()));
            return static_cast<std::size_t>(
                std::lower_bound(gridKey.begin() + static_cast<std::ptrdiff_t>(below), end, key) -
                gridKey.begin());
        };
        for (std::uint64_t x = cx > 0 ? cx - 1 : 0; x <= std::min(cx + 1, kCellCoordinateMask); ++x) {
            for (std::uint64_t y = cy > 0 ? cy - 1 : 0; y <= std::min(cy + 1, kCellCoordinateMask); ++y) {
                // The cells (x, y, z0..z1) are consecutive in key order.
                const std::uint64_t last = packCell(x, y, z1);
                std::size_t& start = s.columnStart[3 * (x + 1 - cx) + (y + 1 - cy)];
                start = seek(start, packCell(x, y, z0));
                for (std::size_t k = start; k < gridKey.size() && gridKey[k] <= last; ++k) {
                    // The distance to the box as the hierarchy measures it.
                    const std::uint32_t i = gridPoint[k];
                    if (k + kPrefetchAhead < gridPoint.size()) {
                        __builtin_prefetch(&points.position[gridPoint[k + kPrefetchAhead]]);
                        __builtin_prefetch(&points.normal[gridPoint[k + kPrefetchAhead]]);
                    }
                    const glm::vec3 d = points.position[i] - glm::clamp(points.position[i], lo, hi);
                    if (glm::dot(d, d) <= margin * margin)
                        nearby.push_back(NearbyPoint{points.position[i], i, points.normal[i]});
                }
            }
        }
    }
    // Every point of the group reads the children of the refined points among these (and then
    // again from cache): start their loads, the child ranges first.
    for (const NearbyPoint& c : nearby) __builtin_prefetch(&childRange[c.index]);
    for (const NearbyPoint& c : nearby) {
        if (!refined[c.index]) continue;
        const ChildRange range = childRange[c.index];
        const auto* children = reinterpret_cast<const char*>(cellBase[range.cell] + range.begin);
        for (std::size_t line = 0; line < range.count * sizeof(NewPoint); line += 64)
            __builtin_prefetch(children + line);
    }
    if (options.profile) s.times.neighbourhood += secondsSince(t0);
}

// Nε_p, N'_p and Y_p of p within `reach`. When more than options.maxNeighbours points pass, only
// the maxNeighbours nearest points within reach (ties by index) are kept and then checked against
// the validity cone, so N'_p and Y_p hold the children of those only. Returns whether it cut: a
// wider reach would keep the same points.
bool Refiner::State::gatherNeighbourhood(std::uint32_t p, const TangentFrame& frame, float reach,
                                         std::span<const NearbyPoint> candidates, WorkerScratch& s) {
    collectNeighbourhood(p, frame, reach, candidates, s);
    const std::size_t cap = options.maxNeighbours;
    if (s.fan.size() <= cap) return false;
    const glm::vec3 x = points.position[p];
    const auto distance2 = [&](const NearbyPoint& c) { return glm::dot(c.position - x, c.position - x); };
    s.nearest.clear();
    for (const NearbyPoint& c : candidates)
        if (c.index != p && distance2(c) < reach * reach) s.nearest.push_back(c);
    if (s.nearest.size() <= cap) return false; // the same points (rounding aside)
    ++s.capped;
    const auto middle = s.nearest.begin() + static_cast<std::ptrdiff_t>(cap);
    std::nth_element(s.nearest.begin(), middle, s.nearest.end(),
                     [&](const NearbyPoint& a, const NearbyPoint& b) {
                         const float da = distance2(a), db = distance2(b);
                         return da != db ? da < db : a.index < b.index;
                     });
    s.nearest.erase(middle, s.nearest.end());
    collectNeighbourhood(p, frame, reach, s.nearest, s);
    return true;
}

// Nε_p, N'_p and Y_p of p among `candidates`; `frame` is the tangent frame of planeNormal(p).
// Crease points show the normal of p's side (facing); a crease point p pairs each neighbour with
// the closer of its own two normals for the validity cone.
void Refiner::State::collectNeighbourhood(std::uint32_t p, const TangentFrame& frame, float reach,
                                          std::span<const NearbyPoint> candidates, WorkerScratch& s) {
    const glm::vec3 x = points.position[p];
    const glm::vec3 n = frame.n;
    const bool creases = points.hasCrease();
    const bool creaseP = points.isCrease(p);
    const float r = levelRadius[p];
    const float reach2 = reach * reach;
    const float r2 = r * r, inner2 = kLambda1 * kLambda1 * r2;
    s.scanned += candidates.size();
    s.fan.clear();
    s.ring.clear();
    s.outer.clear();
    // Nε_p (eq. 7): points of P(l) closer than r that pass the validity cone (eq. 6). Most
    // candidates are out of reach: they are sorted out first, without branches.
    s.inReach.resize(candidates.size());
    std::size_t inReach = 0;
    for (std::size_t k = 0; k < candidates.size(); ++k) {
        const glm::vec3 d = candidates[k].position - x;
        s.inReach[inReach] = static_cast<std::uint32_t>(k);
        inReach += static_cast<std::size_t>(glm::dot(d, d) < reach2) &
                   static_cast<std::size_t>(candidates[k].index != p);
    }
    s.reachableFrom = candidates;
    s.reachable = inReach;
    for (std::size_t j = 0; j < inReach; ++j) {
        const NearbyPoint& candidate = candidates[s.inReach[j]];
        const std::uint32_t i = candidate.index;
        glm::vec3 ni = candidate.normal, np = n;
        if (creases) {
            ni = facing(candidate.normal, points.crease[i], n);
            if (creaseP) {
                const glm::vec3 n1 = points.normal[p], n2 = points.crease[p];
                const glm::vec3 m1 = facing(candidate.normal, points.crease[i], n1);
                const glm::vec3 m2 = facing(candidate.normal, points.crease[i], n2);
                const bool first = glm::dot(n1, m1) >= glm::dot(n2, m2);
                np = first ? n1 : n2;
                ni = first ? m1 : m2;
            }
        }
        if (!validNeighbours(x, np, candidate.position, ni)) continue;
        s.fan.push(i, candidate.position, ni);
        // The points already inserted near p are the children of its neighbours (section 7). Only
        // points within p's reach are read here, and none of them is refined concurrently.
        if (!refined[i]) continue;
        const ChildRange range = childRange[i];
        const NewPoint* children = cellBase[range.cell] + range.begin;
        for (std::uint32_t k = 0; k < range.count; ++k) {
            const glm::vec3 d = children[k].position - x;
            const float distance2 = glm::dot(d, d);
            // N'_p (section 5) within λ1·r, Y_p (eq. 10) beyond; neither at exactly λ1·r. The member
            // is written where it is stored (a copy from the stack stalled on store forwarding).
            if (!(distance2 < r2) || distance2 == inner2) continue;
            const bool inner = distance2 < inner2;
            RingMember& m = inner ? s.ring.emplace_back() : s.outer.emplace_back();
            m.cell = range.cell;
            m.local = range.begin + k;
            m.position = children[k].position;
            m.normal = facing(children[k].normal, children[k].crease, n);
            m.angle = inner ? frame.angleOf(d) : 0.0f; // Y_p's is needed only if it joins N'_p
            m.discardRadius = inner ? 0.0f : kLambda2 * children[k].radius;
        }
    }
}

// The plane a point is refined in: its normal, or for a crease point the bisector of its two.
glm::vec3 Refiner::State::planeNormal(std::uint32_t p) const {
    return points.isCrease(p) ? glm::normalize(points.normal[p] + points.crease[p]) : points.normal[p];
}

// Creases (section 6): the corner normals of the fan triangle (p, fan[a], fan[b]), or false for
// a triangle across a crease, which would cut the edge off (the crease itself is filled by its
// segments). Choices: for a crease point p, a neighbour is on the side of the normal of p that
// it faces, or on the crease when it is a crease point of the same crease; a triangle takes the
// side of its corners, must not have two, and needs a corner off the crease. For an ordinary p,
// a triangle with a crease corner must have its other ordinary corner on p's side of it.
bool Refiner::State::creaseTriangleNormals(std::uint32_t p, const NeighbourSet& fan, std::uint32_t a,
                                           std::uint32_t b, glm::vec3 (&normals)[3]) const {
    const std::uint32_t corner[2] = {fan.index[a], fan.index[b]};
    if (points.isCrease(p)) {
        const glm::vec3 n1 = points.normal[p], n2 = points.crease[p];
        int sides[2];
        for (int k = 0; k < 2; ++k) {
            const std::uint32_t i = corner[k];
            if (points.isCrease(i) && sameCrease(n1, n2, points.normal[i], points.crease[i]))
                sides[k] = -1;
            else
                sides[k] = glm::dot(n1, normals[1 + k]) >= glm::dot(n2, normals[1 + k]) ? 0 : 1;
        }
        if (sides[0] < 0 && sides[1] < 0) return false;
        if (sides[0] >= 0 && sides[1] >= 0 && sides[0] != sides[1]) return false;
        normals[0] = std::max(sides[0], sides[1]) == 0 ? n1 : n2;
        for (int k = 0; k < 2; ++k)
            normals[1 + k] = facing(points.normal[corner[k]], points.crease[corner[k]], normals[0]);
        return true;
    }
    for (int k = 0; k < 2; ++k) {
        const std::uint32_t c = corner[k], other = corner[1 - k];
        if (!points.isCrease(c) || points.isCrease(other)) continue;
        const glm::vec3 mine = normals[1 + k];
        const glm::vec3 theirs = mine == points.normal[c] ? points.crease[c] : points.normal[c];
        if (glm::dot(normals[2 - k], theirs) > glm::dot(normals[2 - k], mine)) return false;
    }
    return true;
}

void Refiner::State::makeCandidates(std::uint32_t p, const TangentFrame& frame, WorkerScratch& s) const {
    const glm::vec3 x = points.position[p];
    const glm::vec3 n = points.normal[p];
    const bool creaseP = points.isCrease(p);
    const NeighbourSet& fan = s.fan;
    const std::size_t m = fan.size();
    s.candidates.clear();
    if (m < 2) return;
    for (std::uint32_t a = 0; a < m; ++a) {
        const auto b = static_cast<std::uint32_t>(nextIndex(a, m));
        // Boundary gap (section 6): no triangle across an opening wider than θb.
        if (sweep(fan.angle[a], fan.angle[b]) > options.thetaB) continue;
        Candidate c;
        glm::vec3 normals[3];
        if (!triangleNormals(p, fan, a, b, normals)) continue;
        const glm::vec3 cog = centreOfGravity(x, fan.position[a], fan.position[b]);
        // L_p (eq. 12): cog + φ on the PN triangle (p, p_a, p_b); the plain centroid for the
        // baseline and for variant 4, which smooths only what it inserts. The fan's edge control
        // points were made with n_p: a crease point makes its triangles with its side's normal.
        if (!options.smoothing || options.centroidCandidates) {
            c.position = cog;
        } else {
            const PnTriangle t = creaseP ? makePnTriangle(x, normals[0], fan.position[a], normals[1],
                                                          fan.position[b], normals[2])
                                         : fanTriangle(x, n, fan, a, b);
            c.position = cog + smoothingDisplacement(t);
            c.b021 = t.b021;
            c.b012 = t.b012;
        }
        c.angle = frame.angleOf(c.position - x);
        c.a = a;
        c.b = b;
        s.candidates.push_back(c);
    }
}

// Whether consecutive fan neighbours leave an opening wider than θb around p (section 6).
bool Refiner::State::fanIsOpen(const NeighbourSet& fan) const {
    const std::size_t m = fan.size();
    if (m < 2) return true;
    for (std::size_t a = 0; a < m; ++a)
        if (sweep(fan.angle[a], fan.angle[nextIndex(a, m)]) > options.thetaB) return true;
    return false;
}

// The point inserted for candidate c of p: its normal from the exact tangents of the PN triangle
// (section 3), its colour the mean of the corners' (section 8, figure 12).
NewPoint Refiner::State::newPointFrom(std::uint32_t p, const NeighbourSet& fan, const Candidate& c) const {
    const glm::vec3 x = points.position[p];
    glm::vec3 n = points.normal[p], na = fan.normal[c.a], nb = fan.normal[c.b];
    const bool creaseP = points.isCrease(p);
    if (creaseP) {
        glm::vec3 normals[3];
        triangleNormals(p, fan, c.a, c.b, normals);
        n = normals[0], na = normals[1], nb = normals[2];
    }
    NewPoint np{c.position, glm::vec3(0.0f), 0.0f, glm::u8vec3(0)};
    if (!options.smoothing) {
        np.normal = meanNormal(n, na, nb);
    } else {
        PnTriangle t;
        if (creaseP) {
            t = makePnTriangle(x, n, fan.position[c.a], na, fan.position[c.b], nb);
            if (options.centroidCandidates) np.position = c.position + smoothingDisplacement(t);
        } else if (options.centroidCandidates) {
            t = fanTriangle(x, n, fan, c.a, c.b);
            np.position = c.position + smoothingDisplacement(t);
        } else {
            t = fanTriangleFromP(x, n, fan, c.a, c.b);
            t.b021 = c.b021;
            t.b012 = c.b012;
        }
        np.normal = meanNormals ? meanNormal(n, na, nb) : centreNormal(t, n, na, nb);
    }
    if (points.hasColour())
        np.colour =
            meanColour(points.colour[p], points.colour[fan.index[c.a]], points.colour[fan.index[c.b]]);
    return np;
}

// The "curved angle" between consecutive members of N'_p (eq. 5), or their plain angle
// (variant 2). A gap wider than π cannot be measured by unsigned angles: its counter-clockwise
// sweep is used, which is always above θc. Gaps are only compared with θc and ranked above it,
// so an angle surely below θc is not measured (curvedAngleUnlessSmall, angleAtUnlessSmall).
// Always inlined: refinePoint's x86-64-v3 clone calls it out of line otherwise.
inline float Refiner::State::gapValue(glm::vec3 x, const RingMember& a, const RingMember& b,
                                      std::size_t ringSize) const {
    const float s = ringSize == 1 ? kTwoPi : sweep(a.angle, b.angle);
    if (s > kPi) return s;
    if (options.plainAngle) return angleAtUnlessSmall(x, a.position, b.position);
    return curvedAngleUnlessSmall(x, a.position, a.normal, b.position, b.normal);
}

void Refiner::State::insertIntoRing(std::vector<RingMember>& ring, const RingMember& m) const {
    auto at = std::upper_bound(ring.begin(), ring.end(), m,
                               [](const RingMember& u, const RingMember& v) { return u.angle < v.angle; });
    at = ring.insert(at, m);
    // The gaps before and after the new member change.
    const std::size_t k = static_cast<std::size_t>(at - ring.begin());
    ring[k].gapStale = true;
    ring[previousIndex(k, ring.size())].gapStale = true;
}

// Segments (section 6): a segment (a, b) receives two new points, at the thirds of the cubic
// Bézier curve a, c1, c2, b, at every odd step; never one at the middle. They are children of a;
// the one next to a joins N'_a. Boundary: c1, c2 are the edge control points of ALGORITHM.md §2.2 (tangents
// in the tangent planes); normal and colour interpolated along the curve (choice: the paper gives
// none for boundary points). Crease: the curve leaves each end along its crease direction n1 × n2,
// with the same |ab|/3 legs, and the new points are crease points whose two normals interpolate
// the ends' paired normals.
void Refiner::State::splitSegments(std::uint32_t p, std::uint32_t cell, std::uint32_t firstChild,
                                   WorkerScratch& s) {
    const glm::vec3 x = points.position[p];
    const glm::vec3 n = points.normal[p], nc = creaseOf(p);
    const TangentFrame frame(planeNormal(p));
    for (std::uint32_t k = segmentsOfBegin[p]; k < segmentsOfBegin[p + 1]; ++k) {
        const std::uint32_t segment = segmentsOf[k];
        const std::uint32_t b = segments[segment].b;
        const glm::vec3 pb = points.position[b];
        glm::vec3 nb = points.normal[b], nbc = creaseOf(b);
        glm::vec3 c1, c2;
        if (segments[segment].crease) {
            const glm::vec3 chord = pb - x;
            const float leg = glm::length(chord) / 3.0f;
            const float chord2 = glm::dot(chord, chord);
            const glm::vec3 along = chord2 >= std::numeric_limits<float>::min()
                                        ? chord * (1.0f / std::sqrt(chord2))
                                        : glm::vec3(0.0f);
            const auto directionAt = [&](glm::vec3 first, glm::vec3 second) {
                const glm::vec3 d = creaseDirection(first, second);
                return d == glm::vec3(0.0f) ? along : d;
            };
            glm::vec3 ta = directionAt(n, nc), tb = directionAt(nb, nbc);
            if (glm::dot(ta, chord) < 0.0f) ta = -ta;
            if (glm::dot(tb, chord) < 0.0f) tb = -tb;
            c1 = x + leg * ta;
            c2 = pb - leg * tb;
            if (glm::dot(n, nb) + glm::dot(nc, nbc) < glm::dot(n, nbc) + glm::dot(nc, nb)) std::swap(nb, nbc);
        } else {
            const EdgeControls e = edgeControlPoints(x, n, pb, nb);
            c1 = e.ab;
            c2 = e.ba;
        }
        segmentChild[segment] = cellCount[cell] - firstChild;
        segmentInserted[segment] = 0;
        glm::vec3 curve[2];
        for (int third = 1; third <= 2; ++third) {
            const float t = static_cast<float>(third) / 3.0f, u = 1.0f - t;
            curve[third - 1] = u * u * u * x + 3.0f * u * u * t * c1 + 3.0f * u * t * t * c2 + t * t * t * pb;
        }
        for (int third = 1; third <= 2; ++third) {
            const float t = static_cast<float>(third) / 3.0f;
            const glm::vec3 q = curve[third - 1];
            if (outsideRegion(q)) { // refineRegion: choice, as for candidates (refiner.h)
                ++s.outsideRegion;
                continue;
            }
            segmentInserted[segment] |= static_cast<std::uint8_t>(1u << (third - 1));
            const glm::vec3 before = third == 1 ? x : curve[0], after = third == 1 ? curve[1] : pb;
            NewPoint np{q, glm::normalize((1.0f - t) * n + t * nb),
                        kRadiusMargin * std::max(glm::length(q - before), glm::length(q - after)),
                        glm::u8vec3(0)};
            if (segments[segment].crease) np.crease = glm::normalize((1.0f - t) * nc + t * nbc);
            if (points.hasColour())
                np.colour = glm::u8vec3(
                    glm::round(glm::mix(glm::vec3(points.colour[p]), glm::vec3(points.colour[b]), t)));
            const std::uint32_t local = store(cell, np, PointSource{{p, b, b}, t}, s);
            ++s.inserted;
            ++s.boundaryInserted;
            // The first point joins N'_p (it fills the gap along the segment), unless it lies
            // farther than c_β,max · r_p: choice, as for Y_p's substitutes, so that r' stays within
            // the convergence bound of ALGORITHM.md §4.7 (a segment may be up to kRetryReach · r long).
            if (third == 1 && withinConvergenceBound(p, q))
                insertIntoRing(s.ring, RingMember{cell, local, q, facing(np.normal, np.crease, frame.n),
                                                  frame.angleOf(q - x)});
        }
    }
}

// Crease neighbours of a crease point p (section 6): among the crease points of the same crease
// closer than kRetryReach·r_p (the points gathered for the wider second look), the nearest on
// each side along the crease direction n1 × n2 (choice: within 45° of it, so that a point of a
// parallel crease is not taken). UINT32_MAX where there is none. Choice: not only those that pass
// the fuzzy filter into p's fan. An edge is sampled as sparsely as the faces beside it, and the
// filtered first ring of a crease point often holds no crease point ahead: on the fandisk's 179
// crease points the fans gave 61 segments, r gives 92 and 1.5 r 123 (RefinerCreases). A segment
// longer than r_p needs splitSegments' guard on N'_p for the convergence bound of ALGORITHM.md §4.7; with it,
// wider balls (2 r, 3 r) still broke the bound at level 5 (r'/r up to 0.983). None for a point
// whose two normals are less than 1° apart (creaseDirection; before, such points within 1° of
// parallel found neighbours along a direction made of rounding, and exactly parallel ones none).
std::array<std::uint32_t, 2> Refiner::State::creaseNeighbours(std::uint32_t p,
                                                              std::span<const NearbyPoint> nearby) const {
    const glm::vec3 x = points.position[p], n1 = points.normal[p], n2 = points.crease[p];
    const glm::vec3 direction = creaseDirection(n1, n2);
    std::array<std::uint32_t, 2> ends{UINT32_MAX, UINT32_MAX};
    if (direction == glm::vec3(0.0f)) return ends;
    const float reach = kRetryReach * levelRadius[p];
    std::array<float, 2> nearest{std::numeric_limits<float>::max(), std::numeric_limits<float>::max()};
    for (const NearbyPoint& candidate : nearby) {
        const std::uint32_t i = candidate.index;
        if (i == p || !points.isCrease(i) || !sameCrease(n1, n2, points.normal[i], points.crease[i]))
            continue;
        const glm::vec3 d = candidate.position - x;
        const float along = glm::dot(d, direction), length = glm::length(d);
        if (!(length < reach) || !(std::abs(along) > kCreaseMatch * length)) continue;
        const int end = along > 0.0f ? 0 : 1;
        if (length < nearest[end] || (length == nearest[end] && i < ends[end]))
            nearest[end] = length, ends[end] = i;
    }
    return ends;
}

// The segments of section 6, from the neighbourhoods of P0. Boundary: potential boundary points are those
// whose fan leaves an opening wider than θb (after the wider second search); the two fan
// neighbours at the ends of the opening, when they are potential boundary points too, make
// boundary segments with the point. Crease: each crease point with its crease neighbours (in its
// ball, creaseNeighbours).
void Refiner::State::findSegments() {
    const auto count = static_cast<std::uint32_t>(points.size());
    std::vector<std::uint8_t> potential(count, 0);
    std::vector<std::array<std::uint32_t, 2>> ends(count), creaseEnds(count, {UINT32_MAX, UINT32_MAX});
    const FuzzyParams fuzzy = fuzzyParams(false);
    pool.parallelFor(count, [&](std::size_t item, unsigned worker) {
        const auto p = static_cast<std::uint32_t>(item);
        WorkerScratch& s = scratch[worker];
        const glm::vec3 x = points.position[p], n = planeNormal(p);
        const TangentFrame frame(n);
        gatherNearby(std::span(&p, 1), std::nullopt, kRetryReach, s.nearby, s);
        bool open = true;
        for (const float reach : {levelRadius[p], kRetryReach * levelRadius[p]}) {
            const bool cut = gatherNeighbourhood(p, frame, reach, s.nearby, s);
            filterFuzzy(x, n, fuzzy, s.fan, s.neighbourhood);
            if (!fanIsOpen(s.fan)) {
                open = false;
                break;
            }
            if (cut) break; // a wider search would keep the same neighbours
        }
        if (points.isCrease(p)) creaseEnds[p] = creaseNeighbours(p, s.nearby);
        const std::size_t m = s.fan.size();
        if (!options.boundaries || !open || m < 2) return; // closed, or isolated: no direction to follow
        std::size_t widest = 0;
        for (std::size_t a = 1; a < m; ++a)
            if (sweep(s.fan.angle[a], s.fan.angle[nextIndex(a, m)]) >
                sweep(s.fan.angle[widest], s.fan.angle[nextIndex(widest, m)]))
                widest = a;
        potential[p] = 1;
        ends[p] = {s.fan.index[widest], s.fan.index[nextIndex(widest, m)]};
    });
    segments.clear();
    for (std::uint32_t p = 0; p < count; ++p) {
        if (potential[p])
            for (const std::uint32_t q : ends[p])
                if (potential[q]) segments.push_back(Segment{std::min(p, q), std::max(p, q), false});
        for (const std::uint32_t q : creaseEnds[p])
            if (q != UINT32_MAX) segments.push_back(Segment{std::min(p, q), std::max(p, q), true});
    }
    // A pair found both ways, or as a boundary and a crease, is one segment (a crease if either).
    std::sort(segments.begin(), segments.end(), [](const Segment& u, const Segment& v) {
        return u.a != v.a ? u.a < v.a : u.b != v.b ? u.b < v.b : u.crease > v.crease;
    });
    segments.erase(std::unique(segments.begin(), segments.end(),
                               [](const Segment& u, const Segment& v) { return u.a == v.a && u.b == v.b; }),
                   segments.end());
}

// One function on purpose, though long: split into steps (always inlined) it ran 2.5-5 %
// slower on one thread, twice (d86c966, 61ad2ac: bench refine of the lion at level 5, binaries
// alternated), and so did the smallest change measured, its lambda candidateIn made a function.
void Refiner::State::refinePoint(std::uint32_t p, std::uint32_t cell, WorkerScratch& s) {
    const bool profile = options.profile;
    Clock::time_point t0;
    if (profile) t0 = Clock::now();

    const glm::vec3 x = points.position[p];
    const glm::vec3 n = planeNormal(p);
    const FuzzyParams fuzzy =
        fuzzyParams(options.smoothing && !options.centroidCandidates); // PN-centre candidates
    const TangentFrame frame(n);
    std::span<const NearbyPoint> nearby = s.nearby;
    if (s.groupCell) {
        s.nearbyGrid.select(x, levelRadius[p], s.pointNearby);
        nearby = s.pointNearby;
    }
    const bool cut = gatherNeighbourhood(p, frame, levelRadius[p], nearby, s);
    std::size_t neighbours = s.fan.size();
    if (profile) s.times.neighbourhood += secondsSince(t0);
    filterFuzzy(x, n, fuzzy, s.fan, s.neighbourhood);
    if (profile) s.times.filtering += secondsSince(t0);
    if (!cut && fanIsOpen(s.fan)) {
        // Choice: a fan open wider than θb may be a boundary, or a radius that fell short of the
        // natural first ring on one side (the radius update only reaches N'_p). Look once more
        // within kRetryReach·r before treating it as a boundary; the new one-ring then reaches
        // across, and the gap is filled at this level instead of staying a hole.
        ++s.retried;
        gatherNearby(std::span(&p, 1), s.groupCell, kRetryReach, s.wideNearby, s);
        if (profile) t0 = Clock::now(); // gatherNearby counted its own time
        gatherNeighbourhood(p, frame, kRetryReach * levelRadius[p], s.wideNearby, s);
        neighbours = s.fan.size();
        if (profile) s.times.neighbourhood += secondsSince(t0);
        filterFuzzy(x, n, fuzzy, s.fan, s.neighbourhood);
        if (profile) s.times.filtering += secondsSince(t0);
    }
    s.neighbours += neighbours;

    makeCandidates(p, frame, s);
    if (profile) s.times.interpolation += secondsSince(t0);

    // N'_p sorted around n_p; ties broken by storage position, which is deterministic.
    std::sort(s.ring.begin(), s.ring.end(), [](const RingMember& a, const RingMember& b) {
        return a.angle != b.angle ? a.angle < b.angle : storedBefore(a, b);
    });

    std::vector<RingMember>& ring = s.ring;
    std::uint32_t phantoms = 0;
    std::vector<Candidate>& candidates = s.candidates;
    const std::uint32_t firstChild = cellCount[cell];
    double interpolationSeconds = 0;
    if (splitsSegments()) splitSegments(p, cell, firstChild, s);

    // 2. (below) The candidate that best balances the sampling of the gap after ring[j]:
    //    max of min(∠p_j p p_k, ∠p_k p p_j+1), or candidates.size() when none is inside it; with
    //    `anyInside`, the first candidate found inside instead of the best.
    //    Choice: angles measured around n_p in the tangent plane (the plane that orders the fan),
    //    and only candidates inside the gap compete, so a point is never put into a gap other than
    //    the one being filled.
    const auto candidateIn = [&](std::size_t j, bool anyInside) {
        const RingMember& a = ring[j];
        const float gapSweep =
            ring.size() == 1 ? kTwoPi : sweep(a.angle, ring[nextIndex(j, ring.size())].angle);
        std::size_t best = candidates.size();
        float bestScore = -1.0f;
        for (std::size_t k = 0; k < candidates.size(); ++k) {
            if (candidates[k].taken) continue;
            const float into = sweep(a.angle, candidates[k].angle);
            const float score = std::min(into, gapSweep - into);
            if (score >= kMinSplitAngle && score > bestScore) {
                if (anyInside) return k;
                bestScore = score;
                best = k;
            }
        }
        return best;
    };
    // For speed only: a curved angle costs more than looking for a candidate in its gap, a plain
    // angle (variant 2) less, so only the first is looked at first.
    const bool candidatesFirst = !options.plainAngle;

    // Candidates leave L_p by being marked taken; the others keep their order.
    for (std::size_t remaining = candidates.size(); remaining > 0; --remaining) {
        // 1. The pair of consecutive members of N'_p with the largest curved angle that is not
        //    below θc (N'_p complete otherwise) and still has a candidate inside it. A gap with no
        //    candidate inside can never be chosen, and candidates only leave: it may be marked
        //    exhausted at once, and its curved angle is then never measured (the same choice).
        std::size_t chosen = candidates.size();
        if (ring.empty()) {
            // An empty N'_p is incomplete; every candidate fills it equally: the first one left.
            chosen = 0;
            while (candidates[chosen].taken) ++chosen;
        } else {
            for (std::size_t j = 0; j < ring.size(); ++j) {
                if (!ring[j].gapStale) continue;
                ring[j].gapStale = false;
                ring[j].gapExhausted = candidatesFirst && candidateIn(j, true) == candidates.size();
                if (!ring[j].gapExhausted)
                    ring[j].gapToNext = gapValue(x, ring[j], ring[nextIndex(j, ring.size())], ring.size());
            }
            for (;;) {
                std::size_t widest = ring.size();
                for (std::size_t j = 0; j < ring.size(); ++j) {
                    if (ring[j].gapExhausted || ring[j].gapToNext < kThetaC) continue;
                    if (widest == ring.size() || ring[j].gapToNext > ring[widest].gapToNext) widest = j;
                }
                if (widest == ring.size()) break; // complete, or no candidate fills what is open
                chosen = candidateIn(widest, false);
                if (chosen < candidates.size()) break;
                ring[widest].gapExhausted = true;
            }
            if (chosen == candidates.size()) break;
        }

        // 3. Insert the candidate unless it falls into the discard space D_p (eq. 11); then the
        //    closest point of Y_p joins N'_p instead (ties broken by storage position).
        candidates[chosen].taken = true;
        const Candidate& c = candidates[chosen];
        std::size_t closest = s.outer.size();
        float closestDistance = std::numeric_limits<float>::max();
        bool discarded = false;
        for (std::size_t h = 0; h < s.outer.size(); ++h) {
            const float distance = glm::length(c.position - s.outer[h].position);
            if (distance < s.outer[h].discardRadius) discarded = true;
            const bool tie = distance == closestDistance && closest < s.outer.size() &&
                             storedBefore(s.outer[h], s.outer[closest]);
            if (distance < closestDistance || tie) {
                closestDistance = distance;
                closest = h;
            }
        }
        if (discarded) {
            ++s.discarded;
            RingMember& y = s.outer[closest];
            y.angle = frame.angleOf(y.position - x);
            const bool present = std::any_of(ring.begin(), ring.end(), [&](const RingMember& m) {
                return m.cell == y.cell && m.local == y.local;
            });
            // Choice: a substitute farther than c_β,max · r from p would break the convergence
            // bound of section 8.1 (the proof assumes the farthest new neighbour is a PN centre);
            // such a point is left out and nothing joins N'_p.
            if (!present && withinConvergenceBound(p, y.position)) insertIntoRing(ring, y);
            continue;
        }
        Clock::time_point ti;
        if (profile) ti = Clock::now();
        const NewPoint np = newPointFrom(p, s.fan, c);
        // Choice: a candidate farther than c_β,max · r from p is not inserted, as Y_p's substitutes
        // and the segments' first points are not put into N'_p: it would break the convergence
        // bound of section 8.1. The bound assumes a fan within r; after the wider second look (up
        // to kRetryReach · r) a PN centre can lie beyond it (1 in 118,000 on the fandisk). The
        // gap stays open for p's other candidates, and the far triangle's other corners, which
        // are closer to it, insert their own.
        if (!withinConvergenceBound(p, np.position)) {
            ++s.beyondBound;
            if (profile) interpolationSeconds += secondsSince(ti);
            continue;
        }
        // Choice: a point that would coincide with p or a point near it (of P(l) within reach, of
        // N'_p or of Y_p) is not inserted. The fuzzy filter can drop p's own child of the previous
        // level from its fan (normals far apart, as in noisy scans), and the fan triangle that
        // made that child then makes it again: one such duplicate in the nefertiti's 214,257
        // points, and in a quarter of small sets with normals tilted by up to 50° (fuzz_refine: its
        // radius then collapsed to 0). Such a point lies within p's reach, where the points of
        // P(l) were just scanned (collectNeighbourhood); with centroid candidates (variant 4) a
        // twin in Y_p can escape D_p, which is measured on the centroid.
        if (coincidesWithNearby(np.position, x, s) || madeByCorner(np.position, s.fan.index[c.a]) ||
            madeByCorner(np.position, s.fan.index[c.b])) {
            ++s.coincident;
            if (profile) interpolationSeconds += secondsSince(ti);
            continue;
        }
        // refineRegion: the neighbouring region inserts what lies in it (see refiner.h). Choice: the
        // candidate joins N'_p all the same, unstored, as the point the whole level would insert
        // there: p's radius reaches it, and the members beside it grow to reach it rather than
        // each other across the gap it leaves.
        if (outsideRegion(np.position)) {
            ++s.outsideRegion;
            insertIntoRing(ring, RingMember{kPhantomCell, phantoms++, np.position, np.normal,
                                            frame.angleOf(np.position - x)});
            continue;
        }
        const std::uint32_t local = store(cell, np, PointSource{{p, s.fan.index[c.a], s.fan.index[c.b]}}, s);
        ++s.inserted;
        RingMember m{cell, local, np.position, np.normal, frame.angleOf(np.position - x)};
        insertIntoRing(ring, m);
        if (profile) interpolationSeconds += secondsSince(ti);
    }

    // Radii (section 5): r' = max_{j ∈ N'_p} |p - p_j|; each member grows to reach p and its two
    // neighbours in the new ring. Choice for an empty N'_p (nothing found, nothing inserted: the
    // paper's maximum is undefined): r' = c_β,max · r, so every radius still converges (8.1).
    if (ring.empty()) points.radius[p] = kCBetaMax * levelRadius[p];
    if (!ring.empty()) {
        float newRadius = 0.0f;
        const std::size_t m = ring.size();
        // Each side of the ring measured once: |p_j - p_j+1| reaches both of its members.
        float before = glm::length(ring[0].position - ring[m - 1].position);
        for (std::size_t j = 0; j < m; ++j) {
            const glm::vec3 pj = ring[j].position;
            const float toP = glm::length(pj - x);
            newRadius = std::max(newRadius, toP);
            const float after = glm::length(pj - ring[nextIndex(j, m)].position);
            if (ring[j].cell != kPhantomCell) {
                float& rj = newPoint(ring[j]).radius;
                rj = std::max(rj, kRadiusMargin * std::max({toP, before, after}));
            }
            before = after;
        }
        points.radius[p] = kRadiusMargin * newRadius;
    }
    s.reachable = 0; // reachableFrom may point into storage that the next point reuses
    childRange[p] = ChildRange{cell, firstChild, cellCount[cell] - firstChild};
    refined[p] = 1;
    if (profile) {
        const double total = secondsSince(t0);
        s.times.selection += total - interpolationSeconds;
        s.times.interpolation += interpolationSeconds;
    }
}

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

void Refiner::State::indexSegments() {
    const auto count = static_cast<std::uint32_t>(points.size());
    segmentsOfBegin.assign(count + 1, 0);
    for (const Segment& segment : segments) ++segmentsOfBegin[segment.a + 1];
    for (std::uint32_t i = 0; i < count; ++i) segmentsOfBegin[i + 1] += segmentsOfBegin[i];
    segmentsOf.resize(segments.size());
    std::vector<std::uint32_t> fill(segmentsOfBegin.begin(), segmentsOfBegin.end() - 1);
    for (std::uint32_t k = 0; k < segments.size(); ++k) segmentsOf[fill[segments[k].a]++] = k;
    segmentChild.assign(segments.size(), 0);
    segmentInserted.assign(segments.size(), 0);
}

LevelSkip Refiner::State::skipRule(float scale) const {
    LevelSkip skip{scale, options.targetRadius * scale, {}};
    // Adaptive refinement skips a point small enough already, unless it owns a segment longer than
    // the target: its radius covers its new ring, not the segment, which only its refinement splits.
    if (skip.targetRadius > 0.0f && !segments.empty()) {
        skip.longestOwned.assign(points.size(), 0.0f);
        for (const Segment& segment : segments)
            skip.longestOwned[segment.a] = std::max(skip.longestOwned[segment.a], segmentLength(segment));
    }
    return skip;
}

bool Refiner::State::skips(std::uint32_t i, const LevelSkip& skip) const {
    if (regionRun && regionRun->frozen[i]) return true;
    if (!refinedBalls.empty() && !insideAny(refinedBalls, points.position[i], skip.scale)) return true;
    return levelRadius[i] <= skip.targetRadius &&
           (skip.longestOwned.empty() || skip.longestOwned[i] <= skip.targetRadius);
}

LevelCells Refiner::State::sortIntoCells(const LevelScale& level, const LevelSkip& skip, LevelStats& stats) {
    const auto count = static_cast<std::uint32_t>(points.size());
    const float cellSize = std::max(kCellFactor * level.radiusLimit, level.extent / float(1u << 20));
    LevelCells out;
    CellKeys& keyed = out.keyed;
    keyed.resize(count);
    parallelForRanges(pool, count, 16384, [&](std::size_t begin, std::size_t end, unsigned) {
        for (auto i = static_cast<std::uint32_t>(begin); i < end; ++i)
            keyed[i] = {cellKeyOf(points.position[i], level.lo, cellSize), i};
    });
    sortCellKeys(keyed);
    gridKey.resize(count);
    gridPoint.resize(count);
    for (std::uint32_t k = 0; k < count; ++k) gridKey[k] = keyed[k].first, gridPoint[k] = keyed[k].second;
    // The points refined in cells: all but the large ones and those skipped.
    std::vector<std::uint8_t> skipped(count);
    std::vector<std::uint32_t> large;
    for (std::uint32_t i = 0; i < count; ++i) {
        skipped[i] = skips(i, skip);
        if (skipped[i]) continue;
        ++stats.refinedPoints;
        if (levelRadius[i] > level.radiusLimit) large.push_back(i);
    }
    std::erase_if(keyed, [&](const auto& entry) {
        return skipped[entry.second] || levelRadius[entry.second] > level.radiusLimit;
    });
    stats.largePoints = large.size();
    // The large points get a colouring of their own, at the scale of the largest of them, appended
    // to `keyed` (their cells' keys use that scale).
    const std::size_t smallEnd = keyed.size();
    if (!large.empty()) {
        float largest = 0.0f;
        for (const std::uint32_t i : large) largest = std::max(largest, levelRadius[i]);
        const float largeCellSize = std::max(kCellFactor * largest, level.extent / float(1u << 20));
        CellKeys keyedLarge(large.size());
        for (std::size_t k = 0; k < large.size(); ++k)
            keyedLarge[k] = {cellKeyOf(points.position[large[k]], level.lo, largeCellSize), large[k]};
        sortCellKeys(keyedLarge);
        keyed.insert(keyed.end(), keyedLarge.begin(), keyedLarge.end());
    }
    out.cells.reserve(keyed.size()); // at most one cell per point: no growth, no copy
    for (std::uint32_t k = 0; k < keyed.size();) {
        std::uint32_t e = k + 1;
        while (e < keyed.size() && e != smallEnd && keyed[e].first == keyed[k].first) ++e;
        if (k < smallEnd) ++out.smallCells;
        out.cells.push_back(Cell{k, e});
        k = e;
    }
    return out;
}

// A cell's points find their surroundings together, from the grid; a large point alone, through
// the hierarchy (its reach may pass the 3×3×3 cells of the grid).
void Refiner::State::refineCell(const LevelCells& level, std::uint32_t c, bool largeCell, WorkerScratch& s) {
    const Cell cell = level.cells[c];
    const CellKeys& keyed = level.keyed;
    cellBase[c] = s.arena.open();
    if (recordSources) cellSources[c] = s.sources.open();
    if (largeCell) {
        s.groupCell.reset();
        for (std::uint32_t k = cell.begin; k < cell.end; ++k) {
            const std::uint32_t i = keyed[k].second;
            gatherNearby(std::span(&i, 1), std::nullopt, 1.0f, s.nearby, s);
            refinePoint(i, c, s);
        }
        return;
    }
    s.group.clear();
    for (std::uint32_t k = cell.begin; k < cell.end; ++k) s.group.push_back(keyed[k].second);
    s.groupCell = keyed[cell.begin].first;
    gatherNearby(s.group, s.groupCell, 1.0f, s.nearby, s);
    float largest = 0.0f;
    for (const std::uint32_t i : s.group) largest = std::max(largest, levelRadius[i]);
    s.nearbyGrid.build(s.nearby, largest);
    for (std::uint32_t k = cell.begin; k < cell.end; ++k) refinePoint(keyed[k].second, c, s);
}

void Refiner::State::refineCells(const LevelCells& level, const ProgressFn& progress,
                                 std::size_t refinedPoints) {
    const HugePageVector<Cell>& cells = level.cells;
    // The largest tiles that leave the workers at least kMinTiles to share (a choice of the data
    // alone, never of the thread count).
    const unsigned tileShift = chooseTileShift(level.keyed, std::span(cells.data(), level.smallCells));
    const Tiles smallTiles = makeTiles(level.keyed, cells, 0, level.smallCells, tileShift);
    const Tiles largeTiles =
        makeTiles(level.keyed, cells, level.smallCells, static_cast<std::uint32_t>(cells.size()), 0);
    cellBase.assign(cells.size(), nullptr);
    cellCount.assign(cells.size(), 0);
    recordSources = points.hasAttributes() || (regionRun && regionRun->recordParents);
    if (recordSources) cellSources.assign(cells.size(), nullptr);
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
        const Tiles& tiles = largeCells ? largeTiles : smallTiles;
        runGraph(pool, tiles.graph, [&](std::uint32_t tile, unsigned worker) {
            std::size_t done = 0;
            for (std::uint32_t k = tiles.cellBegin[tile]; k < tiles.cellBegin[tile + 1]; ++k) {
                refineCell(level, tiles.cells[k], largeCells, scratch[worker]);
                done += cells[tiles.cells[k]].end - cells[tiles.cells[k]].begin;
            }
            const std::size_t total = processed.fetch_add(done, std::memory_order_relaxed) + done;
            if (worker == 0 && progress) progress(total, refinedPoints);
        });
    }
    if (progress) progress(processed.load(), refinedPoints);
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

void Refiner::State::splitAllSegments(std::span<const std::uint32_t> childBegin, const LevelSkip& skip) {
    // Each segment becomes three: (a, q1), (q1, q2), (q2, b); one whose first point was not refined
    // (adaptive refinement: the point and the segment are within the target) stays whole.
    std::vector<Segment> split;
    split.reserve(3 * segments.size());
    for (std::uint32_t k = 0; k < segments.size(); ++k) {
        const Segment segment = segments[k];
        if (skips(segment.a, skip)) {
            split.push_back(segment);
            continue;
        }
        // (a, q1), (q1, q2), (q2, b), without the points refineRegion left out.
        std::uint32_t from = segment.a, next = childBegin[segment.a] + segmentChild[k];
        for (unsigned t = 0; t < 2; ++t) {
            if (!(segmentInserted[k] & (1u << t))) continue;
            split.push_back(Segment{from, next, segment.crease});
            from = next++;
        }
        split.push_back(Segment{from, segment.b, segment.crease});
    }
    segments = std::move(split);
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
    LevelStats stats;
    stats.level = hierarchy.levels();
    stats.pointsBefore = points.size();
    // The level's scale, then its colouring (see the top of this file).
    const LevelScale level = beginLevel();
    if (regionRun)
        scaledRegion = Region{regionRun->region.lo * level.scale, regionRun->region.hi * level.scale};
    if (stats.level == 1 && !regionRun && (options.boundaries || points.hasCrease())) findSegments();
    if (splitsSegments()) indexSegments();
    const LevelSkip skip = skipRule(level.scale);
    const LevelCells cells = sortIntoCells(level, skip, stats);
    refineCells(cells, progress, stats.refinedPoints);
    // The new points appended grouped by parent, parents in index order (section 7).
    HugePageVector<std::uint32_t> childBegin = appendChildren();
    if (splitsSegments()) splitAllSegments(childBegin, skip);
    stats.boundarySegments = segments.size();
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
    for (const State::Segment& segment : state_->segments)
        longest = std::max(longest, state_->segmentLength(segment));
    return longest;
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
    const int exponent = state.beginLevel().exponent;
    state.findSegments();
    if (exponent != 0) scalePoints(state.points, std::ldexp(1.0f, -exponent), state.pool);
    std::vector<SegmentEnds> segments;
    segments.reserve(state.segments.size());
    for (const Refiner::State::Segment& segment : state.segments)
        segments.push_back(
            {state.points.position[segment.a], state.points.position[segment.b], segment.crease});
    return segments;
}

RegionResult refineRegion(RegionLevel input, const RefineOptions& options) {
    RegionResult result;
    const std::size_t owned = input.owned;
    assert(owned <= input.points.size());
    if (owned == 0) return result;
    RefineOptions local = options;
    local.threads = 1;
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
        if (a && b && !context[*a]) state.segments.push_back({*a, *b, segment.crease});
    }
    state.regionRun = std::move(run);
    result.stats = state.refineLevel({});

    const PointSet& all = state.points;
    const std::size_t firstNew = state.hierarchy.levelEnd(0);
    result.points.reserve(owned + all.size() - firstNew);
    for (std::size_t k = 0; k < owned; ++k) result.points.appendFrom(all, sortedIndexOf[k]);
    for (std::size_t i = firstNew; i < all.size(); ++i) result.points.appendFrom(all, i);
    for (const Refiner::State::Segment& segment : state.segments)
        if (segment.a >= firstNew || !context[segment.a])
            result.segments.push_back({all.position[segment.a], all.position[segment.b], segment.crease});
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
