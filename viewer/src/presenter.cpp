#include "presenter.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

namespace pnsplat::viewer {

namespace {

using engine::Unique;

bool isSrgb(VkFormat format) {
    return format == VK_FORMAT_B8G8R8A8_SRGB || format == VK_FORMAT_R8G8B8A8_SRGB ||
           format == VK_FORMAT_A8B8G8R8_SRGB_PACK32;
}

void imageBarrier(VkCommandBuffer cmd, VkImage image, VkImageLayout from, VkImageLayout to,
                  VkPipelineStageFlags srcStage, VkAccessFlags srcAccess, VkPipelineStageFlags dstStage,
                  VkAccessFlags dstAccess) {
    VkImageMemoryBarrier barrier{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
    barrier.srcAccessMask = srcAccess;
    barrier.dstAccessMask = dstAccess;
    barrier.oldLayout = from;
    barrier.newLayout = to;
    barrier.srcQueueFamilyIndex = barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.image = image;
    barrier.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdPipelineBarrier(cmd, srcStage, dstStage, 0, 0, nullptr, 0, nullptr, 1, &barrier);
}

} // namespace

Presenter::Presenter(engine::Context& context, GLFWwindow* window, bool vsync)
    : context_(context), device_(context.device()), window_(window), vsync_(vsync) {
    PNSPLAT_VK_CHECK(glfwCreateWindowSurface(context.instance(), window, nullptr, &surface_));
    try {
        const VkPhysicalDevice physical = context.physicalDevice();
        VkBool32 supported = VK_FALSE;
        PNSPLAT_VK_CHECK(
            vkGetPhysicalDeviceSurfaceSupportKHR(physical, context.queueFamily(), surface_, &supported));
        if (!supported)
            throw std::runtime_error(context.deviceName() +
                                     " cannot present to this window; choose another device with --device");
        std::uint32_t count = 0;
        PNSPLAT_VK_CHECK(vkGetPhysicalDeviceSurfaceFormatsKHR(physical, surface_, &count, nullptr));
        std::vector<VkSurfaceFormatKHR> formats(count);
        PNSPLAT_VK_CHECK(vkGetPhysicalDeviceSurfaceFormatsKHR(physical, surface_, &count, formats.data()));
        if (formats.empty()) throw std::runtime_error("the window's surface offers no image format");
        // The engine's picture holds sRGB-encoded bytes: a UNORM swapchain takes them as they are; an
        // sRGB one is blitted from a canvas of sRGB format (decoded and encoded again: the same bytes).
        const auto blitTarget = [&](VkFormat format) {
            VkFormatProperties properties;
            vkGetPhysicalDeviceFormatProperties(physical, format, &properties);
            return (properties.optimalTilingFeatures & VK_FORMAT_FEATURE_BLIT_DST_BIT) != 0;
        };
        const auto find = [&](std::initializer_list<VkFormat> wanted) -> const VkSurfaceFormatKHR* {
            for (const VkFormat w : wanted)
                for (const VkSurfaceFormatKHR& f : formats)
                    if (f.format == w && f.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR && blitTarget(w))
                        return &f;
            return nullptr;
        };
        const VkSurfaceFormatKHR* chosen = find({VK_FORMAT_B8G8R8A8_UNORM, VK_FORMAT_R8G8B8A8_UNORM});
        if (!chosen) chosen = find({VK_FORMAT_B8G8R8A8_SRGB, VK_FORMAT_R8G8B8A8_SRGB});
        if (!chosen)
            throw std::runtime_error(context.deviceName() +
                                     " offers no 8-bit RGBA or BGRA swapchain format it can blit into");
        format_ = *chosen;
        canvasFormat_ = isSrgb(format_.format) ? VK_FORMAT_R8G8B8A8_SRGB : VK_FORMAT_R8G8B8A8_UNORM;

        PNSPLAT_VK_CHECK(vkGetPhysicalDeviceSurfacePresentModesKHR(physical, surface_, &count, nullptr));
        std::vector<VkPresentModeKHR> modes(count);
        PNSPLAT_VK_CHECK(vkGetPhysicalDeviceSurfacePresentModesKHR(physical, surface_, &count, modes.data()));
        const auto has = [&](VkPresentModeKHR mode) {
            return std::find(modes.begin(), modes.end(), mode) != modes.end();
        };
        // FIFO is always there (vsync); without vsync, the first that does not wait for the display.
        presentMode_ = VK_PRESENT_MODE_FIFO_KHR;
        if (!vsync_) {
            if (has(VK_PRESENT_MODE_IMMEDIATE_KHR))
                presentMode_ = VK_PRESENT_MODE_IMMEDIATE_KHR;
            else if (has(VK_PRESENT_MODE_MAILBOX_KHR))
                presentMode_ = VK_PRESENT_MODE_MAILBOX_KHR;
        }
    } catch (...) {
        vkDestroySurfaceKHR(context_.instance(), surface_, nullptr);
        throw;
    }
}

Presenter::~Presenter() {
    vkQueueWaitIdle(context_.queue());
    swapchain_.reset();
    vkDestroySurfaceKHR(context_.instance(), surface_, nullptr);
}

const char* Presenter::presentModeName() const {
    switch (presentMode_) {
    case VK_PRESENT_MODE_IMMEDIATE_KHR:
        return "immediate";
    case VK_PRESENT_MODE_MAILBOX_KHR:
        return "mailbox";
    default:
        return "fifo";
    }
}

bool Presenter::rebuild() {
    PNSPLAT_VK_CHECK(vkQueueWaitIdle(context_.queue()));
    VkSurfaceCapabilitiesKHR caps;
    PNSPLAT_VK_CHECK(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(context_.physicalDevice(), surface_, &caps));
    VkExtent2D extent = caps.currentExtent;
    if (extent.width == 0xFFFFFFFFu) {
        int width = 0, height = 0;
        glfwGetFramebufferSize(window_, &width, &height);
        extent.width = std::clamp(std::uint32_t(std::max(width, 0)), caps.minImageExtent.width,
                                  caps.maxImageExtent.width);
        extent.height = std::clamp(std::uint32_t(std::max(height, 0)), caps.minImageExtent.height,
                                   caps.maxImageExtent.height);
    }
    if (extent.width == 0 || extent.height == 0) {
        swapchain_.reset();
        extent_ = {0, 0};
        return false;
    }
    if ((caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT) == 0)
        throw std::runtime_error("the window's swapchain images cannot be written by transfers");
    VkSwapchainCreateInfoKHR info{VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR};
    info.surface = surface_;
    info.minImageCount = caps.minImageCount + 1;
    if (caps.maxImageCount > 0) info.minImageCount = std::min(info.minImageCount, caps.maxImageCount);
    info.imageFormat = format_.format;
    info.imageColorSpace = format_.colorSpace;
    info.imageExtent = extent;
    info.imageArrayLayers = 1;
    info.imageUsage = VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    info.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.preTransform = caps.currentTransform;
    info.compositeAlpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
    if ((caps.supportedCompositeAlpha & info.compositeAlpha) == 0)
        for (VkCompositeAlphaFlagBitsKHR bit :
             {VK_COMPOSITE_ALPHA_INHERIT_BIT_KHR, VK_COMPOSITE_ALPHA_PRE_MULTIPLIED_BIT_KHR,
              VK_COMPOSITE_ALPHA_POST_MULTIPLIED_BIT_KHR})
            if (caps.supportedCompositeAlpha & bit) {
                info.compositeAlpha = bit;
                break;
            }
    info.presentMode = presentMode_;
    info.clipped = VK_TRUE;
    info.oldSwapchain = swapchain_.get();
    Unique<VkSwapchainKHR> swapchain = PNSPLAT_VK_CREATE(SwapchainKHR, device_, info);
    swapchain_ = std::move(swapchain); // the old one, retired by the new one, is destroyed here
    extent_ = extent;
    std::uint32_t count = 0;
    PNSPLAT_VK_CHECK(vkGetSwapchainImagesKHR(device_, swapchain_.get(), &count, nullptr));
    images_.resize(count);
    PNSPLAT_VK_CHECK(vkGetSwapchainImagesKHR(device_, swapchain_.get(), &count, images_.data()));
    renderFinished_.clear();
    const VkSemaphoreCreateInfo semaphore{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
    for (std::uint32_t i = 0; i < count; ++i)
        renderFinished_.push_back(PNSPLAT_VK_CREATE(Semaphore, device_, semaphore));
    return true;
}

void Presenter::setCanvas(VkExtent2D extent) {
    if (canvasExtent_.width == extent.width && canvasExtent_.height == extent.height) return;
    PNSPLAT_VK_CHECK(vkQueueWaitIdle(context_.queue()));
    canvas_ = engine::createDeviceImage(context_, extent, canvasFormat_,
                                        VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT);
    canvasExtent_ = extent;
}

bool Presenter::acquire() {
    if (freeSemaphores_.empty()) {
        const VkSemaphoreCreateInfo info{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
        freeSemaphores_.push_back(PNSPLAT_VK_CREATE(Semaphore, device_, info));
    }
    Unique<VkSemaphore> semaphore = std::move(freeSemaphores_.back());
    freeSemaphores_.pop_back();
    const VkResult result = vkAcquireNextImageKHR(device_, swapchain_.get(), UINT64_MAX, semaphore.get(),
                                                  VK_NULL_HANDLE, &image_);
    if (result == VK_ERROR_OUT_OF_DATE_KHR) {
        freeSemaphores_.push_back(std::move(semaphore)); // not signalled
        return false;
    }
    if (result != VK_SUBOPTIMAL_KHR) PNSPLAT_VK_CHECK(result);
    acquired_ = semaphore.get();
    pending_ = std::move(semaphore);
    return true;
}

void Presenter::submitted(std::uint64_t frame) {
    busySemaphores_.emplace_back(frame, std::move(pending_));
}

void Presenter::finished(std::uint64_t frame) {
    while (!busySemaphores_.empty() && busySemaphores_.front().first <= frame) {
        freeSemaphores_.push_back(std::move(busySemaphores_.front().second));
        busySemaphores_.pop_front();
    }
}

void Presenter::finished() {
    for (auto& busy : busySemaphores_) freeSemaphores_.push_back(std::move(busy.second));
    busySemaphores_.clear();
}

void Presenter::record(VkCommandBuffer cmd, const engine::FrameOutput::Source& source,
                       std::span<const PlacedPanel> panels) {
    constexpr VkPipelineStageFlags kTransfer = VK_PIPELINE_STAGE_TRANSFER_BIT;
    const VkImage canvas = canvas_.image.get();
    const VkExtent2D size = canvasExtent_;
    // The canvas was last read by the previous frame's blit (an execution dependency suffices).
    imageBarrier(cmd, canvas, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, kTransfer, 0,
                 kTransfer, VK_ACCESS_TRANSFER_WRITE_BIT);
    if (source.buffer != VK_NULL_HANDLE) {
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageExtent = {size.width, size.height, 1};
        vkCmdCopyBufferToImage(cmd, source.buffer, canvas, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    } else {
        VkImageCopy region{};
        region.srcSubresource = region.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.extent = {size.width, size.height, 1};
        vkCmdCopyImage(cmd, source.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, canvas,
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    }

    // The panels, from this slot's host-visible buffer (its last frame has finished), over the picture.
    std::size_t bytes = 0;
    for (const PlacedPanel& p : panels) bytes += p.pixels.pixels.size();
    std::vector<VkBufferImageCopy> regions;
    if (bytes > 0) {
        engine::Buffer& staging = panelBuffers_[source.slot];
        if (staging.size < bytes)
            staging = engine::createBuffer(context_, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                           engine::MemoryUse::Upload);
        std::size_t offset = 0;
        for (const PlacedPanel& p : panels) {
            std::memcpy(static_cast<std::uint8_t*>(staging.mapped) + offset, p.pixels.pixels.data(),
                        p.pixels.pixels.size());
            // Clipped to the canvas.
            const int x0 = std::max(0, p.x), y0 = std::max(0, p.y);
            const int x1 = std::min(int(size.width), p.x + int(p.pixels.width));
            const int y1 = std::min(int(size.height), p.y + int(p.pixels.height));
            if (x0 < x1 && y0 < y1) {
                VkBufferImageCopy region{};
                region.bufferOffset =
                    offset + (std::size_t(y0 - p.y) * p.pixels.width + std::size_t(x0 - p.x)) * 4;
                region.bufferRowLength = p.pixels.width;
                region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
                region.imageOffset = {x0, y0, 0};
                region.imageExtent = {std::uint32_t(x1 - x0), std::uint32_t(y1 - y0), 1};
                regions.push_back(region);
            }
            offset += p.pixels.pixels.size();
        }
    }
    if (!regions.empty()) {
        VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
        barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        barrier.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        vkCmdPipelineBarrier(cmd, kTransfer, kTransfer, 0, 1, &barrier, 0, nullptr, 0, nullptr);
        vkCmdCopyBufferToImage(cmd, panelBuffers_[source.slot].buffer.get(), canvas,
                               VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, std::uint32_t(regions.size()),
                               regions.data());
    }

    imageBarrier(cmd, canvas, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                 kTransfer, VK_ACCESS_TRANSFER_WRITE_BIT, kTransfer, VK_ACCESS_TRANSFER_READ_BIT);
    // The swapchain image after the acquire semaphore's wait (at the transfer stage).
    const VkImage target = images_[image_];
    imageBarrier(cmd, target, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, kTransfer, 0,
                 kTransfer, VK_ACCESS_TRANSFER_WRITE_BIT);
    VkImageBlit blit{};
    blit.srcSubresource = blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    blit.srcOffsets[1] = {int(size.width), int(size.height), 1};
    blit.dstOffsets[1] = {int(extent_.width), int(extent_.height), 1};
    const bool same = size.width == extent_.width && size.height == extent_.height;
    vkCmdBlitImage(cmd, canvas, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, target,
                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit,
                   same ? VK_FILTER_NEAREST : VK_FILTER_LINEAR);
    imageBarrier(cmd, target, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR,
                 kTransfer, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, 0);
}

bool Presenter::present() {
    const VkSemaphore wait = renderFinished_[image_].get();
    const VkSwapchainKHR swapchain = swapchain_.get();
    VkPresentInfoKHR info{VK_STRUCTURE_TYPE_PRESENT_INFO_KHR};
    info.waitSemaphoreCount = 1;
    info.pWaitSemaphores = &wait;
    info.swapchainCount = 1;
    info.pSwapchains = &swapchain;
    info.pImageIndices = &image_;
    const VkResult result = vkQueuePresentKHR(context_.queue(), &info);
    // Suboptimal still presents; a new size is seen by the viewer's resize check, so rebuilding here
    // would only make the swapchain anew every frame where a platform keeps saying so.
    if (result == VK_ERROR_OUT_OF_DATE_KHR) return false;
    if (result != VK_SUBOPTIMAL_KHR) PNSPLAT_VK_CHECK(result);
    return true;
}

} // namespace pnsplat::viewer
