#include "pnsplat/engine/context.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdio>
#include <cstring>

namespace pnsplat::engine {

namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

bool hasLayer(const char* name) {
    std::uint32_t count = 0;
    vkEnumerateInstanceLayerProperties(&count, nullptr);
    std::vector<VkLayerProperties> layers(count);
    vkEnumerateInstanceLayerProperties(&count, layers.data());
    return std::any_of(layers.begin(), layers.end(),
                       [&](const VkLayerProperties& l) { return std::strcmp(l.layerName, name) == 0; });
}

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return s;
}

int typeRank(VkPhysicalDeviceType type) {
    switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
        return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
        return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
        return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
        return 3;
    default:
        return 4;
    }
}

// A queue family with graphics and compute, or -1.
int queueFamilyOf(VkPhysicalDevice device) {
    std::uint32_t count = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(device, &count, nullptr);
    std::vector<VkQueueFamilyProperties> families(count);
    vkGetPhysicalDeviceQueueFamilyProperties(device, &count, families.data());
    for (std::uint32_t i = 0; i < count; ++i)
        if ((families[i].queueFlags & VK_QUEUE_GRAPHICS_BIT) &&
            (families[i].queueFlags & VK_QUEUE_COMPUTE_BIT))
            return static_cast<int>(i);
    return -1;
}

VkInstance createInstance(const ContextOptions& options) {
    const bool validation = options.validation;
    VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
    app.pApplicationName = "pnsplat";
    app.pEngineName = "pnsplat";
    app.apiVersion = VK_API_VERSION_1_2;
    std::vector<const char*> layers, extensions;
    if (validation) {
        layers.push_back(kValidationLayer);
        extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    }
    for (const std::string& e : options.instanceExtensions) extensions.push_back(e.c_str());
    VkInstanceCreateInfo info{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
    const VkValidationFeatureEnableEXT synchronization =
        VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT;
    VkValidationFeaturesEXT features{VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT};
    features.enabledValidationFeatureCount = 1;
    features.pEnabledValidationFeatures = &synchronization;
    if (validation && options.synchronizationValidation) info.pNext = &features;
    info.pApplicationInfo = &app;
    info.enabledLayerCount = static_cast<std::uint32_t>(layers.size());
    info.ppEnabledLayerNames = layers.data();
    info.enabledExtensionCount = static_cast<std::uint32_t>(extensions.size());
    info.ppEnabledExtensionNames = extensions.data();
    VkInstance instance = VK_NULL_HANDLE;
    PNSPLAT_VK_CHECK(vkCreateInstance(&info, nullptr, &instance));
    return instance;
}

bool hasDeviceExtensions(VkPhysicalDevice device, const std::vector<std::string>& wanted) {
    std::uint32_t count = 0;
    vkEnumerateDeviceExtensionProperties(device, nullptr, &count, nullptr);
    std::vector<VkExtensionProperties> available(count);
    vkEnumerateDeviceExtensionProperties(device, nullptr, &count, available.data());
    return std::all_of(wanted.begin(), wanted.end(), [&](const std::string& name) {
        return std::any_of(available.begin(), available.end(),
                           [&](const VkExtensionProperties& e) { return name == e.extensionName; });
    });
}

std::vector<VkPhysicalDevice> physicalDevices(VkInstance instance) {
    std::uint32_t count = 0;
    PNSPLAT_VK_CHECK(vkEnumeratePhysicalDevices(instance, &count, nullptr));
    std::vector<VkPhysicalDevice> devices(count);
    PNSPLAT_VK_CHECK(vkEnumeratePhysicalDevices(instance, &count, devices.data()));
    return devices;
}

} // namespace

Result<std::unique_ptr<Context>> Context::create(const ContextOptions& options) {
    std::unique_ptr<Context> context(new Context());
    try {
        context->initialise(options);
    } catch (const VulkanError& e) {
        return Error{std::string("Vulkan: ") + e.what()};
    } catch (const std::runtime_error& e) {
        return Error{e.what()};
    }
    return context;
}

void Context::initialise(const ContextOptions& options) {
    if (options.validation && !hasLayer(kValidationLayer))
        throw std::runtime_error("validation requested but VK_LAYER_KHRONOS_validation is not installed "
                                 "(Debian package vulkan-validationlayers)");
    instance_ = createInstance(options);
    if (options.validation) {
        VkDebugUtilsMessengerCreateInfoEXT info{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
        info.messageSeverity =
            VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
        info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                           VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                           VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
        info.pfnUserCallback = &Context::onMessage;
        info.pUserData = this;
        auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(instance_, "vkCreateDebugUtilsMessengerEXT"));
        if (create == nullptr)
            throw std::runtime_error("validation: vkCreateDebugUtilsMessengerEXT is missing");
        PNSPLAT_VK_CHECK(create(instance_, &info, nullptr, &messenger_));
    }

    // Choose the device.
    std::vector<std::string> names;
    int bestRank = 100;
    for (VkPhysicalDevice candidate : physicalDevices(instance_)) {
        VkPhysicalDeviceProperties props;
        vkGetPhysicalDeviceProperties(candidate, &props);
        names.emplace_back(props.deviceName);
        if (props.apiVersion < VK_API_VERSION_1_2 || queueFamilyOf(candidate) < 0 ||
            !hasDeviceExtensions(candidate, options.deviceExtensions))
            continue;
        if (!options.deviceName.empty()) {
            if (lower(props.deviceName).find(lower(options.deviceName)) == std::string::npos) continue;
            if (physical_ == VK_NULL_HANDLE) physical_ = candidate;
        } else if (typeRank(props.deviceType) < bestRank) {
            bestRank = typeRank(props.deviceType);
            physical_ = candidate;
        }
    }
    if (physical_ == VK_NULL_HANDLE) {
        std::string list;
        for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
        if (names.empty())
            throw std::runtime_error("no Vulkan device found (install mesa-vulkan-drivers for lavapipe)");
        throw std::runtime_error(options.deviceName.empty()
                                     ? "no Vulkan 1.2 device with a graphics and compute queue among: " + list
                                     : "no Vulkan 1.2 device named like '" + options.deviceName +
                                           "' among: " + list);
    }
    vkGetPhysicalDeviceProperties(physical_, &properties_);
    vkGetPhysicalDeviceMemoryProperties(physical_, &memory_);
    name_ = properties_.deviceName;
    queueFamily_ = static_cast<std::uint32_t>(queueFamilyOf(physical_));

    VkPhysicalDeviceDriverProperties driverProps{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
    VkPhysicalDeviceProperties2 props2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    props2.pNext = &driverProps;
    vkGetPhysicalDeviceProperties2(physical_, &props2);
    driver_ = std::string(driverProps.driverName) + " " + driverProps.driverInfo;

    // Features: 64-bit integer atomics on storage buffers (the compute path) where present.
    VkPhysicalDeviceVulkan12Features features12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
    VkPhysicalDeviceFeatures2 features{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
    features.pNext = &features12;
    vkGetPhysicalDeviceFeatures2(physical_, &features);
    int64Atomics_ = features.features.shaderInt64 && features12.shaderBufferInt64Atomics;

    VkPhysicalDeviceVulkan12Features enabled12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
    enabled12.shaderBufferInt64Atomics = int64Atomics_;
    VkPhysicalDeviceFeatures2 enabled{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
    enabled.pNext = &enabled12;
    enabled.features.shaderInt64 = int64Atomics_;
    std::vector<const char*> extensions;
    for (const std::string& e : options.deviceExtensions) extensions.push_back(e.c_str());

    const float priority = 1.0f;
    VkDeviceQueueCreateInfo queueInfo{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
    queueInfo.queueFamilyIndex = queueFamily_;
    queueInfo.queueCount = 1;
    queueInfo.pQueuePriorities = &priority;
    VkDeviceCreateInfo info{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
    info.pNext = &enabled;
    info.queueCreateInfoCount = 1;
    info.pQueueCreateInfos = &queueInfo;
    info.enabledExtensionCount = static_cast<std::uint32_t>(extensions.size());
    info.ppEnabledExtensionNames = extensions.data();
    PNSPLAT_VK_CHECK(vkCreateDevice(physical_, &info, nullptr, &device_));
    vkGetDeviceQueue(device_, queueFamily_, 0, &queue_);

    VkCommandPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    poolInfo.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
    poolInfo.queueFamilyIndex = queueFamily_;
    PNSPLAT_VK_CHECK(vkCreateCommandPool(device_, &poolInfo, nullptr, &commandPool_));
}

Context::~Context() {
    if (device_ != VK_NULL_HANDLE) {
        vkDeviceWaitIdle(device_);
        if (commandPool_ != VK_NULL_HANDLE) vkDestroyCommandPool(device_, commandPool_, nullptr);
        vkDestroyDevice(device_, nullptr);
    }
    if (messenger_ != VK_NULL_HANDLE) {
        auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
        if (destroy != nullptr) destroy(instance_, messenger_, nullptr);
    }
    if (instance_ != VK_NULL_HANDLE) vkDestroyInstance(instance_, nullptr);
}

std::uint32_t Context::memoryType(std::uint32_t typeBits, VkMemoryPropertyFlags required,
                                  VkMemoryPropertyFlags preferred) const {
    int fallback = -1;
    for (std::uint32_t i = 0; i < memory_.memoryTypeCount; ++i) {
        if (!(typeBits & (1u << i))) continue;
        const VkMemoryPropertyFlags flags = memory_.memoryTypes[i].propertyFlags;
        if ((flags & required) != required) continue;
        if ((flags & preferred) == preferred) return i;
        if (fallback < 0) fallback = static_cast<int>(i);
    }
    if (fallback < 0) throw VulkanError("no memory type with the required properties");
    return static_cast<std::uint32_t>(fallback);
}

void Context::submitAndWait(const std::function<void(VkCommandBuffer)>& record) {
    VkCommandBufferAllocateInfo alloc{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    alloc.commandPool = commandPool_;
    alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    alloc.commandBufferCount = 1;
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    PNSPLAT_VK_CHECK(vkAllocateCommandBuffers(device_, &alloc, &cmd));
    struct Free {
        VkDevice device;
        VkCommandPool pool;
        VkCommandBuffer cmd;
        ~Free() { vkFreeCommandBuffers(device, pool, 1, &cmd); }
    } freeLater{device_, commandPool_, cmd};

    VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    PNSPLAT_VK_CHECK(vkBeginCommandBuffer(cmd, &begin));
    record(cmd);
    PNSPLAT_VK_CHECK(vkEndCommandBuffer(cmd));

    VkFenceCreateInfo fenceInfo{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    const Unique<VkFence> fence = PNSPLAT_VK_CREATE(Fence, device_, fenceInfo);
    const VkFence fenceHandle = fence.get();
    VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cmd;
    PNSPLAT_VK_CHECK(vkQueueSubmit(queue_, 1, &submit, fenceHandle));
    PNSPLAT_VK_CHECK(vkWaitForFences(device_, 1, &fenceHandle, VK_TRUE, UINT64_MAX));
}

std::string Context::lastValidationMessage() const {
    std::lock_guard lock(messageMutex_);
    return lastMessage_;
}

VKAPI_ATTR VkBool32 VKAPI_CALL Context::onMessage(VkDebugUtilsMessageSeverityFlagBitsEXT,
                                                  VkDebugUtilsMessageTypeFlagsEXT,
                                                  const VkDebugUtilsMessengerCallbackDataEXT* data,
                                                  void* self) {
    auto* context = static_cast<Context*>(self);
    context->messages_.fetch_add(1);
    {
        std::lock_guard lock(context->messageMutex_);
        context->lastMessage_ = data->pMessage != nullptr ? data->pMessage : "";
    }
    std::fprintf(stderr, "validation: %s\n", data->pMessage != nullptr ? data->pMessage : "");
    return VK_FALSE;
}

} // namespace pnsplat::engine
