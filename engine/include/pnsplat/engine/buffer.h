// Buffers with their own memory (one allocation each: the engine holds a handful of large ones).
#pragma once

#include <cstddef>
#include <cstdint>

#include "pnsplat/engine/context.h"

namespace pnsplat::engine {

enum class MemoryUse {
    Device,   // device-local, filled by the GPU or through upload()
    Upload,   // host-visible and coherent, written by the CPU every frame (uniforms, node lists)
    Readback, // host-visible and coherent, preferably cached: results copied back for the CPU
};

struct Buffer {
    Unique<VkBuffer> buffer;
    Unique<VkDeviceMemory> memory;
    VkDeviceSize size = 0;
    void* mapped = nullptr; // set for Upload and Readback, and for Device memory that is host-visible
};

// Memory for `buffer` (or `image`), bound to it, of a type with all of `required`, preferring one
// with `preferred`; the type chosen goes to *type when given. Throws VulkanError on failure.
Unique<VkDeviceMemory> bindMemory(Context& context, VkBuffer buffer, VkMemoryPropertyFlags required,
                                  VkMemoryPropertyFlags preferred = 0, std::uint32_t* type = nullptr);
Unique<VkDeviceMemory> bindMemory(Context& context, VkImage image, VkMemoryPropertyFlags required,
                                  VkMemoryPropertyFlags preferred = 0, std::uint32_t* type = nullptr);

// Throws VulkanError on failure. size must be positive.
Buffer createBuffer(Context& context, VkDeviceSize size, VkBufferUsageFlags usage, MemoryUse use);

// The whole of `buffer` (created with UNIFORM_TEXEL_BUFFER usage, its size a multiple of the
// format's texel and within maxTexelBufferElements texels) as texels of `format`, for the shaders'
// texelFetch. Throws VulkanError on failure.
Unique<VkBufferView> createTexelView(Context& context, const Buffer& buffer, VkFormat format);

// A 2D image of one mip level and one layer, optimal tiling, UNDEFINED layout, with device-local memory
// of its own. Throws VulkanError on failure; the extent must not be empty.
struct DeviceImage {
    Unique<VkImage> image;
    Unique<VkDeviceMemory> memory;
};
DeviceImage createDeviceImage(Context& context, VkExtent2D extent, VkFormat format, VkImageUsageFlags usage);

// Copies `size` bytes into the start of a Device buffer (created with TRANSFER_DST usage): directly
// when its memory is host-visible (lavapipe, integrated GPUs), else through a staging buffer.
void upload(Context& context, const Buffer& destination, const void* data, std::size_t size);

} // namespace pnsplat::engine
