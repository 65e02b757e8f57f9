// The ring-buffer GPU cache of the real-time refinement (paper section 7): one buffer of
// fixed capacity holds the splats of every resident node, each node one contiguous chunk.
//
// The input's chunks sit at the front for good (allocatePermanent). The rest is a ring: a new chunk
// is placed at the ring's head, and the chunks it overlaps are evicted, oldest placement first,
// except pinned ones (drawn by the current frame or by a frame still in flight, as the caller
// says), which the head jumps over. So chunks are overwritten only once no frame reads them, and
// a chunk that stays visible survives every pass of the head.
//
// Writes go straight into the buffer where its memory is host-visible (lavapipe, integrated GPUs);
// otherwise into a staging buffer of the current frame (one per frame in flight: a staging ring),
// with a copy recorded into the frame's upload command buffer.
//
// Thread use: the render thread only.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <vector>

#include "gpu_types.h"
#include "pnsplat/engine/buffer.h"
#include "pnsplat/engine/frames.h"

namespace pnsplat::engine {

struct Chunk {
    std::uint32_t first = 0, count = 0; // splats [first, first + count) of the buffer
};

class ChunkCache {
  public:
    // capacity in splats (> 0, at most half the device's texel buffer elements: the caller checks).
    // forceStaging: write through the staging ring even where the buffer is host-visible (tests
    // of the path GPUs with device-local memory take). Throws VulkanError.
    ChunkCache(Context& context, std::uint32_t capacity, bool forceStaging = false);

    const Buffer& buffer() const { return buffer_; }
    // The buffer as the passes read it: two RGBA32UI texels a splat (splat_common.glsl).
    VkBufferView texels() const { return texels_.get(); }
    std::uint32_t capacity() const { return capacity_; }
    std::uint32_t used() const { return used_; } // splats in chunks, permanent ones included
    bool staged() const { return staged_; }

    // A chunk at the front that is never evicted; only before any allocate(). Nothing when full.
    std::optional<Chunk> allocatePermanent(std::uint32_t count);
    // A chunk of `count` splats for `owner` at the ring's head; the chunks evicted to make room are
    // appended to `evicted` (their owners). pinned(owner) tells a chunk that may not be evicted.
    // Nothing (and nothing evicted) when no place is found in one turn of the ring.
    std::optional<Chunk> allocate(std::uint32_t count, std::uint32_t owner,
                                  const std::function<bool(std::uint32_t owner)>& pinned,
                                  std::vector<std::uint32_t>& evicted);
    // Gives back a ring chunk (its owner is gone); no frame may read it any more.
    void release(Chunk chunk);

    // Writes splats into `chunk` for the current frame of `frames`: directly, or staged with a copy
    // recorded into `uploads` (a command buffer of the current frame, created on first need; the
    // caller submits it before the frame's passes).
    void write(Chunk chunk, std::span<const gpu::Splat> splats, FrameRing& frames, VkCommandBuffer& uploads);

  private:
    struct Entry {
        std::uint32_t count, owner;
    };
    Context& context_;
    Buffer buffer_;
    Unique<VkBufferView> texels_;
    std::uint32_t capacity_ = 0, permanentEnd_ = 0, head_ = 0, used_ = 0;
    std::map<std::uint32_t, Entry> ring_; // ring chunks by first splat
    bool staged_ = false;
    std::array<Buffer, kFramesInFlight> staging_;
    std::array<VkDeviceSize, kFramesInFlight> stagingUsed_{};
    std::array<std::uint64_t, kFramesInFlight> stagingFrame_{};
};

} // namespace pnsplat::engine
