// The Vulkan instance, the chosen physical device, the logical device and its one queue.
//
// Device choice: a device whose name contains ContextOptions::deviceName (case-insensitive) when
// one is given, otherwise the first of discrete GPU, integrated GPU, virtual GPU, CPU (lavapipe);
// CPU devices are never skipped. The device needs Vulkan 1.2 and a queue with graphics and
// compute. 64-bit integer atomics on storage buffers (shaderInt64, shaderBufferInt64Atomics),
// which the compute path needs, are enabled where present.
//
// Validation: with ContextOptions::validation the Khronos validation layer is loaded (an error when
// it is not installed) and every message it reports is counted, kept, and printed to stderr;
// tests assert that the count stays zero.
//
// Thread use: create and destroy on one thread; submitAndWait from one thread at a time.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "pnsplat/engine/vulkan.h"
#include "pnsplat/refine/result.h"

namespace pnsplat::engine {

struct ContextOptions {
    std::string deviceName; // empty: the default choice above
    bool validation = false;
    // With validation: the layer's synchronization validation too (hazards between commands).
    bool synchronizationValidation = false;
    // Extensions a caller needs besides the engine's (a window: VK_KHR_surface and its platform's
    // at instance level, VK_KHR_swapchain at device level); a device without the device ones is
    // not chosen.
    std::vector<std::string> instanceExtensions, deviceExtensions;
};

class Context {
  public:
    static Result<std::unique_ptr<Context>> create(const ContextOptions& options = {});
    ~Context();
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;

    VkInstance instance() const { return instance_; }
    VkPhysicalDevice physicalDevice() const { return physical_; }
    VkDevice device() const { return device_; }
    VkQueue queue() const { return queue_; }
    std::uint32_t queueFamily() const { return queueFamily_; }
    const VkPhysicalDeviceProperties& properties() const { return properties_; }
    const std::string& deviceName() const { return name_; }
    // The driver as "name version" (e.g. "llvmpipe Mesa 22.3.6").
    const std::string& driverName() const { return driver_; }
    bool hasInt64Atomics() const { return int64Atomics_; }

    // A memory type among typeBits with all of `required`, preferring one that also has
    // `preferred`; throws VulkanError when there is none.
    std::uint32_t memoryType(std::uint32_t typeBits, VkMemoryPropertyFlags required,
                             VkMemoryPropertyFlags preferred = 0) const;

    // Records a one-time command buffer with `record`, submits it and waits for it to finish.
    void submitAndWait(const std::function<void(VkCommandBuffer)>& record);

    // Validation messages seen so far (0 without validation), and the last one.
    std::uint32_t validationMessages() const { return messages_.load(); }
    std::string lastValidationMessage() const;

  private:
    Context() = default;
    void initialise(const ContextOptions& options);
    static VKAPI_ATTR VkBool32 VKAPI_CALL onMessage(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                    VkDebugUtilsMessageTypeFlagsEXT types,
                                                    const VkDebugUtilsMessengerCallbackDataEXT* data,
                                                    void* self);

    VkInstance instance_ = VK_NULL_HANDLE;
    VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
    VkPhysicalDevice physical_ = VK_NULL_HANDLE;
    VkDevice device_ = VK_NULL_HANDLE;
    VkQueue queue_ = VK_NULL_HANDLE;
    std::uint32_t queueFamily_ = 0;
    VkCommandPool commandPool_ = VK_NULL_HANDLE;
    VkPhysicalDeviceProperties properties_{};
    VkPhysicalDeviceMemoryProperties memory_{};
    std::string name_, driver_;
    bool int64Atomics_ = false;
    std::atomic<std::uint32_t> messages_{0};
    mutable std::mutex messageMutex_;
    std::string lastMessage_;
};

} // namespace pnsplat::engine
