#include "pnsplat/engine/vulkan.h"

#include <string>

namespace pnsplat::engine {

const char* resultName(VkResult result) {
    switch (result) {
#define PNSPLAT_RESULT_CASE(name)                                                                            \
    case name:                                                                                               \
        return #name;
        PNSPLAT_RESULT_CASE(VK_SUCCESS)
        PNSPLAT_RESULT_CASE(VK_NOT_READY)
        PNSPLAT_RESULT_CASE(VK_TIMEOUT)
        PNSPLAT_RESULT_CASE(VK_INCOMPLETE)
        PNSPLAT_RESULT_CASE(VK_ERROR_OUT_OF_HOST_MEMORY)
        PNSPLAT_RESULT_CASE(VK_ERROR_OUT_OF_DEVICE_MEMORY)
        PNSPLAT_RESULT_CASE(VK_ERROR_INITIALIZATION_FAILED)
        PNSPLAT_RESULT_CASE(VK_ERROR_DEVICE_LOST)
        PNSPLAT_RESULT_CASE(VK_ERROR_MEMORY_MAP_FAILED)
        PNSPLAT_RESULT_CASE(VK_ERROR_LAYER_NOT_PRESENT)
        PNSPLAT_RESULT_CASE(VK_ERROR_EXTENSION_NOT_PRESENT)
        PNSPLAT_RESULT_CASE(VK_ERROR_FEATURE_NOT_PRESENT)
        PNSPLAT_RESULT_CASE(VK_ERROR_INCOMPATIBLE_DRIVER)
        PNSPLAT_RESULT_CASE(VK_ERROR_TOO_MANY_OBJECTS)
        PNSPLAT_RESULT_CASE(VK_ERROR_FORMAT_NOT_SUPPORTED)
        PNSPLAT_RESULT_CASE(VK_ERROR_FRAGMENTED_POOL)
        PNSPLAT_RESULT_CASE(VK_ERROR_OUT_OF_POOL_MEMORY)
        PNSPLAT_RESULT_CASE(VK_ERROR_SURFACE_LOST_KHR)
        PNSPLAT_RESULT_CASE(VK_ERROR_OUT_OF_DATE_KHR)
        PNSPLAT_RESULT_CASE(VK_SUBOPTIMAL_KHR)
#undef PNSPLAT_RESULT_CASE
    default:
        return "VK_ERROR_UNKNOWN";
    }
}

void check(VkResult result, const char* call, const char* file, int line) {
    if (result == VK_SUCCESS) return;
    // Only the file name: the message is for a person, and paths of the build machine do not help.
    std::string where = file;
    if (const auto slash = where.find_last_of('/'); slash != std::string::npos) where.erase(0, slash + 1);
    throw VulkanError(where + ":" + std::to_string(line) + ": " + call + " -> " + resultName(result) + " (" +
                      std::to_string(static_cast<int>(result)) + ")");
}

} // namespace pnsplat::engine
