// The huge-page allocator and the block arena (huge_pages.h): contents survive growth and moves.
#include <cstdint>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "pnsplat/refine/huge_pages.h"

namespace pnsplat {
namespace {

TEST(HugePages, LargeBlocksOfTheAllocatorAreWholeHugePages) {
    HugePageVector<std::uint64_t> v = {1, 2, 3};
    v.resize(std::size_t{1} << 18); // 2 MiB
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(v.data()) % kHugePageBytes, 0u);
    EXPECT_EQ(v[1], 2u);
    EXPECT_EQ(v.back(), 0u);
    v.resize(5);
    v.shrink_to_fit(); // a small block again
    EXPECT_EQ(v[2], 3u);
}

// Blocks are powers of two of huge pages; a released one serves the next request of its size.
TEST(HugePages, ReleasedBlocksAreReused) {
    void* a = allocateHugePages(3 * kHugePageBytes);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(a) % kHugePageBytes, 0u);
    static_cast<char*>(a)[4 * kHugePageBytes - 1] = 1; // the block is 4 huge pages
    releaseHugePages(a, 3 * kHugePageBytes);
    void* b = allocateHugePages(4 * kHugePageBytes - 1); // the same size class
    EXPECT_EQ(b, a);
    void* c = allocateHugePages(4 * kHugePageBytes - 1); // another block
    EXPECT_NE(c, a);
    releaseHugePages(b, 4 * kHugePageBytes - 1);
    releaseHugePages(c, 4 * kHugePageBytes - 1);
}

struct Item {
    std::uint32_t run, k;
    float pad[14];
};

// Runs of random lengths, some longer than a block, through two passes (clear() in between): every
// run stays contiguous and holds what was appended, also after later runs moved on to new blocks.
TEST(BlockArena, RunsStayContiguousAcrossBlocks) {
    BlockArena<Item> arena;
    std::mt19937_64 rng(21);
    for (int pass = 0; pass < 2; ++pass) {
        arena.clear();
        std::vector<Item*> runs;
        std::vector<std::uint32_t> lengths;
        std::size_t total = 0;
        for (std::uint32_t run = 0; total < 600000; ++run) {
            const auto length =
                static_cast<std::uint32_t>(run % 50 == 49 ? 200000 + rng() % 1000 : rng() % 300);
            Item* base = arena.open();
            for (std::uint32_t k = 0; k < length; ++k) arena.append(base, k, Item{run, k, {}});
            runs.push_back(base);
            lengths.push_back(length);
            total += length;
        }
        std::size_t checked = 0;
        for (std::uint32_t run = 0; run < runs.size(); ++run) {
            for (std::uint32_t k = 0; k < lengths[run]; ++k) {
                ASSERT_EQ(runs[run][k].run, run) << pass << " " << k;
                ASSERT_EQ(runs[run][k].k, k) << pass << " " << run;
            }
            checked += lengths[run];
        }
        EXPECT_EQ(checked, total);
    }
}

} // namespace
} // namespace pnsplat
