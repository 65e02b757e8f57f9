#include "pnsplat/engine/buffer.h"

#include <cstring>

namespace pnsplat::engine {

namespace {

// bindMemory for a buffer or an image: `requirementsOf` and `bind` are its vkGet*MemoryRequirements and
// vkBind*Memory, `call` the latter's name.
template <typename T>
Unique<VkDeviceMemory>
bindMemoryTo(Context& context, T object, void (*requirementsOf)(VkDevice, T, VkMemoryRequirements*),
             VkResult (*bind)(VkDevice, T, VkDeviceMemory, VkDeviceSize), const char* call,
             VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred, std::uint32_t* type) {
    const VkDevice device = context.device();
    VkMemoryRequirements requirements;
    requirementsOf(device, object, &requirements);
    VkMemoryAllocateInfo alloc{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    alloc.allocationSize = requirements.size;
    alloc.memoryTypeIndex = context.memoryType(requirements.memoryTypeBits, required, preferred);
    VkDeviceMemory memoryHandle = VK_NULL_HANDLE;
    PNSPLAT_VK_CHECK(vkAllocateMemory(device, &alloc, nullptr, &memoryHandle));
    Unique<VkDeviceMemory> memory(device, memoryHandle, vkFreeMemory);
    check(bind(device, object, memoryHandle, 0), call, __FILE__, __LINE__);
    if (type != nullptr) *type = alloc.memoryTypeIndex;
    return memory;
}

} // namespace

Unique<VkDeviceMemory> bindMemory(Context& context, VkBuffer buffer, VkMemoryPropertyFlags required,
                                  VkMemoryPropertyFlags preferred, std::uint32_t* type) {
    return bindMemoryTo(context, buffer, vkGetBufferMemoryRequirements, vkBindBufferMemory,
                        "vkBindBufferMemory", required, preferred, type);
}

Unique<VkDeviceMemory> bindMemory(Context& context, VkImage image, VkMemoryPropertyFlags required,
                                  VkMemoryPropertyFlags preferred, std::uint32_t* type) {
    return bindMemoryTo(context, image, vkGetImageMemoryRequirements, vkBindImageMemory, "vkBindImageMemory",
                        required, preferred, type);
}

DeviceImage createDeviceImage(Context& context, VkExtent2D extent, VkFormat format, VkImageUsageFlags usage) {
    VkImageCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = format;
    info.extent = {extent.width, extent.height, 1};
    info.mipLevels = 1;
    info.arrayLayers = 1;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = usage;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    DeviceImage result;
    result.image = PNSPLAT_VK_CREATE(Image, context.device(), info);
    result.memory = bindMemory(context, result.image.get(), VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    return result;
}

Buffer createBuffer(Context& context, VkDeviceSize size, VkBufferUsageFlags usage, MemoryUse use) {
    const VkDevice device = context.device();
    Buffer result;
    result.size = size;
    VkBufferCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    info.size = size;
    info.usage = usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    result.buffer = PNSPLAT_VK_CREATE(Buffer, device, info);

    constexpr VkMemoryPropertyFlags kHost =
        VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    VkMemoryPropertyFlags required = 0, preferred = 0;
    switch (use) {
    case MemoryUse::Device:
        required = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
        break;
    case MemoryUse::Upload:
        required = kHost;
        preferred = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
        break;
    case MemoryUse::Readback:
        required = kHost;
        preferred = VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
        break;
    }
    std::uint32_t type = 0;
    result.memory = bindMemory(context, result.buffer.get(), required, preferred, &type);

    VkPhysicalDeviceMemoryProperties properties;
    vkGetPhysicalDeviceMemoryProperties(context.physicalDevice(), &properties);
    if ((properties.memoryTypes[type].propertyFlags & kHost) == kHost)
        PNSPLAT_VK_CHECK(vkMapMemory(device, result.memory.get(), 0, VK_WHOLE_SIZE, 0, &result.mapped));
    return result;
}

Unique<VkBufferView> createTexelView(Context& context, const Buffer& buffer, VkFormat format) {
    VkBufferViewCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO};
    info.buffer = buffer.buffer.get();
    info.format = format;
    info.range = VK_WHOLE_SIZE;
    return PNSPLAT_VK_CREATE(BufferView, context.device(), info);
}

void upload(Context& context, const Buffer& destination, const void* data, std::size_t size) {
    if (size == 0) return;
    if (destination.mapped != nullptr) {
        std::memcpy(destination.mapped, data, size);
        return;
    }
    const Buffer staging = createBuffer(context, size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUse::Upload);
    std::memcpy(staging.mapped, data, size);
    context.submitAndWait([&](VkCommandBuffer cmd) {
        const VkBufferCopy region{0, 0, size};
        vkCmdCopyBuffer(cmd, staging.buffer.get(), destination.buffer.get(), 1, &region);
    });
}

} // namespace pnsplat::engine
