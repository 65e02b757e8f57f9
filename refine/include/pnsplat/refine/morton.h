// Morton (Z-order) codes: the bits of three integer cell coordinates interleaved, so that sorting
// points by the code of their cell orders them along a space-filling curve on which points close in
// space are mostly close in the order (mortonOrder, point_set.h). The refinement stores P0 in this
// order (refiner.cpp, spatialOrder), and completeInput estimates in it (input.cpp).
// Pure constexpr functions; any thread.
#pragma once

#include <cstdint>

namespace pnsplat {

// Bits per coordinate of a 64-bit code.
inline constexpr unsigned kMortonBits = 21;

// Bit k of v moves to bit 3k, for k < kMortonBits; the higher bits of v are dropped.
constexpr std::uint64_t spreadMortonBits(std::uint64_t v) {
    v &= (std::uint64_t{1} << kMortonBits) - 1;
    v = (v | v << 32) & 0x1f00000000ffffull;
    v = (v | v << 16) & 0x1f0000ff0000ffull;
    v = (v | v << 8) & 0x100f00f00f00f00full;
    v = (v | v << 4) & 0x10c30c30c30c30c3ull;
    v = (v | v << 2) & 0x1249249249249249ull;
    return v;
}

// The code of cell (x, y, z): bit k of x, y and z goes to bit 3k, 3k+1 and 3k+2. Coordinates
// must be below 2^kMortonBits (higher bits are dropped); coordinates below 2^b give codes below
// 2^(3b).
constexpr std::uint64_t mortonCode(std::uint32_t x, std::uint32_t y, std::uint32_t z) {
    return spreadMortonBits(x) | spreadMortonBits(y) << 1 | spreadMortonBits(z) << 2;
}

static_assert(mortonCode(1, 0, 0) == 1 && mortonCode(0, 1, 0) == 2 && mortonCode(0, 0, 1) == 4);
static_assert(mortonCode(3, 5, 6) == 0b110'101'011);
static_assert(mortonCode(0x1fffff, 0x1fffff, 0x1fffff) == (std::uint64_t{1} << 63) - 1);

} // namespace pnsplat
