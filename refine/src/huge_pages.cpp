#include "pnsplat/refine/huge_pages.h"

#include <cstdlib>
#include <new>

#ifdef __linux__
#include <sys/mman.h>
#endif

namespace pnsplat {

void* allocateHugePages(std::size_t bytes) {
    const std::size_t rounded = (bytes + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
    void* data = std::aligned_alloc(kHugePageBytes, rounded);
    if (data == nullptr) throw std::bad_alloc();
#ifdef __linux__
    // Advice only: where it is refused (no transparent huge pages) the pages stay small.
    madvise(data, rounded, MADV_HUGEPAGE);
#endif
    return data;
}

void releaseHugePages(void* data) { std::free(data); }

} // namespace pnsplat
