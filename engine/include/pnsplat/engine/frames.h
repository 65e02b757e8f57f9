// Frames in flight: the CPU records frame n+1 while the GPU still draws frame n. Each frame has a
// slot of its own (a fence, a command pool, a list of objects to destroy later); a slot is reused
// kFramesInFlight frames later, after its fence has signalled. Objects a frame may still read are
// handed to defer() and destroyed then, not at once (as Granite and niagara do).
//
// Thread use: one thread (the render thread) for everything.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "pnsplat/engine/context.h"

namespace pnsplat::engine {

inline constexpr std::uint32_t kFramesInFlight = 2;

class FrameRing {
  public:
    explicit FrameRing(Context& context); // throws VulkanError
    ~FrameRing();                         // waits for every frame
    FrameRing(const FrameRing&) = delete;
    FrameRing& operator=(const FrameRing&) = delete;

    // Starts the next frame: waits until the frame that last used its slot has finished on the GPU,
    // destroys what was deferred to it, and recycles its command buffers. Returns the frame's index
    // (0, 1, 2, ...).
    std::uint64_t begin();
    std::uint64_t index() const { return index_; } // of the current frame
    std::uint32_t slot() const { return static_cast<std::uint32_t>(index_ % kFramesInFlight); }

    // A new primary command buffer of the current frame, recording (one-time submit).
    VkCommandBuffer commandBuffer();
    // Ends and submits `cmd`. The frame's last submission passes last = true: it signals the frame's
    // fence, after which nothing may be submitted for this frame. Optional semaphores (a swapchain).
    void submit(VkCommandBuffer cmd, bool last, VkSemaphore wait = VK_NULL_HANDLE,
                VkPipelineStageFlags waitStage = 0, VkSemaphore signal = VK_NULL_HANDLE);

    // Every frame below this index has finished on the GPU (polls the fences, does not wait).
    std::uint64_t completed();
    // Waits until frame `index` (submitted already) has finished.
    void wait(std::uint64_t index);
    // Waits for every submitted frame.
    void waitAll();

    // Keeps `object` alive until the current frame has finished on the GPU.
    template <typename T>
    void defer(T&& object) {
        slots_[slot()].deferred.push_back(std::make_unique<Held<std::decay_t<T>>>(std::forward<T>(object)));
    }

  private:
    struct HeldBase {
        virtual ~HeldBase() = default;
    };
    template <typename T>
    struct Held : HeldBase {
        explicit Held(T&& v) : value(std::move(v)) {}
        T value;
    };
    struct Slot {
        Unique<VkFence> fence;
        Unique<VkCommandPool> pool;
        std::vector<VkCommandBuffer> buffers; // allocated from the pool, reused
        std::uint32_t used = 0;               // of buffers, this frame
        bool submitted = false;               // the fence will signal
        std::uint64_t frame = 0;              // the frame that used the slot last
        std::vector<std::unique_ptr<HeldBase>> deferred;
    };
    void retire(Slot& slot); // after its fence: destroy, recycle

    Context& context_;
    std::array<Slot, kFramesInFlight> slots_;
    std::uint64_t index_ = 0;
    bool begun_ = false;
};

} // namespace pnsplat::engine
