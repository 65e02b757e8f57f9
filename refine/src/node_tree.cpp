// The node hierarchy of the real-time refinement: paper section 7 ("Real-Time Refinement");
// node_tree.h has the rules.
#include "pnsplat/refine/node_tree.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <span>
#include <string>
#include <vector>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "pnsplat/refine/neighbourhood.h"
#include "pnsplat/refine/quantile.h"
#include "pnsplat/refine/worker_pool.h"

namespace pnsplat {

namespace {

// Whether region [rlo, rhi) meets the closed box [lo, hi].
bool meets(const Region& region, glm::vec3 lo, glm::vec3 hi) {
    for (int a = 0; a < 3; ++a)
        if (!(region.lo[a] <= hi[a] && lo[a] < region.hi[a])) return false;
    return true;
}

bool inside(glm::vec3 p, glm::vec3 lo, glm::vec3 hi) {
    return lo.x <= p.x && p.x <= hi.x && lo.y <= p.y && p.y <= hi.y && lo.z <= p.z && p.z <= hi.z;
}

struct Box {
    glm::vec3 lo, hi;
};

Box boxOf(std::span<const glm::vec3> points, std::span<const std::uint32_t> indices) {
    Box box{points[indices[0]], points[indices[0]]};
    for (const std::uint32_t i : indices) {
        box.lo = glm::min(box.lo, points[i]);
        box.hi = glm::max(box.hi, points[i]);
    }
    return box;
}

// The axes of a box, longest first (ties: x before y before z).
std::array<int, 3> axesByExtent(const Box& box) {
    const glm::vec3 extent = box.hi - box.lo;
    std::array<int, 3> axes{0, 1, 2};
    std::stable_sort(axes.begin(), axes.end(), [&](int a, int b) { return extent[a] > extent[b]; });
    return axes;
}

// `indices` cut into at most k parts of about equal counts along `axis`, each part the points whose
// coordinate lies between two cuts. A cut is the coordinate of the point at a count quantile, and
// points on a cut go to the part above it, so equal coordinates never straddle two parts; cuts that
// would leave a part empty are dropped. Where that drops them all (more than a part's share of the
// points at the smallest coordinate), the cut is the first coordinate above it: one part is left
// only where every point has the same coordinate.
std::vector<SplitPart> splitAlong(std::span<const glm::vec3> points, std::span<const std::uint32_t> indices,
                                  int axis, std::uint32_t k, const Region& region) {
    std::vector<float> sorted(indices.size());
    for (std::size_t j = 0; j < indices.size(); ++j) sorted[j] = points[indices[j]][axis];
    std::sort(sorted.begin(), sorted.end());
    std::vector<float> cuts;
    float below = sorted.empty() ? 0.0f : sorted[0]; // no cut at or below the smallest coordinate
    for (std::uint32_t q = 1; q < k; ++q) {
        const float cut = sorted[q * sorted.size() / k];
        if (cut > below) cuts.push_back(below = cut);
    }
    if (cuts.empty() && !sorted.empty() && sorted.back() > sorted.front())
        cuts.push_back(*std::upper_bound(sorted.begin(), sorted.end(), sorted.front()));
    std::vector<SplitPart> parts(cuts.size() + 1);
    for (std::size_t q = 0; q < parts.size(); ++q) {
        parts[q].region = region;
        if (q > 0) parts[q].region.lo[axis] = cuts[q - 1];
        if (q < cuts.size()) parts[q].region.hi[axis] = cuts[q];
    }
    for (const std::uint32_t i : indices) {
        const float c = points[i][axis];
        const auto part =
            static_cast<std::size_t>(std::upper_bound(cuts.begin(), cuts.end(), c) - cuts.begin());
        parts[part].indices.push_back(i);
    }
    return parts;
}

// Whether the radii of `indices` spread more than kRootSpread (a root split further, node_tree.h;
// radii for refinement: positive and finite).
bool spreadsTooWide(std::span<const float> radius, std::span<const std::uint32_t> indices) {
    if (radius.empty() || indices.size() < kRootSpreadPoints) return false;
    std::vector<float> values(indices.size());
    for (std::size_t j = 0; j < indices.size(); ++j) values[j] = radius[indices[j]];
    const auto at = [&](float quantile) {
        const auto nth = values.begin() + static_cast<std::ptrdiff_t>(quantileIndex(values.size(), quantile));
        std::nth_element(values.begin(), nth, values.end());
        return *nth;
    };
    const float high = at(0.9f);
    return high > kRootSpread * at(0.1f);
}

// The whole levels of NodeSettings::wholeLevelPoints: P(0) (in the refiner's order) to P(W), each
// with the radii of its level, and the segments of P(W) into `segments`.
std::vector<PointSet> refineWholeLevels(PointSet input, const NodeSettings& settings,
                                        std::vector<SegmentEnds>& segments) {
    Refiner refiner(std::move(input), settings.refine);
    std::vector<PointSet> whole{refiner.points()};
    while (refiner.levels() < settings.maxLevel &&
           double(refiner.points().size()) * kLevelGrowth <= double(settings.wholeLevelPoints)) {
        refiner.refineLevel();
        whole.push_back(refiner.points());
    }
    segments = refiner.segmentEnds();
    return whole;
}

// The `segments` whose first point `region` holds (a node's, ALGORITHM.md §8.2).
std::vector<SegmentEnds> segmentsIn(const Region& region, std::span<const SegmentEnds> segments) {
    std::vector<SegmentEnds> in;
    for (const SegmentEnds& segment : segments)
        if (region.contains(segment.a)) in.push_back(segment);
    return in;
}

// A part of a split: the points `part.indices` of `points` (indices into `subset` when it is not
// empty) with their shape, and the `segments` whose first point its region holds.
NodeChild partOf(const PointSet& points, const NeighbourShape& shape, std::span<const std::uint32_t> subset,
                 const SplitPart& part, std::span<const SegmentEnds> segments) {
    NodeChild child;
    child.region = part.region;
    child.points.reserve(part.indices.size());
    child.shape.reserve(part.indices.size());
    for (const std::uint32_t k : part.indices) {
        const std::uint32_t i = subset.empty() ? k : subset[k];
        child.points.appendFrom(points, i);
        child.shape.appendFrom(shape, i);
    }
    child.segments = segmentsIn(part.region, segments);
    return child;
}

// The children of a node of `region` holding the points `subset` of `points` (empty: all of them),
// split by splitNode. For a job's result (run) and for the whole levels (NodeTree::create).
std::vector<NodeChild> childrenOf(const PointSet& points, const NeighbourShape& shape,
                                  std::span<const std::uint32_t> subset, const Region& region,
                                  std::span<const SegmentEnds> segments, std::uint32_t maxNodePoints) {
    std::vector<glm::vec3> gathered;
    if (!subset.empty()) {
        gathered.reserve(subset.size());
        for (const std::uint32_t i : subset) gathered.push_back(points.position[i]);
    }
    std::vector<NodeChild> children;
    for (const SplitPart& part : splitNode(
             subset.empty() ? std::span<const glm::vec3>(points.position) : gathered, region, maxNodePoints))
        children.push_back(partOf(points, shape, subset, part, segments));
    return children;
}

// What a node's selection reads of its points (non-empty; its shape filled): its box,
// largest, 99th percentile and median splat radii, largest point radius, largest bend and normal
// cone. For the roots and for a job's children.
void describePoints(Node& node) {
    std::vector<std::uint32_t> all(node.points.size());
    std::iota(all.begin(), all.end(), 0u);
    const Box box = boxOf(node.points.position, all);
    node.lo = box.lo;
    node.hi = box.hi;
    node.maxRadius = std::ranges::max(node.shape.splatRadius);
    node.maxPointRadius = std::ranges::max(node.points.radius);
    node.drawnRadius = drawnRadiusOf(node.shape.splatRadius);
    node.medianRadius = medianRadiiOf(node.shape.splatRadius);
    node.maxBend = node.shape.bend.empty() ? 0.0f : std::ranges::max(node.shape.bend);
    normalConeOf(node.points.normal, node.coneAxis, node.coneAngle);
}

// The nearest points of each of a set's points, for neighbourShapeOf: a grid of cubic cells, kept
// as columns along z (a dense array of column starts over the points sorted by column, then by
// their cell along z). Exact: a search stops when the farthest point kept is nearer than every
// point outside the cells it read; ties in distance go to the lower index, as a brute-force search
// breaks them. It replaced a k-d tree (nanoflann), whose build and searches were a quarter of the
// real-time refinement's processor time (the sparse bunny at render's framing, 640x480; then
// 17 %): 4,500 points on a sphere, 2.7 times faster. Columns rather than a dense array of every
// cell: a dense array of at most kCellsPerPoint cells a point made cells of 3 to 4 spacings in a
// node's box and of 5 over a whole level, so that a point's 3×3×3 cells held 115 to 190 points
// (the sparse bunny's, lion's and nefertiti's levels 4 and 5); in columns they hold about 50, and
// neighbourShapeOf takes 0.7–0.9 times the time on those levels and 0.8–0.9 on parts of them the
// size of a job's, the same bits (its Voronoi cells, cellRadius, are now a third of it). A cell far
// more crowded than the grid's cells were sized for (a terrestrial scan's near field, whose density
// is a hundred thousand times its far field's) searches a grid of its 3×3×3 cells' points sized for
// them (kDenseCell, kDenseBlock): such a scan's level of 816,453 points took 15.0 s, now 1.1 s, and
// 50,000 points in one cell amid 50,000 spread 4.1 s, now 0.35 s, the same bits.
class NearestGrid {
  public:
    explicit NearestGrid(std::span<const glm::vec3> positions) : positions_(positions) {
        const auto [lo, hi] = boundsOf(positions);
        lo_ = lo;
        // Cells of about two spacings of the surface the points sample, so that a point's nearest
        // few lie in its 3×3×3 cells: first from the area of the box's three faces, then once more
        // from the points the non-empty cells hold (kOccupancy wanted: a plane sampled at spacing
        // s in cells of side 2 s puts 4 in each; the faces' area overestimates a patch's that
        // crosses its box obliquely, and cells of the real-time refinement's jobs held 2.2 times
        // the points wanted). The first count is in a dense array of at most kCellsPerPoint cells a
        // point (cells of that size or larger); the grid then has at most kCellsPerPoint columns a
        // point. The grid's geometry is in double precision: the extent of floats may pass the
        // largest float (3e38 either side).
        const glm::dvec3 extent = glm::dvec3(hi) - lo_;
        const double n = static_cast<double>(positions.size());
        const double area = extent.x * extent.y + extent.y * extent.z + extent.z * extent.x;
        const double smallest = std::max(1e-6 * std::max({extent.x, extent.y, extent.z}),
                                         double{std::numeric_limits<float>::min()});
        double side = std::max(2.0 * std::sqrt(area / n), smallest);
        // The cells per axis for `side`, grown by a quarter at a time until `cells` of them (every
        // cell, or the columns) are at most kCellsPerPoint a point.
        const auto sizeFor = [&](double (*cells)(glm::ivec3)) {
            for (;; side *= 1.25) {
                dims_ = glm::ivec3(extent / side) + 1;
                if (cells(dims_) <= kCellsPerPoint * n) break;
            }
            scale_ = 1.0 / side;
        };
        sizeFor([](glm::ivec3 d) { return double(d.x) * double(d.y) * double(d.z); });
        std::vector<bool> occupied(static_cast<std::size_t>(dims_.x) * dims_.y * dims_.z, false);
        std::size_t count = 0;
        for (const glm::vec3 p : positions) {
            const glm::ivec3 c = cellAt(p);
            const std::size_t at = columnIndex(c.x, c.y) * dims_.z + c.z;
            count += occupied[at] ? 0 : 1;
            occupied[at] = true;
        }
        side = std::max(side * std::sqrt(kOccupancy * double(count) / n), smallest);
        sizeFor([](glm::ivec3 d) { return double(d.x) * double(d.y); });
        // Counting sort by column, then each column's points by their cell along z (ties by index:
        // any order would do, this one is the same every time).
        columnStart_.assign(columns() + 1, 0);
        std::vector<std::uint32_t> columnOf(positions.size());
        std::vector<std::int32_t> cellZ(positions.size());
        for (std::size_t i = 0; i < positions.size(); ++i) {
            const glm::ivec3 c = cellAt(positions[i]);
            columnOf[i] = static_cast<std::uint32_t>(columnIndex(c.x, c.y));
            cellZ[i] = c.z;
            ++columnStart_[columnOf[i] + 1];
        }
        for (std::size_t c = 1; c < columnStart_.size(); ++c) columnStart_[c] += columnStart_[c - 1];
        sorted_.resize(positions.size());
        std::vector<std::uint32_t> fill(columnStart_.begin(), columnStart_.end() - 1);
        for (std::size_t i = 0; i < positions.size(); ++i)
            sorted_[fill[columnOf[i]]++] = static_cast<std::uint32_t>(i);
        for (std::size_t c = 0; c + 1 < columnStart_.size(); ++c)
            std::sort(sorted_.begin() + columnStart_[c], sorted_.begin() + columnStart_[c + 1],
                      [&](std::uint32_t a, std::uint32_t b) {
                          return cellZ[a] != cellZ[b] ? cellZ[a] < cellZ[b] : a < b;
                      });
        // A block's squared distances (at most 12 cell sides squared) stay finite in single
        // precision: where they do not (coordinates near 1e37), a finer grid cannot tell its points
        // apart and its search would be wasted before the widening one.
        blockFits_ = 12.0 / (scale_ * scale_) < double{std::numeric_limits<float>::max()};
        x_.resize(positions.size());
        y_.resize(positions.size());
        z_.resize(positions.size());
        cellZ_.resize(positions.size());
        for (std::size_t k = 0; k < positions.size(); ++k) {
            const std::uint32_t i = sorted_[k];
            x_[k] = positions[i].x;
            y_[k] = positions[i].y;
            z_[k] = positions[i].z;
            cellZ_[k] = cellZ[i];
        }
    }

    // Columns of cells along z, numbered x-major: forEachNearest visits the points of columns
    // [begin, end).
    std::size_t columns() const { return static_cast<std::size_t>(dims_.x) * dims_.y; }

    // visit(i, nearest, found) for every point i of the cells of columns [begin, end) with its
    // min(K, size) nearest as nearest() gives them, cell after cell: a point's candidates are the
    // points of the 3×3×3 cells around its own that lie nearer than every point outside them; where
    // fewer than K do, nearest() widens the search. Calls over disjoint columns may run concurrently.
    template <std::size_t K, typename Visit>
    void forEachNearest(std::size_t begin, std::size_t end, Visit&& visit) const {
        Candidates candidates;
        // The block's runs of points, one per column around the cell's: [from, to) in the sorted
        // order. The cells of a column are visited by rising z, so each run only moves forward.
        std::array<std::uint32_t, 9> from{}, to{};
        for (std::size_t column = begin; column < end; ++column) {
            const int cx = static_cast<int>(column / dims_.y), cy = static_cast<int>(column % dims_.y);
            const int x0 = std::max(cx - 1, 0), x1 = std::min(cx + 1, dims_.x - 1);
            const int y0 = std::max(cy - 1, 0), y1 = std::min(cy + 1, dims_.y - 1);
            std::size_t runs = 0;
            for (int ox = x0; ox <= x1; ++ox)
                for (int oy = y0; oy <= y1; ++oy) {
                    const std::size_t c = columnIndex(ox, oy);
                    from[runs] = to[runs] = columnStart_[c];
                    ++runs;
                }
            for (std::uint32_t cell = columnStart_[column]; cell < columnStart_[column + 1];) {
                const int cz = cellZ_[cell];
                std::uint32_t cellEnd = cell + 1;
                while (cellEnd < columnStart_[column + 1] && cellZ_[cellEnd] == cz) ++cellEnd;
                const glm::ivec3 home(cx, cy, cz);
                const glm::ivec3 first(x0, y0, std::max(cz - 1, 0));
                const glm::ivec3 last(x1, y1, std::min(cz + 1, dims_.z - 1));
                std::size_t blockSize = 0, r = 0;
                for (int ox = x0; ox <= x1; ++ox)
                    for (int oy = y0; oy <= y1; ++oy, ++r) {
                        const std::uint32_t columnEnd = columnStart_[columnIndex(ox, oy) + 1];
                        while (from[r] < columnEnd && cellZ_[from[r]] < first.z) ++from[r];
                        if (to[r] < from[r]) to[r] = from[r];
                        while (to[r] < columnEnd && cellZ_[to[r]] <= last.z) ++to[r];
                        blockSize += to[r] - from[r];
                    }
                const Block block{std::span(from).first(runs),
                                  std::span(to).first(runs),
                                  first,
                                  last,
                                  home,
                                  first == glm::ivec3(0) && last == dims_ - 1};
                // A crowded cell amid sparser ones (a scan's near field) searches a finer grid.
                if (cellEnd - cell >= kDenseCell && blockSize >= kDenseBlock && blockFits_)
                    visitCrowdedCell<K>(cell, cellEnd, block, visit);
                else
                    visitCell<K>(cell, cellEnd, block, blockSize, candidates, visit);
                cell = cellEnd;
            }
        }
    }

    // The min(K, size) nearest points to point i (itself among them), by distance, then index; with
    // `farthest2`, the last one's squared distance.
    template <std::size_t K>
    std::size_t nearest(std::uint32_t i, std::array<std::uint32_t, K>& out,
                        float* farthest2 = nullptr) const {
        const glm::vec3 x = positions_[i];
        const glm::ivec3 home = cellAt(x);
        const glm::dvec3 inCell = (glm::dvec3(x) - lo_) * scale_ - glm::dvec3(home); // [0, 1] per axis
        std::array<float, K> kept{};
        std::size_t found = 0;
        // The cells within Chebyshev distance `reach` of x's that the cube read before (`seen`)
        // does not hold, for reach = 0, 1, 2, 4, 8, ... while fewer than K points are found (a point
        // far from the others crosses the empty cells in a few steps, not one shell each), then one
        // more each time. A cell nearer to x than the farthest point kept (distances in cell units,
        // below) is read; the others cannot hold a nearer point.
        const double unit2 = scale_ * scale_;
        const auto farther = [&](double bound2) {
            return found == K && bound2 > double{kept[K - 1]} * unit2;
        };
        int seen = -1;
        for (int reach = 0;;) {
            const glm::ivec3 first = glm::max(home - reach, glm::ivec3(0));
            const glm::ivec3 last = glm::min(home + reach, dims_ - 1);
            for (int cx = first.x; cx <= last.x; ++cx) {
                const double bx = gapTo(cx - home.x, inCell.x);
                for (int cy = first.y; cy <= last.y; ++cy) {
                    const double by = gapTo(cy - home.y, inCell.y), bxy = bx * bx + by * by;
                    if (farther(bxy)) continue;
                    const std::size_t column = columnIndex(cx, cy);
                    // The points of this column's cells z0..z1.
                    const auto read = [&](int z0, int z1) {
                        if (z0 > z1) return;
                        const auto cells = cellZ_.begin();
                        auto k = static_cast<std::uint32_t>(std::lower_bound(cells + columnStart_[column],
                                                                             cells + columnStart_[column + 1],
                                                                             z0) -
                                                            cells);
                        for (; k < columnStart_[column + 1] && cellZ_[k] <= z1; ++k) {
                            const double bz = gapTo(cellZ_[k] - home.z, inCell.z);
                            if (farther(bxy + bz * bz)) continue;
                            const glm::vec3 d = glm::vec3(x_[k], y_[k], z_[k]) - x;
                            const float d2 = glm::dot(d, d);
                            if (found < K || d2 <= kept[K - 1]) keep(d2, sorted_[k], kept, out, found);
                        }
                    };
                    if (std::abs(cx - home.x) > seen || std::abs(cy - home.y) > seen) {
                        read(first.z, last.z); // a column the cube read before did not reach
                    } else {
                        read(first.z, std::min(last.z, home.z - seen - 1));
                        read(std::max(first.z, home.z + seen + 1), last.z);
                    }
                }
            }
            const bool all = first == glm::ivec3(0) && last == dims_ - 1; // every point seen
            const double clear = clearance(first, last, reach, x, home);
            if (all || (found == K && double{kept[K - 1]} < clear * clear)) {
                if (farthest2 != nullptr && found > 0) *farthest2 = kept[found - 1];
                return found;
            }
            seen = reach;
            reach = found < K ? std::max(1, 2 * reach) : reach + 1;
        }
    }

  private:
    // The cells [first, last] about a cell `home`, their points the runs [from, to) of sorted_, and
    // whether they are the whole grid.
    struct Block {
        std::span<const std::uint32_t> from, to;
        glm::ivec3 first, last, home;
        bool whole;
    };

    // A point's candidates nearer than its block's sides: their squared distances and places in the
    // sorted order, appended without a branch.
    struct Candidates {
        std::vector<float> near2;
        std::vector<std::uint32_t> nearAt;
    };

    // visit(i, nearest, found) for the points [cell, cellEnd) of sorted_, of one cell, `blockSize`
    // points in its block: a point's nearest are among the block's points nearer than every point
    // outside it, where K of them are; else the widening search finds them.
    template <std::size_t K, typename Visit>
    void visitCell(std::uint32_t cell, std::uint32_t cellEnd, const Block& block, std::size_t blockSize,
                   Candidates& c, Visit&& visit) const {
        c.near2.resize(blockSize + 1);
        c.nearAt.resize(blockSize + 1);
        std::array<std::uint32_t, K> nearest{};
        // The previous point's K-th nearest distance, squared and doubled: a first, narrower bound
        // (the points of one cell lie at like spacings), which leaves fewer candidates to sort;
        // where fewer than K lie within it, the block's bound.
        float guess2 = std::numeric_limits<float>::infinity();
        for (std::uint32_t k = cell; k < cellEnd; ++k) {
            const float px = x_[k], py = y_[k], pz = z_[k];
            // Every point outside the block is farther than `clear`: the K nearest are among those
            // nearer than it, if K of them are.
            const double clear = clearance(block.first, block.last, 1, {px, py, pz}, block.home);
            const auto limit2 =
                block.whole ? std::numeric_limits<float>::infinity() : static_cast<float>(clear * clear);
            std::size_t count = 0;
            const auto gather = [&](float bound2, bool all) {
                count = 0;
                for (std::size_t run = 0; run < block.from.size(); ++run)
                    for (std::uint32_t j = block.from[run]; j < block.to[run]; ++j) {
                        const float dx = x_[j] - px, dy = y_[j] - py, dz = z_[j] - pz;
                        const float d2 = dx * dx + dy * dy + dz * dz;
                        c.near2[count] = d2;
                        c.nearAt[count] = j;
                        count += static_cast<std::size_t>(d2 < bound2 || all);
                    }
            };
            if (guess2 < limit2) gather(guess2, false);
            const bool narrowed = guess2 < limit2 && count >= K;
            if (!narrowed) gather(limit2, block.whole);
            std::size_t found = 0;
            guess2 = std::numeric_limits<float>::infinity(); // unless the block gives one
            if (narrowed || count >= K || block.whole) {
                std::array<float, K> kept{};
                for (std::size_t m = 0; m < count; ++m)
                    if (found < K || c.near2[m] <= kept[K - 1])
                        keep(c.near2[m], sorted_[c.nearAt[m]], kept, nearest, found);
                if (found == K) guess2 = 2.0f * kept[K - 1];
            } else {
                found = this->nearest(sorted_[k], nearest);
            }
            visit(sorted_[k], nearest, found);
        }
    }

    // visit(i, nearest, found) for the points [cell, cellEnd) of sorted_, of a crowded cell: each
    // searches a finer grid of its block's points instead of every one of them, and the widening
    // search where K of them do not lie nearer than every point outside the block.
    template <std::size_t K, typename Visit>
    void visitCrowdedCell(std::uint32_t cell, std::uint32_t cellEnd, const Block& block,
                          Visit&& visit) const {
        std::vector<std::uint32_t> points; // the block's, by index: local order = global order, the same ties
        for (std::size_t run = 0; run < block.from.size(); ++run)
            for (std::uint32_t j = block.from[run]; j < block.to[run]; ++j) points.push_back(sorted_[j]);
        std::ranges::sort(points);
        std::vector<glm::vec3> positions(points.size());
        for (std::size_t b = 0; b < points.size(); ++b) positions[b] = positions_[points[b]];
        const NearestGrid finer(positions);
        std::array<std::uint32_t, K> nearest{};
        for (std::uint32_t k = cell; k < cellEnd; ++k) {
            const std::uint32_t i = sorted_[k];
            const auto local =
                static_cast<std::uint32_t>(std::ranges::lower_bound(points, i) - points.begin());
            float farthest2 = 0.0f;
            std::size_t found = finer.nearest(local, nearest, &farthest2);
            const double clear = clearance(block.first, block.last, 1, positions_[i], block.home);
            if (block.whole || (found == K && farthest2 < static_cast<float>(clear * clear))) {
                for (std::size_t m = 0; m < found; ++m) nearest[m] = points[nearest[m]];
            } else {
                found = this->nearest(i, nearest);
            }
            visit(i, nearest, found);
        }
    }

    static constexpr double kCellsPerPoint = 4.0;
    static constexpr double kOccupancy = 3.0;
    // A cell of at least kDenseCell points whose 3×3×3 cells hold at least kDenseBlock (about 20
    // times what a cell of kOccupancy's grid holds) gives its points a finer grid of its own.
    static constexpr std::uint32_t kDenseCell = 32;
    static constexpr std::size_t kDenseBlock = 1024;

    // The distance, in cell units, from x (at `t` in [0, 1] across its cell) to the cell `offset`
    // cells away along one axis, less a little for rounding: a millionth of it (distances squared in
    // single precision round by about 1e-7 of themselves, which a fixed margin does not cover a
    // million cells away) and a thousandth of a cell.
    static double gapTo(int offset, double t) {
        const double gap = offset > 0 ? double(offset) - t : offset < 0 ? double(-offset - 1) + t : 0.0;
        return std::max(gap * (1.0 - 1e-6) - 1e-3, 0.0);
    }
    // How far every point outside the cube of cells [first, last] (those within `reach` of `home`,
    // clamped to the grid) is at least from x, which lies in `home`: no point lies beyond a side at
    // the grid's border; less as gapTo, and never below 0.
    double clearance(glm::ivec3 first, glm::ivec3 last, int reach, glm::vec3 x, glm::ivec3 home) const {
        const glm::dvec3 inCell = (glm::dvec3(x) - lo_) * scale_ - glm::dvec3(home); // [0, 1] per axis
        double clear = std::numeric_limits<double>::max();
        for (int a = 0; a < 3; ++a) {
            if (first[a] > 0) clear = std::min(clear, double(reach) + inCell[a]);
            if (last[a] < dims_[a] - 1) clear = std::min(clear, double(reach + 1) - inCell[a]);
        }
        return std::max(clear * (1.0 - 1e-6) - 1e-3, 0.0) / scale_;
    }
    glm::ivec3 cellAt(glm::vec3 p) const {
        return glm::ivec3(glm::clamp((glm::dvec3(p) - lo_) * scale_, glm::dvec3(0.0), glm::dvec3(dims_ - 1)));
    }
    std::size_t columnIndex(int x, int y) const { return static_cast<std::size_t>(x) * dims_.y + y; }
    // Inserts (d2, j) among the `found` kept nearest, sorted by distance then index, keeping K.
    // (A shift loop of its own: written as a search and then a shift, the compiler made the shift
    // two calls of memmove, which took most of the search's time.)
    template <std::size_t K>
    static void keep(float d2, std::uint32_t j, std::array<float, K>& kept,
                     std::array<std::uint32_t, K>& index, std::size_t& found) {
        const auto before = [&](std::size_t m) { return d2 < kept[m] || (d2 == kept[m] && j < index[m]); };
        std::size_t m = found;
        if (found < K) {
            ++found;
        } else {
            if (!before(K - 1)) return;
            m = K - 1;
        }
        for (; m > 0 && before(m - 1); --m) {
            kept[m] = kept[m - 1];
            index[m] = index[m - 1];
        }
        kept[m] = d2;
        index[m] = j;
    }

    std::span<const glm::vec3> positions_;
    glm::dvec3 lo_{0.0};
    double scale_ = 1.0; // cell coordinates: (position - lo_) · scale_
    glm::ivec3 dims_{1};
    bool blockFits_ = true; // a block's squared distances are finite (kDenseCell's finer grids)
    std::vector<std::uint32_t> columnStart_; // where each column's points start in sorted_
    std::vector<std::uint32_t> sorted_;      // the points by column, then by cell along z
    std::vector<float> x_, y_, z_;           // their positions, in the same order
    std::vector<std::int32_t> cellZ_;        // and their cells along z
};

// The distance from a point to the farthest corner of its Voronoi cell among `offsets` (its
// neighbours' positions less its own; zeros, the point itself, are skipped), in the plane normal to
// `normal` (unit: the basis is skewed otherwise), the cell cut to the square of half-side `limit` about the
// point: a disk of that radius covers every point of that plane nearer to it than to those neighbours. A cell
// that reaches the square's side (a point at an open boundary, or with its neighbours on one side) gives at
// least `limit`. The cell of a few neighbours holds the cell of all the points, so the radius is at least the
// true one. The cell starts as the square and is cut by the bisector of each neighbour (Sutherland-Hodgman on
// a convex polygon). Where rounding would leave no corner (neighbours within about 2e-7 times `limit` of the
// point) or more corners than a convex cut can, it gives `limit`. With `region` (which holds the
// point), the cell is cut by the region's faces too: the part of the plane nearer to the point than
// to those neighbours and within the region.
float cellRadius(glm::vec3 normal, std::span<const glm::vec3> offsets, float limit, glm::vec3 point = {},
                 const Region* region = nullptr) {
    const TangentFrame frame(normal);
    // Each of at most kBendNeighbours cuts, and of a region's 6 faces, adds at most one corner to
    // the square's 4; one more for a corner that rounding puts on both sides of a bisector.
    constexpr std::size_t kCorners = 4 + kBendNeighbours + 6 + 2;
    std::array<std::array<glm::vec2, kCorners>, 2> buffers;
    glm::vec2* corners = buffers[0].data();
    glm::vec2* cut = buffers[1].data();
    corners[0] = {-limit, -limit};
    corners[1] = {limit, -limit};
    corners[2] = {limit, limit};
    corners[3] = {-limit, limit};
    std::size_t count = 4;
    // Without a region, the bound of the bisectors alone (as before regions: the same results).
    const std::size_t cornerLimit = region == nullptr ? kCorners - 6 : kCorners;
    // Cuts the cell to x · q <= half; false where rounding breaks it (the radius is then `limit`).
    const auto cutTo = [&](glm::vec2 q, float half) {
        if (!(half > 0.0f)) return true;
        float reach = glm::dot(corners[0], q);
        for (std::size_t c = 1; c < count; ++c) reach = std::max(reach, glm::dot(corners[c], q));
        if (reach <= half) return true; // the cut misses the cell (most of the farther neighbours)
        std::size_t kept = 0;
        glm::vec2 from = corners[count - 1];
        float fromSide = glm::dot(from, q) - half;
        for (std::size_t c = 0; c < count; ++c) {
            const glm::vec2 to = corners[c];
            const float toSide = glm::dot(to, q) - half;
            if (kept + 2 > cornerLimit) return false; // only where rounding breaks convexity
            if ((fromSide < 0.0f && toSide > 0.0f) || (fromSide > 0.0f && toSide < 0.0f))
                cut[kept++] = from + (fromSide / (fromSide - toSide)) * (to - from);
            if (toSide <= 0.0f) cut[kept++] = to;
            from = to;
            fromSide = toSide;
        }
        if (kept == 0) return false; // the point lies inside its cell: only rounding empties it
        count = kept;
        std::swap(corners, cut);
        return true;
    };
    for (const glm::vec3& offset : offsets) {
        const glm::vec2 q(glm::dot(offset, frame.u), glm::dot(offset, frame.v));
        if (!cutTo(q, 0.5f * glm::dot(q, q))) return limit; // the bisector: x · q = |q|² / 2
    }
    for (int a = 0; region != nullptr && a < 3; ++a) {
        const glm::vec2 q(frame.u[a], frame.v[a]); // the face's normal in the plane
        if (std::isfinite(region->hi[a]) && !cutTo(q, region->hi[a] - point[a])) return limit;
        if (std::isfinite(region->lo[a]) && !cutTo(-q, point[a] - region->lo[a])) return limit;
    }
    float farthest = 0.0f;
    for (std::size_t c = 0; c < count; ++c) farthest = std::max(farthest, glm::dot(corners[c], corners[c]));
    return std::sqrt(farthest);
}

} // namespace

float drawnRadiusOf(std::span<const float> radii) {
    if (radii.empty()) return 0.0f;
    std::vector<float> sorted(radii.begin(), radii.end());
    const auto at =
        sorted.begin() + static_cast<std::ptrdiff_t>(quantileIndex(sorted.size(), kDrawnRadiusQuantile));
    std::nth_element(sorted.begin(), at, sorted.end());
    return *at;
}

void NeighbourShape::reserve(std::size_t count) {
    bend.reserve(count);
    splatRadius.reserve(count);
}

void NeighbourShape::appendFrom(const NeighbourShape& from, std::size_t i) {
    bend.push_back(from.bend[i]);
    splatRadius.push_back(from.splatRadius[i]);
}

NeighbourShape neighbourShapeOf(const PointSet& points, WorkerPool* pool, const Region* region) {
    NeighbourShape shape;
    shape.bend.assign(points.size(), 0.0f);
    shape.splatRadius.assign(points.radius.begin(), points.radius.end()); // none without radii
    if (points.size() < 2) return shape;
    const NearestGrid grid(points.position);
    const auto visit = [&](std::uint32_t i, const auto& nearest, std::size_t found) {
        float lowest = 1.0f; // the point itself is among its nearest, at angle 0
        for (std::size_t k = 0; k < found; ++k)
            lowest = std::min(lowest, glm::dot(points.normal[i], points.normal[nearest[k]]));
        shape.bend[i] = std::acos(std::clamp(lowest, -1.0f, 1.0f));
        if (!points.hasRadius()) return; // no radii to draw with: the bend only
        const glm::vec3 p = points.position[i];
        const float farthest = glm::length(points.position[nearest[found - 1]] - p);
        if (!(farthest > 0.0f)) return;
        std::array<glm::vec3, kBendNeighbours + 1> offsets;
        for (std::size_t k = 0; k < found; ++k) offsets[k] = points.position[nearest[k]] - p;
        const float cell = cellRadius(points.normal[i], std::span(offsets).first(found), farthest, p, region);
        shape.splatRadius[i] = std::min({shape.splatRadius[i], farthest, kCellMargin * cell});
    };
    const std::size_t columns = grid.columns();
    if (pool == nullptr || pool->size() < 2 || columns < 2) {
        grid.forEachNearest<kBendNeighbours + 1>(0, columns, visit);
        return shape;
    }
    // Each point's nearest are found exactly, whichever column range holds it: the same bits for
    // any thread count. Ranges of many columns each, handed out as workers free up (columns hold
    // unlike counts of points).
    const std::size_t chunk = std::max<std::size_t>(1, columns / (8 * std::size_t{pool->size()}));
    parallelForRanges(*pool, columns, chunk, [&](std::size_t begin, std::size_t end, unsigned) {
        grid.forEachNearest<kBendNeighbours + 1>(begin, end, visit);
    });
    return shape;
}

std::array<float, 2> medianRadiiOf(std::span<const float> radii) {
    if (radii.empty()) return {0.0f, 0.0f};
    std::vector<float> sorted(radii.begin(), radii.end());
    const std::size_t n = sorted.size();
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(n / 2), sorted.end());
    const float upper = sorted[n / 2];
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>((n - 1) / 2),
                     sorted.begin() + static_cast<std::ptrdiff_t>(n / 2));
    return {n % 2 == 1 ? upper : sorted[(n - 1) / 2], upper};
}

void normalConeOf(std::span<const glm::vec3> normals, glm::vec3& axis, float& angle) {
    glm::vec3 sum(0.0f);
    for (const glm::vec3 n : normals) sum += n;
    const float length = glm::length(sum);
    angle = 3.14159265f;
    if (!(length > 1e-3f * float(normals.size()))) return;
    axis = sum / length;
    float lowest = 1.0f;
    for (const glm::vec3 n : normals) lowest = std::min(lowest, glm::dot(n, axis));
    angle = std::acos(std::clamp(lowest, -1.0f, 1.0f)) + 1e-3f; // a little margin for rounding
}

std::vector<SplitPart> splitNode(std::span<const glm::vec3> points, const Region& region,
                                 std::uint32_t maxNodePoints) {
    std::vector<std::uint32_t> all(points.size());
    std::iota(all.begin(), all.end(), 0u);
    const std::size_t n = points.size();
    if (n <= maxNodePoints) return {SplitPart{region, std::move(all)}};
    const std::array<int, 3> axes = axesByExtent(boxOf(points, all));
    if (n <= 3 * std::size_t{maxNodePoints})
        return splitAlong(points, all, axes[0], n <= 2 * std::size_t{maxNodePoints} ? 2 : 3, region);
    std::vector<SplitPart> parts;
    for (const SplitPart& half : splitAlong(points, all, axes[0], 2, region)) {
        std::vector<SplitPart> quarters = splitAlong(points, half.indices, axes[1], 2, half.region);
        for (SplitPart& quarter : quarters) parts.push_back(std::move(quarter));
    }
    return parts;
}

namespace {

// The roots over `input`: halves at the median along the longest axis until each holds at most
// maxNodePoints and, for refinement, its radii spread at most kRootSpread (a tree only drawn
// decides no level of detail; its radii may be 0). In space order.
std::vector<SplitPart> cutRoots(const PointSet& input, const NodeSettings& settings, bool forRefinement) {
    std::vector<SplitPart> pending{SplitPart{Region{}, std::vector<std::uint32_t>(input.size())}};
    std::iota(pending[0].indices.begin(), pending[0].indices.end(), 0u);
    std::vector<SplitPart> roots;
    if (input.empty()) pending.clear(); // a tree only drawn may be empty: no roots
    while (!pending.empty()) {
        SplitPart part = std::move(pending.back());
        pending.pop_back();
        if (part.indices.size() <= settings.maxNodePoints &&
            !(forRefinement && spreadsTooWide(input.radius, part.indices))) {
            roots.push_back(std::move(part));
            continue;
        }
        const Box box = boxOf(input.position, part.indices);
        std::vector<SplitPart> halves =
            splitAlong(input.position, part.indices, axesByExtent(box)[0], 2, part.region);
        if (halves.size() < 2) {
            // Only coincident points left (possible in a tree only drawn; refinement requires
            // distinct positions): roots of consecutive points sharing the region.
            for (std::size_t first = 0; first < part.indices.size(); first += settings.maxNodePoints) {
                const auto begin = part.indices.begin() + static_cast<std::ptrdiff_t>(first);
                const auto end =
                    part.indices.begin() + static_cast<std::ptrdiff_t>(std::min<std::size_t>(
                                               part.indices.size(), first + settings.maxNodePoints));
                roots.push_back(SplitPart{part.region, std::vector<std::uint32_t>(begin, end)});
            }
            continue;
        }
        // Lower half last, so that it is taken first: roots in space order.
        pending.push_back(std::move(halves[1]));
        pending.push_back(std::move(halves[0]));
    }
    return roots;
}

// The roots' points and shapes, with the `segments` whose first point each holds.
std::vector<NodeChild> rootParts(const PointSet& input, std::span<const SplitPart> roots,
                                 std::span<const SegmentEnds> segments, bool forRefinement,
                                 WorkerPool& pool) {
    std::vector<NodeChild> parts(roots.size());
    if (!forRefinement) {
        // A tree only drawn draws the radii it was given, and no node of it is refined or drawn
        // through children, the only decisions that read the bends: nothing to measure (its
        // points' nearest and cells took about 1 us a point).
        NeighbourShape shape;
        shape.bend.assign(input.size(), 0.0f);
        shape.splatRadius.assign(input.radius.begin(), input.radius.end());
        for (std::size_t r = 0; r < roots.size(); ++r)
            parts[r] = partOf(input, shape, {}, roots[r], segments);
        return parts;
    }
    // Each root's splats are measured among its own points, their cells cut to its region: a root
    // drawn beside nodes drawn levels deeper covers its region up to its faces (a choice,
    // docs/REALTIME.md, "Roots of one density": measured among all of P0, its cells stopped short of
    // its faces where P0's points beyond them were nearer, and those points' nodes, drawn finer, do
    // not reach that far).
    pool.parallelFor(roots.size(), [&](std::size_t r, unsigned) {
        NodeChild& root = parts[r];
        root.region = roots[r].region;
        root.points.reserve(roots[r].indices.size());
        for (const std::uint32_t i : roots[r].indices) root.points.appendFrom(input, i);
        root.shape = neighbourShapeOf(root.points, nullptr, &root.region);
        root.segments = segmentsIn(root.region, segments);
    });
    return parts;
}

} // namespace

Result<NodeTree> NodeTree::create(PointSet input, const NodeSettings& settings, bool forRefinement) {
    if (settings.maxNodePoints < 16)
        return Error{"nodes must hold at least 16 points (got " + std::to_string(settings.maxNodePoints) +
                     ")"};
    if (forRefinement) {
        if (auto valid = validateForRefinement(input); !valid) return valid.error();
    } else if (input.normal.size() != input.size() || input.radius.size() != input.size()) {
        return Error{"the point set lacks normals or radii"};
    }
    const auto start = std::chrono::steady_clock::now();
    NodeTree tree;
    tree.settings_ = settings;
    tree.inputPoints_ = input.size();
    // Whole levels first (P(0) to P(W) as the offline refinement builds them, and the segments of
    // P(W)), or the segments of P0.
    std::vector<PointSet> whole;
    std::vector<SegmentEnds> segments;
    if (forRefinement && double(input.size()) * kLevelGrowth <= double(settings.wholeLevelPoints)) {
        whole = refineWholeLevels(std::move(input), settings, segments);
        tree.wholeLevels_ = static_cast<std::uint32_t>(whole.size() - 1);
        input = std::move(whole.front());
    } else if (forRefinement) {
        segments = findSegments(input, settings.refine);
    }

    const std::vector<SplitPart> roots = cutRoots(input, settings, forRefinement);
    // A tree only drawn measures nothing and refines no whole level (below): a pool of one, no thread.
    WorkerPool pool(forRefinement ? settings.refine.threads : 1u);
    // With whole levels, the segments go to the last one's nodes.
    std::vector<NodeChild> parts =
        rootParts(input, roots,
                  whole.size() <= 1 ? std::span<const SegmentEnds>(segments) : std::span<const SegmentEnds>(),
                  forRefinement, pool);
    std::vector<NodeId> level; // the nodes of the level being built, in tree order
    for (NodeChild& part : parts) {
        const NodeId id = tree.allocate();
        tree.place(id, std::move(part));
        tree.roots_.push_back(id);
        level.push_back(id);
    }
    // The whole levels below the roots, the last with the segments.
    for (std::uint32_t l = 1; l < whole.size(); ++l) {
        level = tree.splitUnder(level, whole[l],
                                l + 1 == whole.size() ? std::span<const SegmentEnds>(segments)
                                                      : std::span<const SegmentEnds>(),
                                pool);
    }
    tree.creationSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return tree;
}

std::vector<NodeId> NodeTree::splitUnder(std::span<const NodeId> level, const PointSet& points,
                                         std::span<const SegmentEnds> segments, WorkerPool& pool) {
    const NeighbourShape levelShape = neighbourShapeOf(points, &pool);
    // The regions of each level partition space: a point's node of the level above is found from
    // the root that holds it, child by child.
    const std::uint32_t parentLevel = nodes_[level.front()].level;
    std::vector<std::uint32_t> slot(nodes_.size());
    for (std::size_t k = 0; k < level.size(); ++k) slot[level[k]] = static_cast<std::uint32_t>(k);
    std::vector<std::vector<std::uint32_t>> inNode(level.size());
    for (std::uint32_t i = 0; i < points.size(); ++i) {
        const glm::vec3 p = points.position[i];
        const auto holds = [&](NodeId n) { return nodes_[n].region.contains(p); };
        NodeId at = *std::ranges::find_if(roots_, holds);
        while (nodes_[at].level < parentLevel) at = *std::ranges::find_if(nodes_[at].childIds(), holds);
        inNode[slot[at]].push_back(i);
    }
    std::vector<NodeId> next;
    for (std::size_t k = 0; k < level.size(); ++k) {
        assert(!inNode[k].empty()); // its own points are points of every later level
        const NodeId parent = level[k];
        adopt(parent, childrenOf(points, levelShape, inNode[k], nodes_[parent].region, segments,
                                 settings_.maxNodePoints));
        for (const NodeId c : nodes_[parent].childIds()) next.push_back(c);
    }
    return next;
}

NodeId NodeTree::allocate() {
    NodeId id;
    if (!free_.empty()) {
        id = free_.back();
        free_.pop_back();
    } else {
        id = static_cast<NodeId>(nodes_.size());
        nodes_.emplace_back();
        live_.push_back(0);
    }
    const std::uint32_t generation = nodes_[id].generation + 1;
    nodes_[id] = Node{};
    nodes_[id].generation = generation;
    live_[id] = 1;
    ++liveCount_;
    return id;
}

bool NodeTree::ready(NodeId id, std::vector<NodeId>& blockers) const {
    const Node& x = nodes_[id];
    if (!x.isLeaf() || x.level >= settings_.maxLevel) return false;
    const float reach = kRetryReach * x.maxPointRadius;
    const glm::vec3 lo = x.lo - reach, hi = x.hi + reach;
    bool ok = true;
    std::vector<NodeId> stack(roots_.rbegin(), roots_.rend());
    while (!stack.empty()) {
        const NodeId n = stack.back();
        stack.pop_back();
        const Node& node = nodes_[n];
        if (node.level >= x.level || !meets(node.region, lo, hi)) continue;
        if (node.isLeaf()) {
            blockers.push_back(n);
            ok = false;
            continue;
        }
        for (std::uint32_t c = node.childCount; c-- > 0;) stack.push_back(node.children[c]);
    }
    return ok;
}

// Appends to `context` the points within [lo, hi] of the nodes of `level` other than `id`, below
// `from`, in tree order.
void NodeTree::gatherContext(NodeId id, glm::vec3 lo, glm::vec3 hi, std::uint32_t level, NodeId from,
                             PointSet& context) const {
    const Node& node = nodes_[from];
    if (!meets(node.region, lo, hi)) return;
    if (node.level < level) {
        assert(!node.isLeaf()); // ready()
        for (const NodeId c : node.childIds()) gatherContext(id, lo, hi, level, c, context);
        return;
    }
    if (from == id) return;
    for (std::size_t i = 0; i < node.points.size(); ++i)
        if (inside(node.points.position[i], lo, hi)) context.appendFrom(node.points, i);
}

NodeJob NodeTree::makeJob(NodeId id, bool recordParents) const {
    const Node& x = nodes_[id];
    NodeJob job;
    job.node = id;
    job.generation = x.generation;
    RegionLevel& input = job.input;
    input.points = x.points;
    input.owned = x.points.size();
    input.region = x.region;
    input.level = x.level;
    input.segments = x.segments;
    input.recordParents = recordParents;
    const float reach = kRetryReach * x.maxPointRadius;
    for (const NodeId root : roots_)
        gatherContext(id, x.lo - reach, x.hi + reach, x.level, root, input.points);
    return job;
}

NodeJobResult NodeTree::run(NodeJob job, const NodeSettings& settings) {
    NodeJobResult out;
    out.node = job.node;
    out.generation = job.generation;
    const Region region = job.input.region;
    RegionResult refined = refineRegion(std::move(job.input), settings.refine);
    out.stats = refined.stats;
    out.parents = std::move(refined.parents);
    out.children = childrenOf(refined.points, neighbourShapeOf(refined.points), {}, region, refined.segments,
                              settings.maxNodePoints);
    return out;
}

bool NodeTree::attach(NodeJobResult&& result) {
    if (!isLive(result.node)) return false;
    if (nodes_[result.node].generation != result.generation || !nodes_[result.node].isLeaf()) return false;
    adopt(result.node, std::move(result.children));
    ++nodes_[result.node].generation;
    return true;
}

void NodeTree::adopt(NodeId parent, std::vector<NodeChild>&& children) {
    assert(!children.empty() && children.size() <= 4);
    std::array<NodeId, 4> ids{kNoNode, kNoNode, kNoNode, kNoNode};
    for (std::size_t c = 0; c < children.size(); ++c) {
        ids[c] = allocate(); // may move nodes_: no references across this loop
        nodes_[ids[c]].level = nodes_[parent].level + 1;
        nodes_[ids[c]].parent = parent;
        place(ids[c], std::move(children[c]));
    }
    nodes_[parent].children = ids;
    nodes_[parent].childCount = static_cast<std::uint32_t>(children.size());
}

void NodeTree::place(NodeId id, NodeChild&& made) {
    Node& node = nodes_[id];
    node.region = made.region;
    node.points = std::move(made.points);
    node.shape = std::move(made.shape);
    node.segments = std::move(made.segments);
    describePoints(node);
    pointCount_ += node.points.size();
}

void NodeTree::release(NodeId id) {
    Node& node = nodes_[id];
    assert(node.level >= wholeLevels_); // no job makes the whole levels' children again
    for (const NodeId c : node.childIds()) {
        Node& child = nodes_[c];
        assert(child.isLeaf());
        pointCount_ -= child.points.size();
        child.points = PointSet{};
        child.shape = {};
        child.segments = {};
        live_[c] = 0;
        --liveCount_;
        free_.push_back(c);
    }
    node.childCount = 0;
    node.children = {kNoNode, kNoNode, kNoNode, kNoNode};
    ++node.generation;
}

} // namespace pnsplat
