#include "pnsplat/engine/frames.h"

#include <limits>

namespace pnsplat::engine {

namespace {
constexpr std::uint64_t kForever = std::numeric_limits<std::uint64_t>::max();
} // namespace

FrameRing::FrameRing(Context& context) : context_(context) {
    const VkDevice device = context.device();
    for (Slot& slot : slots_) {
        VkFenceCreateInfo fenceInfo{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
        VkFence fence = VK_NULL_HANDLE;
        PNSPLAT_VK_CHECK(vkCreateFence(device, &fenceInfo, nullptr, &fence));
        slot.fence = Unique<VkFence>(device, fence, vkDestroyFence);
        VkCommandPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
        poolInfo.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
        poolInfo.queueFamilyIndex = context.queueFamily();
        VkCommandPool pool = VK_NULL_HANDLE;
        PNSPLAT_VK_CHECK(vkCreateCommandPool(device, &poolInfo, nullptr, &pool));
        slot.pool = Unique<VkCommandPool>(device, pool, vkDestroyCommandPool);
    }
}

FrameRing::~FrameRing() {
    waitAll();
}

void FrameRing::retire(Slot& slot) {
    if (slot.submitted) {
        const VkFence fence = slot.fence.get();
        PNSPLAT_VK_CHECK(vkWaitForFences(context_.device(), 1, &fence, VK_TRUE, kForever));
        PNSPLAT_VK_CHECK(vkResetFences(context_.device(), 1, &fence));
        slot.submitted = false;
    }
    slot.deferred.clear();
}

std::uint64_t FrameRing::begin() {
    if (begun_) ++index_;
    begun_ = true;
    Slot& current = slots_[slot()];
    retire(current);
    PNSPLAT_VK_CHECK(vkResetCommandPool(context_.device(), current.pool.get(), 0));
    current.used = 0;
    current.frame = index_;
    return index_;
}

VkCommandBuffer FrameRing::commandBuffer() {
    Slot& current = slots_[slot()];
    if (current.used == current.buffers.size()) {
        VkCommandBufferAllocateInfo alloc{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
        alloc.commandPool = current.pool.get();
        alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        alloc.commandBufferCount = 1;
        VkCommandBuffer cmd = VK_NULL_HANDLE;
        PNSPLAT_VK_CHECK(vkAllocateCommandBuffers(context_.device(), &alloc, &cmd));
        current.buffers.push_back(cmd);
    }
    VkCommandBuffer cmd = current.buffers[current.used++];
    VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    PNSPLAT_VK_CHECK(vkBeginCommandBuffer(cmd, &begin));
    return cmd;
}

void FrameRing::submit(VkCommandBuffer cmd, bool last, VkSemaphore wait, VkPipelineStageFlags waitStage,
                       VkSemaphore signal) {
    PNSPLAT_VK_CHECK(vkEndCommandBuffer(cmd));
    VkSubmitInfo info{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    info.commandBufferCount = 1;
    info.pCommandBuffers = &cmd;
    if (wait != VK_NULL_HANDLE) {
        info.waitSemaphoreCount = 1;
        info.pWaitSemaphores = &wait;
        info.pWaitDstStageMask = &waitStage;
    }
    if (signal != VK_NULL_HANDLE) {
        info.signalSemaphoreCount = 1;
        info.pSignalSemaphores = &signal;
    }
    Slot& current = slots_[slot()];
    PNSPLAT_VK_CHECK(vkQueueSubmit(context_.queue(), 1, &info, last ? current.fence.get() : VK_NULL_HANDLE));
    if (last) current.submitted = true;
}

std::uint64_t FrameRing::completed() {
    // The oldest frame whose fence has not signalled bounds what has finished.
    std::uint64_t oldestPending = begun_ ? index_ + 1 : 0;
    for (Slot& slot : slots_) {
        if (!slot.submitted) continue;
        const VkResult status = vkGetFenceStatus(context_.device(), slot.fence.get());
        if (status == VK_NOT_READY) {
            oldestPending = std::min(oldestPending, slot.frame);
        } else {
            PNSPLAT_VK_CHECK(status);
        }
    }
    // A begun frame that has not been submitted yet has not finished either.
    if (begun_ && !slots_[slot()].submitted) oldestPending = std::min(oldestPending, index_);
    return oldestPending;
}

void FrameRing::wait(std::uint64_t frame) {
    Slot& slot = slots_[frame % kFramesInFlight];
    if (slot.frame != frame || !slot.submitted) return; // finished and retired, or never submitted
    const VkFence fence = slot.fence.get();
    PNSPLAT_VK_CHECK(vkWaitForFences(context_.device(), 1, &fence, VK_TRUE, kForever));
}

void FrameRing::waitAll() {
    for (Slot& slot : slots_) {
        if (!slot.submitted) continue;
        const VkFence fence = slot.fence.get();
        vkWaitForFences(context_.device(), 1, &fence, VK_TRUE,
                        kForever); // also from the destructor: no throw
    }
}

} // namespace pnsplat::engine
