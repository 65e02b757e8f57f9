// The colour cells and tiles of a level: see level_cells.h and refiner.cpp's top.
#include "level_cells.h"

#include <array>
#include <bit>
#include <cassert>

namespace pnsplat {

namespace {

constexpr unsigned kMaxTileShift = 4; // tiles of at most 16³ cells
constexpr std::size_t kMinTiles = 64; // tiles of a level, at least (where the cells allow)

// Sorts (cell key, index) pairs given in increasing index order by key, then index: the order
// std::sort gives them. A stable least-significant-digit radix sort over the bits the keys use,
// in digits of at most 11 bits within each coordinate: typically three passes over the array
// where a comparison sort makes log2(n).
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

} // namespace

LevelCells sortIntoCells(std::span<const glm::vec3> position, std::span<const float> levelRadius,
                         std::span<const std::uint8_t> skipped, const LevelScale& level, WorkerPool& pool) {
    const auto count = static_cast<std::uint32_t>(position.size());
    const float cellSize = std::max(kCellFactor * level.radiusLimit, level.extent / float(1u << 20));
    LevelCells out;
    CellKeys& keyed = out.keyed;
    keyed.resize(count);
    parallelForRanges(pool, count, 16384, [&](std::size_t begin, std::size_t end, unsigned) {
        for (auto i = static_cast<std::uint32_t>(begin); i < end; ++i)
            keyed[i] = {cellKeyOf(position[i], level.lo, cellSize), i};
    });
    sortCellKeys(keyed);
    out.gridKey.resize(count);
    out.gridPoint.resize(count);
    for (std::uint32_t k = 0; k < count; ++k)
        out.gridKey[k] = keyed[k].first, out.gridPoint[k] = keyed[k].second;
    // The points refined in cells: all but the large ones and those skipped.
    std::vector<std::uint32_t> large;
    for (std::uint32_t i = 0; i < count; ++i) {
        if (skipped[i]) continue;
        ++out.refinedPoints;
        if (levelRadius[i] > level.radiusLimit) large.push_back(i);
    }
    std::erase_if(keyed, [&](const auto& entry) {
        return skipped[entry.second] || levelRadius[entry.second] > level.radiusLimit;
    });
    out.largePoints = large.size();
    // The large points get a colouring of their own, at the scale of the largest of them, appended
    // to `keyed` (their cells' keys use that scale).
    const std::size_t smallEnd = keyed.size();
    if (!large.empty()) {
        float largest = 0.0f;
        for (const std::uint32_t i : large) largest = std::max(largest, levelRadius[i]);
        const float largeCellSize = std::max(kCellFactor * largest, level.extent / float(1u << 20));
        CellKeys keyedLarge(large.size());
        for (std::size_t k = 0; k < large.size(); ++k)
            keyedLarge[k] = {cellKeyOf(position[large[k]], level.lo, largeCellSize), large[k]};
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

LevelTiles tilesOf(const LevelCells& level) {
    const unsigned tileShift = chooseTileShift(level.keyed, std::span(level.cells.data(), level.smallCells));
    return LevelTiles{makeTiles(level.keyed, level.cells, 0, level.smallCells, tileShift),
                      makeTiles(level.keyed, level.cells, level.smallCells,
                                static_cast<std::uint32_t>(level.cells.size()), 0)};
}

} // namespace pnsplat
