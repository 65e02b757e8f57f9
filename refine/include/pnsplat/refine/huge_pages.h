// Memory for point arrays, backed by transparent huge pages where the system offers them (Linux,
// madvise mode): a level of refinement writes megabytes of fresh memory, and with 4 KiB pages
// every one of them costs a page fault (several microseconds each on virtual machines, a tenth of
// a level there; one per 2 MiB with huge pages). Elsewhere the advice is a no-op. Any thread.
#pragma once

#include <algorithm>
#include <cstddef>
#include <memory>
#include <new>
#include <vector>

namespace pnsplat {

inline constexpr std::size_t kHugePageBytes = std::size_t{1} << 21;

// A block of at least `bytes` aligned to huge pages and advised as such: a power of two of whole
// huge pages. Throws std::bad_alloc. Release it with the same `bytes`: released blocks are kept
// for reuse, up to kKeptHugePageBytes in all, as malloc keeps freed heap memory (a block in use
// is already faulted in; a fresh one costs a fault and a cleared page per 2 MiB).
void* allocateHugePages(std::size_t bytes);
void releaseHugePages(void* data, std::size_t bytes);
inline constexpr std::size_t kKeptHugePageBytes = std::size_t{128} << 20;

// Allocator for point arrays (PointSet's, the refinement's): blocks of 128 KiB and more (those
// malloc would map afresh, faulting every 4 KiB) are whole advised huge pages, kept for reuse;
// smaller ones come from operator new.
template <typename T>
struct HugePageAllocator {
    using value_type = T;
    static constexpr std::size_t kSmallBytes = std::size_t{128} << 10;

    HugePageAllocator() = default;
    template <typename U>
    HugePageAllocator(const HugePageAllocator<U>&) noexcept {} // implicit, as allocators convert

    T* allocate(std::size_t n) {
        const std::size_t bytes = n * sizeof(T);
        return static_cast<T*>(bytes < kSmallBytes ? ::operator new(bytes) : allocateHugePages(bytes));
    }
    void deallocate(T* data, std::size_t n) noexcept {
        if (n * sizeof(T) < kSmallBytes) {
            ::operator delete(data);
        } else {
            releaseHugePages(data, n * sizeof(T));
        }
    }
    friend bool operator==(const HugePageAllocator&, const HugePageAllocator&) { return true; }
};

template <typename T>
using HugePageVector = std::vector<T, HugePageAllocator<T>>;

// Append-only storage in huge-page-advised blocks for one writer, reused from level to level. Runs
// of elements ("cells") stay contiguous: a run that no longer fits its block moves whole to the
// next one. T must be trivially copyable.
template <typename T>
class BlockArena {
  public:
    // Starts a new pass: every block is free again (and kept).
    void clear() {
        block_ = 0;
        used_ = 0;
    }
    // Starts a run; returns where it begins.
    T* open() { return blocks_.empty() ? nullptr : blocks_[block_].data.get() + used_; }
    // Appends `value` to the open run, which starts at `run` and holds `count` elements; when the
    // block is full the run moves to the next block, and `run` with it.
    void append(T*& run, std::size_t count, const T& value) {
        if (blocks_.empty() || used_ == blocks_[block_].capacity) moveRun(run, count);
        run[count] = value;
        ++used_;
    }

  private:
    struct Release {
        std::size_t bytes;
        void operator()(T* p) const { releaseHugePages(p, bytes); }
    };
    struct Block {
        std::unique_ptr<T[], Release> data;
        std::size_t capacity;
    };
    static constexpr std::size_t kBlockBytes = 4 * kHugePageBytes;

    void moveRun(T*& run, std::size_t count) {
        const std::size_t needed = 2 * (count + 1);
        std::size_t next = blocks_.empty() ? 0 : block_ + 1;
        while (next < blocks_.size() && blocks_[next].capacity < needed) ++next;
        if (next == blocks_.size()) {
            const std::size_t bytes = std::max(needed * sizeof(T), kBlockBytes);
            T* data = static_cast<T*>(allocateHugePages(bytes));
            blocks_.push_back(Block{std::unique_ptr<T[], Release>(data, Release{bytes}), bytes / sizeof(T)});
        }
        T* moved = blocks_[next].data.get();
        std::copy(run, run + count, moved);
        block_ = next;
        used_ = count;
        run = moved;
    }

    std::vector<Block> blocks_;
    std::size_t block_ = 0, used_ = 0; // the block appended to, and its elements in use
};

} // namespace pnsplat
