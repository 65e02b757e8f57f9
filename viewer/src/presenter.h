// The window's swapchain and how a frame of the engine reaches it (docs/VIEWER.md, "Presenting"):
// in the frame's last command buffer (engine FrameOutput), the engine's RGBA8 picture is copied
// into a canvas image, the overlay panels over it, and the canvas blitted into the acquired
// swapchain image (which converts RGBA to the swapchain's BGRA or RGBA and scales while a resize is
// under way), then presented. Acquire semaphores come from a pool, each back once the frame that
// waited on it has finished; each swapchain image has its own render-finished semaphore.
//
// Thread use: the render thread; the queue is the engine's (Context::queue).
#pragma once

#include <cstdint>
#include <deque>
#include <span>
#include <vector>

#include "pnsplat/engine/buffer.h"
#include "pnsplat/engine/context.h"
#include "pnsplat/engine/frames.h"
#include "pnsplat/engine/splat_renderer.h"
#include "pnsplat/viewer/overlay.h"

struct GLFWwindow;

namespace pnsplat::viewer {

class Presenter {
  public:
    // The window's surface; throws VulkanError, or std::runtime_error when the device cannot
    // present to it or blit into its images.
    Presenter(engine::Context& context, GLFWwindow* window, bool vsync);
    ~Presenter(); // waits for the queue
    Presenter(const Presenter&) = delete;
    Presenter& operator=(const Presenter&) = delete;

    // Makes the swapchain (anew) for the window's current size, after waiting for the queue; false
    // (no swapchain) while the window has no area.
    bool rebuild();
    bool ready() const { return swapchain_.get() != VK_NULL_HANDLE; }
    VkExtent2D extent() const { return extent_; }
    const char* presentModeName() const;

    // The canvas for pictures of `extent` (the engine's size): made anew, after waiting for the
    // queue, when the size changes.
    void setCanvas(VkExtent2D extent);

    // Acquires the next swapchain image; false when the swapchain is out of date (rebuild). On
    // success, wait() and signal() are the semaphores of the frame that draws into it.
    bool acquire();
    VkSemaphore wait() const { return acquired_; }
    VkSemaphore signal() const { return renderFinished_[image_].get(); }
    // Records the copies of a frame into `cmd` (the engine's FrameOutput::record): the engine's
    // picture `source`, then `panels` over it (staged in the buffer of the source's frame slot), into
    // the acquired image.
    void record(VkCommandBuffer cmd, const engine::FrameOutput::Source& source,
                std::span<const PlacedPanel> panels);
    // The engine's frame that waits on the semaphore of the last acquire (its semaphore comes back
    // once finished() passes it).
    void submitted(std::uint64_t frame);
    // Every frame up to `frame` has finished; with no argument, every frame (a new engine).
    void finished(std::uint64_t frame);
    void finished();
    // Presents the acquired image; false when the swapchain must be rebuilt.
    bool present();

  private:
    engine::Context& context_;
    VkDevice device_;
    VkSurfaceKHR surface_ = VK_NULL_HANDLE;
    GLFWwindow* window_;
    bool vsync_;
    VkSurfaceFormatKHR format_{};
    VkPresentModeKHR presentMode_ = VK_PRESENT_MODE_FIFO_KHR;
    engine::Unique<VkSwapchainKHR> swapchain_;
    VkExtent2D extent_{0, 0};
    std::vector<VkImage> images_;
    std::vector<engine::Unique<VkSemaphore>> renderFinished_; // per image
    std::uint32_t image_ = 0;                                 // acquired
    VkSemaphore acquired_ = VK_NULL_HANDLE;
    std::vector<engine::Unique<VkSemaphore>> freeSemaphores_;
    std::deque<std::pair<std::uint64_t, engine::Unique<VkSemaphore>>> busySemaphores_; // by frame
    engine::Unique<VkSemaphore> pending_; // acquired, not yet submitted
    engine::DeviceImage canvas_;
    VkExtent2D canvasExtent_{0, 0};
    VkFormat canvasFormat_ = VK_FORMAT_R8G8B8A8_UNORM;
    std::array<engine::Buffer, engine::kFramesInFlight> panelBuffers_;
};

} // namespace pnsplat::viewer
