// The ring-buffer GPU cache (chunk_cache.h).
#include "chunk_cache.h"

#include <algorithm>
#include <cassert>
#include <cstring>

namespace pnsplat::engine {

namespace {
constexpr VkDeviceSize kSplatBytes = sizeof(gpu::Splat);
} // namespace

ChunkCache::ChunkCache(Context& context, std::uint32_t capacity, bool forceStaging)
    : context_(context), capacity_(capacity) {
    assert(capacity > 0);
    buffer_ = createBuffer(context, VkDeviceSize{capacity} * kSplatBytes,
                           VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                               VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                           MemoryUse::Device);
    texels_ = createTexelView(context, buffer_, VK_FORMAT_R32G32B32A32_UINT);
    staged_ = forceStaging || buffer_.mapped == nullptr;
}

std::optional<Chunk> ChunkCache::allocatePermanent(std::uint32_t count) {
    assert(ring_.empty());
    if (count > capacity_ - permanentEnd_) return std::nullopt;
    const Chunk chunk{permanentEnd_, count};
    permanentEnd_ += count;
    head_ = permanentEnd_;
    used_ += count;
    return chunk;
}

std::optional<Chunk> ChunkCache::allocate(std::uint32_t count, std::uint32_t owner,
                                          const std::function<bool(std::uint32_t)>& pinned,
                                          std::vector<std::uint32_t>& evicted) {
    if (count == 0 || count > capacity_ - permanentEnd_) return std::nullopt;
    std::uint32_t at = head_;
    bool wrapped = false;
    for (;;) {
        if (at + count > capacity_) {
            if (wrapped) return std::nullopt;
            wrapped = true;
            at = permanentEnd_;
        }
        if (wrapped && at >= head_) return std::nullopt; // one whole turn: no room
        // The chunks overlapping [at, at + count): the one starting before `at` that reaches into
        // it, and those starting inside.
        auto first = ring_.lower_bound(at);
        if (first != ring_.begin()) {
            const auto before = std::prev(first);
            if (before->first + before->second.count > at) first = before;
        }
        auto last = first;
        std::uint32_t blockedUntil = 0;
        for (; last != ring_.end() && last->first < at + count; ++last)
            if (pinned(last->second.owner)) blockedUntil = last->first + last->second.count;
        if (blockedUntil == 0) {
            for (auto it = first; it != last; ++it) {
                evicted.push_back(it->second.owner);
                used_ -= it->second.count;
            }
            ring_.erase(first, last);
            ring_.emplace(at, Entry{count, owner});
            used_ += count;
            head_ = at + count;
            return Chunk{at, count};
        }
        at = blockedUntil; // jump over the pinned chunk(s)
    }
}

void ChunkCache::release(Chunk chunk) {
    const auto it = ring_.find(chunk.first);
    assert(it != ring_.end() && it->second.count == chunk.count);
    used_ -= it->second.count;
    ring_.erase(it);
}

void ChunkCache::write(Chunk chunk, std::span<const gpu::Splat> splats, FrameRing& frames,
                       VkCommandBuffer& uploads) {
    assert(splats.size() == chunk.count);
    const VkDeviceSize bytes = splats.size() * kSplatBytes;
    if (!staged_) {
        std::memcpy(static_cast<char*>(buffer_.mapped) + chunk.first * kSplatBytes, splats.data(), bytes);
        return;
    }
    // The staging buffer of this frame's slot: its previous frame has finished (FrameRing::begin).
    const std::uint32_t slot = frames.slot();
    if (stagingFrame_[slot] != frames.index() + 1) {
        stagingFrame_[slot] = frames.index() + 1;
        stagingUsed_[slot] = 0;
    }
    Buffer& staging = staging_[slot];
    if (stagingUsed_[slot] + bytes > staging.size) {
        // Grow; what this frame staged already stays in the old buffer until the frame is done.
        const VkDeviceSize size =
            std::max<VkDeviceSize>(2 * (stagingUsed_[slot] + bytes), VkDeviceSize{1} << 20);
        Buffer grown = createBuffer(context_, size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUse::Upload);
        frames.defer(std::move(staging));
        staging = std::move(grown);
        stagingUsed_[slot] = 0;
    }
    std::memcpy(static_cast<char*>(staging.mapped) + stagingUsed_[slot], splats.data(), bytes);
    if (uploads == VK_NULL_HANDLE) {
        uploads = frames.commandBuffer();
        // The chunk's old contents were read by earlier frames' passes: their reads come first.
        VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
        barrier.srcAccessMask = VK_ACCESS_SHADER_READ_BIT;
        barrier.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        vkCmdPipelineBarrier(uploads,
                             VK_PIPELINE_STAGE_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                             VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &barrier, 0, nullptr, 0, nullptr);
    }
    const VkBufferCopy region{stagingUsed_[slot], chunk.first * kSplatBytes, bytes};
    vkCmdCopyBuffer(uploads, staging.buffer.get(), buffer_.buffer.get(), 1, &region);
    stagingUsed_[slot] += bytes;
}

} // namespace pnsplat::engine
