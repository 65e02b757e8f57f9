#include "pnsplat/refine/huge_pages.h"

#include <bit>
#include <cstdlib>
#include <mutex>
#include <new>
#include <utility>
#include <vector>

#ifdef __linux__
#include <sys/mman.h>
#endif

namespace pnsplat {

namespace {

std::size_t blockBytes(std::size_t bytes) {
    return std::bit_ceil((bytes + kHugePageBytes - 1) / kHugePageBytes) * kHugePageBytes;
}

// Released blocks (size, address), most recent last. Never destroyed: blocks may be released by
// destructors of other static objects at exit. The list never grows past its first capacity (each
// block is a whole huge page at least), so releasing allocates nothing: it runs in deallocate,
// which must not throw, also when memory has run out.
struct KeptBlocks {
    KeptBlocks() { blocks.reserve(kKeptHugePageBytes / kHugePageBytes); }
    std::mutex mutex;
    std::vector<std::pair<std::size_t, void*>> blocks;
    std::size_t bytes = 0;
};
KeptBlocks& kept() {
    static KeptBlocks& blocks = *new KeptBlocks;
    return blocks;
}

} // namespace

void* allocateHugePages(std::size_t bytes) {
    const std::size_t size = blockBytes(bytes);
    {
        KeptBlocks& k = kept();
        const std::lock_guard lock(k.mutex);
        for (std::size_t i = k.blocks.size(); i-- > 0;) {
            if (k.blocks[i].first != size) continue;
            void* data = k.blocks[i].second;
            k.blocks.erase(k.blocks.begin() + static_cast<std::ptrdiff_t>(i));
            k.bytes -= size;
            return data;
        }
    }
    void* data = std::aligned_alloc(kHugePageBytes, size);
    if (data == nullptr) throw std::bad_alloc();
#ifdef __linux__
    // Advice only: where it is refused (no transparent huge pages) the pages stay small.
    madvise(data, size, MADV_HUGEPAGE);
#endif
    return data;
}

void releaseHugePages(void* data, std::size_t bytes) {
    const std::size_t size = blockBytes(bytes);
    {
        KeptBlocks& k = kept();
        const std::lock_guard lock(k.mutex);
        if (k.bytes + size <= kKeptHugePageBytes) {
            k.blocks.emplace_back(size, data);
            k.bytes += size;
            return;
        }
    }
    std::free(data);
}

} // namespace pnsplat
