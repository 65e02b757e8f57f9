// The colour cells and tiles of a level (refiner.cpp's top, ALGORITHM.md §5): every point of P(l)
// by cell, the grid a group of points searches for its surroundings; the points the level refines,
// by cell; and the cells in tiles, with the task graph that orders adjacent tiles by colour.
// Private to refine/src.
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include <glm/common.hpp>
#include <glm/vec3.hpp>

#include "pnsplat/refine/huge_pages.h"
#include "pnsplat/refine/worker_pool.h"

namespace pnsplat {

// > 2 and > kRetryReach, see refiner.cpp's top. Larger cells gather the surroundings of more
// points at once; each point then scans the sub-cells around it (CandidateGrid): 4.5 was the
// fastest of 2.25, 3, 4, 4.5, 5, 6 and 9 (1.06x over 2.25 on the faster variants, 1.04x on the full
// method; pinned A/B), and with the sub-cells still over 3 (sparse bunny, 6 levels, one thread:
// 2.54 s against 2.63 s).
inline constexpr float kCellFactor = 4.5f;

// Colour cells: integer coordinates of 21 bits each, packed x, y, z from the most significant
// bits, so that keys sort by x, then y, then z.
inline constexpr std::uint64_t kCellCoordinateMask = (1u << 21) - 1;
inline std::uint64_t packCell(std::uint64_t x, std::uint64_t y, std::uint64_t z) {
    return x << 42 | y << 21 | z;
}
inline std::uint64_t cellKeyOf(glm::vec3 x, glm::vec3 lo, float cellSize) {
    const glm::uvec3 c =
        glm::uvec3(glm::clamp((x - lo) / cellSize, glm::vec3(0.0f), glm::vec3(float(kCellCoordinateMask))));
    return packCell(c.x, c.y, c.z);
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

using CellKeys = HugePageVector<std::pair<std::uint64_t, std::uint32_t>>;
struct Cell {
    std::uint32_t begin, end; // into LevelCells::keyed
};

struct LevelCells {
    // Every point of P(l) by colour cell: cell keys in increasing order and the points, (key, index)
    // sorted. A group of points of one cell finds its surroundings here (PointStep::gatherNearby).
    HugePageVector<std::uint64_t> gridKey;
    HugePageVector<std::uint32_t> gridPoint;
    // The points the level refines, by cell: (cell key, point) pairs, the small points' cells in key
    // order, then the large points' (r > r_lim: a colouring of their own, at the scale of the largest
    // of them); `cells` index into `keyed`.
    CellKeys keyed;
    HugePageVector<Cell> cells;
    std::uint32_t smallCells = 0;
    std::size_t refinedPoints = 0, largePoints = 0;
};

// The level's cells, from the positions and radii of P(l) (scaled) and which points it skips.
LevelCells sortIntoCells(std::span<const glm::vec3> position, std::span<const float> levelRadius,
                         std::span<const std::uint8_t> skipped, const LevelScale& level, WorkerPool& pool);

// Cells in tiles, cubes of 2^tileShift cells a side, coloured by the parity of their integer
// coordinates, tiles in key order and a tile's cells in key order. Tile k of the task graph waits
// for its adjacent tiles of lower colours.
struct Tiles {
    std::vector<std::uint32_t> cells;     // cell indices, tile after tile
    std::vector<std::uint32_t> cellBegin; // per tile, into cells; tiles + 1 entries
    TaskGraph graph;
};
// The small points' cells in the largest tiles that leave the workers at least kMinTiles to share
// (a choice of the data alone, never of the thread count), and the large points' cells one a tile.
struct LevelTiles {
    Tiles small, large;
};
LevelTiles tilesOf(const LevelCells& level);

} // namespace pnsplat
