#include "pnsplat/refine/huge_pages.h"

#include <cstdint>
#include <cstdlib>
#include <new>

#ifdef __linux__
#include <sys/mman.h>
#endif

namespace pnsplat {

void adviseHugePages(void* data, std::size_t bytes) {
#ifdef __linux__
    const auto address = reinterpret_cast<std::uintptr_t>(data);
    const std::uintptr_t begin = (address + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
    const std::uintptr_t end = (address + bytes) / kHugePageBytes * kHugePageBytes;
    // Advice only: where it is refused (no transparent huge pages) the pages stay small.
    if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#else
    (void)data;
    (void)bytes;
#endif
}

void* allocateHugePages(std::size_t bytes) {
    const std::size_t rounded = (bytes + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
    void* data = std::aligned_alloc(kHugePageBytes, rounded);
    if (data == nullptr) throw std::bad_alloc();
    adviseHugePages(data, rounded);
    return data;
}

void releaseHugePages(void* data) { std::free(data); }

} // namespace pnsplat
