// Vulkan basics shared by the engine: the one error path for VkResult and move-only ownership of
// handles (CONTRIBUTING.md, "Errors in the engine").
//
// Inside the engine a failed call throws VulkanError ("file:line: call -> VK_ERROR_NAME"); the
// engine's public entry points catch it and return it as a Result, so callers see values only.
#pragma once

#include <stdexcept>
#include <utility>

#include <vulkan/vulkan.h>

namespace pnsplat::engine {

struct VulkanError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// The name of a VkResult ("VK_ERROR_DEVICE_LOST"), or its number when unknown.
const char* resultName(VkResult result);

// Throws VulkanError naming the call and the place unless result is VK_SUCCESS.
void check(VkResult result, const char* call, const char* file, int line);

#define PNSPLAT_VK_CHECK(call) ::pnsplat::engine::check((call), #call, __FILE__, __LINE__)

// Owns one device-level handle and destroys it with the matching vkDestroy*/vkFree* function.
template <typename T>
class Unique {
  public:
    using Destroy = void (*)(VkDevice, T, const VkAllocationCallbacks*);

    Unique() = default;
    Unique(VkDevice device, T handle, Destroy destroy)
        : device_(device), handle_(handle), destroy_(destroy) {}
    Unique(Unique&& other) noexcept
        : device_(other.device_), handle_(std::exchange(other.handle_, VK_NULL_HANDLE)),
          destroy_(other.destroy_) {}
    Unique& operator=(Unique&& other) noexcept {
        if (this != &other) {
            reset();
            device_ = other.device_;
            handle_ = std::exchange(other.handle_, VK_NULL_HANDLE);
            destroy_ = other.destroy_;
        }
        return *this;
    }
    Unique(const Unique&) = delete;
    Unique& operator=(const Unique&) = delete;
    ~Unique() { reset(); }

    T get() const { return handle_; }
    explicit operator bool() const { return handle_ != VK_NULL_HANDLE; }
    void reset() {
        if (handle_ != VK_NULL_HANDLE) destroy_(device_, handle_, nullptr);
        handle_ = VK_NULL_HANDLE;
    }

  private:
    VkDevice device_ = VK_NULL_HANDLE;
    T handle_ = VK_NULL_HANDLE;
    Destroy destroy_ = nullptr;
};

// Creates a device-level object through its vkCreate* function, create(device, &info, nullptr,
// &handle), and owns it, to be destroyed by `destroy`, the matching vkDestroy* function. A failure
// throws VulkanError naming `call` at `file`:`line`, as PNSPLAT_VK_CHECK does. Use it through
// PNSPLAT_VK_CREATE.
template <typename T, typename Info>
Unique<T> createUnique(VkDevice device,
                       VkResult (*create)(VkDevice, const Info*, const VkAllocationCallbacks*, T*),
                       const Info& info, typename Unique<T>::Destroy destroy, const char* call,
                       const char* file, int line) {
    T handle = VK_NULL_HANDLE;
    check(create(device, &info, nullptr, &handle), call, file, line);
    return Unique<T>(device, handle, destroy);
}

// PNSPLAT_VK_CREATE(Buffer, device, info): the VkBuffer of vkCreateBuffer, owned, destroyed by
// vkDestroyBuffer; likewise for every Vk<Kind> made by vkCreate<Kind> from one create-info.
#define PNSPLAT_VK_CREATE(Kind, device, info)                                                                \
    ::pnsplat::engine::createUnique<Vk##Kind>((device), vkCreate##Kind, (info), vkDestroy##Kind,             \
                                              "vkCreate" #Kind, __FILE__, __LINE__)

} // namespace pnsplat::engine
