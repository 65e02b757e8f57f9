#include "pnsplat/engine/splat_renderer.h"

#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "gpu_types.h"
#include "pnsplat/engine/buffer.h"
#include "spirv/compute_accumulate_comp.h"
#include "spirv/compute_normalize_comp.h"
#include "spirv/compute_visibility_comp.h"
#include "spirv/fullscreen_vert.h"
#include "spirv/graphics_accumulate_frag.h"
#include "spirv/graphics_normalize_frag.h"
#include "spirv/graphics_visibility_frag.h"
#include "spirv/plain_point_frag.h"
#include "spirv/plain_point_vert.h"
#include "spirv/splat_vert.h"

namespace pnsplat::engine {

namespace {

constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
constexpr VkFormat kAccumFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr VkFormat kOutputFormat = VK_FORMAT_R8G8B8A8_UNORM;

template <std::size_t N>
Unique<VkShaderModule> shaderModule(VkDevice device, const std::uint32_t (&code)[N]) {
    VkShaderModuleCreateInfo info{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    info.codeSize = sizeof(code);
    info.pCode = code;
    return PNSPLAT_VK_CREATE(ShaderModule, device, info);
}

struct Image {
    Unique<VkImage> image;
    Unique<VkDeviceMemory> memory;
    Unique<VkImageView> view;
};

Image createImage(Context& context, VkExtent2D extent, VkFormat format, VkImageUsageFlags usage,
                  VkImageAspectFlags aspect) {
    DeviceImage made = createDeviceImage(context, extent, format, usage);
    Image result{std::move(made.image), std::move(made.memory), {}};
    VkImageViewCreateInfo viewInfo{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    viewInfo.image = result.image.get();
    viewInfo.viewType = VK_IMAGE_VIEW_TYPE_2D;
    viewInfo.format = format;
    viewInfo.subresourceRange = {aspect, 0, 1, 0, 1};
    result.view = PNSPLAT_VK_CREATE(ImageView, context.device(), viewInfo);
    return result;
}

// The largest radius scale, depth offset and Gaussian sharpness with which splats of one colour are
// summed in one word a pixel (Impl::submit).
constexpr float kOneWordMaxScale = 4.0f;

// The linear RGB of a colour packed as gpu::Splat::colour (sRGB), as the shaders' srgbToLinear.
glm::vec3 linearColour(std::uint32_t packed) {
    glm::vec3 linear;
    for (int k = 0; k < 3; ++k) {
        const float c = float((packed >> (8 * k)) & 0xFFu) / 255.0f;
        linear[k] = c > 0.04045f ? std::pow((c + 0.055f) / 1.055f, 2.4f) : c / 12.92f;
    }
    return linear;
}

void bufferBarrier(VkCommandBuffer cmd, VkPipelineStageFlags srcStage, VkAccessFlags srcAccess,
                   VkPipelineStageFlags dstStage, VkAccessFlags dstAccess) {
    VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    barrier.srcAccessMask = srcAccess;
    barrier.dstAccessMask = dstAccess;
    vkCmdPipelineBarrier(cmd, srcStage, dstStage, 0, 1, &barrier, 0, nullptr, 0, nullptr);
}

// One subpass, the given attachments; `dependencies` order it after earlier passes and before
// later readers.
Unique<VkRenderPass> createRenderPass(VkDevice device,
                                      const std::vector<VkAttachmentDescription>& attachments,
                                      std::uint32_t colourCount, bool depth,
                                      const std::vector<VkSubpassDependency>& dependencies) {
    std::vector<VkAttachmentReference> colours;
    for (std::uint32_t i = 0; i < colourCount; ++i)
        colours.push_back({i, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL});
    const VkAttachmentReference depthRef{colourCount, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    VkSubpassDescription subpass{};
    subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    subpass.colorAttachmentCount = colourCount;
    subpass.pColorAttachments = colours.data();
    subpass.pDepthStencilAttachment = depth ? &depthRef : nullptr;
    VkRenderPassCreateInfo info{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
    info.attachmentCount = static_cast<std::uint32_t>(attachments.size());
    info.pAttachments = attachments.data();
    info.subpassCount = 1;
    info.pSubpasses = &subpass;
    info.dependencyCount = static_cast<std::uint32_t>(dependencies.size());
    info.pDependencies = dependencies.data();
    return PNSPLAT_VK_CREATE(RenderPass, device, info);
}

VkAttachmentDescription attachment(VkFormat format, VkAttachmentLoadOp load, VkImageLayout initial,
                                   VkImageLayout final) {
    return {.format = format,
            .samples = VK_SAMPLE_COUNT_1_BIT,
            .loadOp = load,
            .storeOp = VK_ATTACHMENT_STORE_OP_STORE,
            .stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE,
            .stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE,
            .initialLayout = initial,
            .finalLayout = final};
}

// The settings that only the frame's uniforms carry are finite, and positive where they must be.
bool lookInRange(const RenderSettings& s) {
    return s.radiusScale > 0.0f && std::isfinite(s.radiusScale) && s.depthOffset >= 0.0f &&
           std::isfinite(s.depthOffset) && s.sharpness >= 0.0f && std::isfinite(s.sharpness) &&
           s.heatMapPx >= 0.0f && std::isfinite(s.heatMapPx);
}

struct GraphicsPipelineDesc {
    VkPrimitiveTopology topology;
    VkShaderModule vertex, fragment;
    VkRenderPass renderPass;
    std::uint32_t colourCount;
    bool depthTest, depthWrite, additive;
};

} // namespace

struct SplatRenderer::Impl {
    Context& context;
    RenderSettings settings;
    VkDevice device;
    // What one frame in flight owns (frames.h): written by the CPU while the other frame draws.
    struct Slot {
        Buffer uniforms, ranges, readback;
        Buffer ticks; // the timestamps, copied here by the frame (host-visible)
        Unique<VkQueryPool> timestamps;
        VkDescriptorSet set = VK_NULL_HANDLE;
        std::uint32_t workItems = 0; // of its frame (compute path)
        bool oneColour = false;      // its splats have one colour (compute path: one word a pixel)
        std::uint64_t frame = ~std::uint64_t{0};
        bool readBack = false;
    };
    std::array<Slot, kFramesInFlight> slots;
    Unique<VkDescriptorSetLayout> setLayout;
    Unique<VkPipelineLayout> pipelineLayout;
    Unique<VkDescriptorPool> descriptorPool;
    // The compute path's sum buffer is cleared (by the last frame's normalization pass, which runs
    // before the next frame's passes on the one queue); false at first and after a frame that failed
    // part-way. (The depth buffer is filled at every frame's start.)
    bool buffersCleared = false;
    std::array<Unique<VkPipeline>, 3> pipelines; // visibility, accumulation, normalization
    // Compute path, splats of one colour: accumulation and normalization.
    std::array<Unique<VkPipeline>, 2> oneColourPipelines;
    // Compute path.
    Buffer depthBits, accum, output;
    // Graphics path.
    Image depth, accumColour, accumNormal, outputImage;
    Unique<VkSampler> sampler;
    std::array<Unique<VkRenderPass>, 3> renderPasses;
    std::array<Unique<VkFramebuffer>, 3> framebuffers;

    Impl(Context& c, const RenderSettings& s) : context(c), settings(s), device(c.device()) {}

    VkExtent2D extent() const { return {settings.width, settings.height}; }
    std::size_t pixelCount() const { return std::size_t{settings.width} * settings.height; }
    bool compute() const { return settings.path == RenderPath::Compute; }
    bool plain() const { return settings.path == RenderPath::PlainPoints; }
    int passCount() const { return plain() ? 1 : 3; }

    void createCommon();
    void createCompute();
    void createGraphics();
    void createPlainPoints();
    Unique<VkPipeline> computePipeline(VkShaderModule module, bool oneColour = false);
    Unique<VkPipeline> graphicsPipeline(const GraphicsPipelineDesc& desc);
    void ensureRangeCapacity(Slot& slot, std::size_t items);
    void writeDescriptors(const Slot& slot, const Buffer& splats);
    void recordCompute(VkCommandBuffer cmd, const Slot& slot, int pass, bool cleared);
    void recordGraphics(VkCommandBuffer cmd, const Slot& slot, int pass, std::span<const DrawRange> draws);
    void submit(FrameRing& frames, const Buffer& splats, std::optional<std::uint32_t> oneColour,
                std::span<const DrawRange> ranges, const Camera& camera, DepthRange depth,
                const FrameOutput& output);
};

void SplatRenderer::Impl::createCommon() {
    for (Slot& slot : slots) {
        slot.uniforms = createBuffer(context, sizeof(gpu::FrameUniforms), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                                     MemoryUse::Upload);
        ensureRangeCapacity(slot, 1);
        slot.readback =
            createBuffer(context, pixelCount() * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUse::Readback);
        if (!context.properties().limits.timestampComputeAndGraphics) continue;
        slot.ticks = createBuffer(context, 6 * sizeof(std::uint64_t), VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                  MemoryUse::Readback);
        VkQueryPoolCreateInfo info{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
        info.queryType = VK_QUERY_TYPE_TIMESTAMP;
        info.queryCount = 6;
        slot.timestamps = PNSPLAT_VK_CREATE(QueryPool, device, info);
    }

    // One set for all three passes of a path: 0 frame uniforms, 1 splats, then the path's own.
    std::vector<VkDescriptorSetLayoutBinding> bindings;
    const auto add = [&](std::uint32_t binding, VkDescriptorType type) {
        bindings.push_back({binding, type, 1, VK_SHADER_STAGE_ALL, nullptr});
    };
    add(gpu::kBindingFrame, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER);
    add(gpu::kBindingSplats, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER);
    if (compute()) {
        for (const std::uint32_t b :
             {gpu::kBindingItems, gpu::kBindingDepth, gpu::kBindingAccum, gpu::kBindingOutput})
            add(b, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER);
    } else if (!plain()) {
        add(gpu::kBindingAccumColour, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER);
        add(gpu::kBindingAccumNormal, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER);
    }
    VkDescriptorSetLayoutCreateInfo layoutInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    layoutInfo.bindingCount = static_cast<std::uint32_t>(bindings.size());
    layoutInfo.pBindings = bindings.data();
    setLayout = PNSPLAT_VK_CREATE(DescriptorSetLayout, device, layoutInfo);
    const VkDescriptorSetLayout layout = setLayout.get();

    VkPipelineLayoutCreateInfo pipelineInfo{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    pipelineInfo.setLayoutCount = 1;
    pipelineInfo.pSetLayouts = &layout;
    pipelineLayout = PNSPLAT_VK_CREATE(PipelineLayout, device, pipelineInfo);

    const std::array<VkDescriptorPoolSize, 3> sizes{
        {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, kFramesInFlight},
         {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 5 * kFramesInFlight},
         {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 2 * kFramesInFlight}}};
    VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    poolInfo.maxSets = kFramesInFlight;
    poolInfo.poolSizeCount = static_cast<std::uint32_t>(sizes.size());
    poolInfo.pPoolSizes = sizes.data();
    descriptorPool = PNSPLAT_VK_CREATE(DescriptorPool, device, poolInfo);
    VkDescriptorSetAllocateInfo alloc{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    alloc.descriptorPool = descriptorPool.get();
    alloc.descriptorSetCount = 1;
    alloc.pSetLayouts = &layout;
    for (Slot& slot : slots) PNSPLAT_VK_CHECK(vkAllocateDescriptorSets(device, &alloc, &slot.set));
}

// `oneColour` sets the shader's specialization constant 0 (kOneColour of compute_accumulate.comp and
// compute_normalize.comp).
Unique<VkPipeline> SplatRenderer::Impl::computePipeline(VkShaderModule module, bool oneColour) {
    const VkBool32 value = oneColour ? VK_TRUE : VK_FALSE;
    const VkSpecializationMapEntry entry{0, 0, sizeof(value)};
    const VkSpecializationInfo specialization{1, &entry, sizeof(value), &value};
    VkComputePipelineCreateInfo info{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    info.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    info.stage.module = module;
    info.stage.pName = "main";
    info.stage.pSpecializationInfo = oneColour ? &specialization : nullptr;
    info.layout = pipelineLayout.get();
    VkPipeline pipeline = VK_NULL_HANDLE;
    PNSPLAT_VK_CHECK(vkCreateComputePipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline));
    return {device, pipeline, vkDestroyPipeline};
}

void SplatRenderer::Impl::createCompute() {
    constexpr VkBufferUsageFlags kStorage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT |
                                            VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                            VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
    depthBits = createBuffer(context, pixelCount() * 4, kStorage, MemoryUse::Device);
    accum = createBuffer(context, pixelCount() * gpu::kAccumStride * 8, kStorage, MemoryUse::Device);
    output = createBuffer(context, pixelCount() * 4, kStorage, MemoryUse::Device);
    const auto visibility = shaderModule(device, k_compute_visibility_comp);
    const auto accumulate = shaderModule(device, k_compute_accumulate_comp);
    const auto normalize = shaderModule(device, k_compute_normalize_comp);
    pipelines = {computePipeline(visibility.get()), computePipeline(accumulate.get()),
                 computePipeline(normalize.get())};
    oneColourPipelines = {computePipeline(accumulate.get(), true), computePipeline(normalize.get(), true)};
}

Unique<VkPipeline> SplatRenderer::Impl::graphicsPipeline(const GraphicsPipelineDesc& desc) {
    std::array<VkPipelineShaderStageCreateInfo, 2> stages{};
    stages[0] = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
    stages[0].module = desc.vertex;
    stages[0].pName = "main";
    stages[1] = stages[0];
    stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
    stages[1].module = desc.fragment;
    VkPipelineVertexInputStateCreateInfo vertexInput{
        VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
    VkPipelineInputAssemblyStateCreateInfo assembly{
        VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
    assembly.topology = desc.topology;
    const VkViewport viewport{0.0f, 0.0f, float(settings.width), float(settings.height), 0.0f, 1.0f};
    const VkRect2D scissor{{0, 0}, extent()};
    VkPipelineViewportStateCreateInfo viewportState{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
    viewportState.viewportCount = 1;
    viewportState.pViewports = &viewport;
    viewportState.scissorCount = 1;
    viewportState.pScissors = &scissor;
    VkPipelineRasterizationStateCreateInfo raster{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
    raster.polygonMode = VK_POLYGON_MODE_FILL;
    raster.cullMode = VK_CULL_MODE_NONE; // back-facing splats are dropped by the vertex shader
    raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
    raster.lineWidth = 1.0f;
    VkPipelineMultisampleStateCreateInfo multisample{
        VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
    multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
    VkPipelineDepthStencilStateCreateInfo depthState{
        VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
    depthState.depthTestEnable = desc.depthTest;
    depthState.depthWriteEnable = desc.depthWrite;
    depthState.depthCompareOp = VK_COMPARE_OP_LESS_OR_EQUAL;
    // Additive blending where the pass asks for it: source and destination weighed one and added, for
    // colour and alpha alike; all four channels written.
    constexpr VkBlendFactor kOne = VK_BLEND_FACTOR_ONE;
    constexpr VkBlendOp kAdd = VK_BLEND_OP_ADD;
    constexpr VkColorComponentFlags kRgba = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                                            VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
    const VkPipelineColorBlendAttachmentState blend{desc.additive, kOne, kOne, kAdd, kOne, kOne, kAdd, kRgba};
    const std::vector<VkPipelineColorBlendAttachmentState> blends(desc.colourCount, blend);
    VkPipelineColorBlendStateCreateInfo blendState{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
    blendState.attachmentCount = desc.colourCount;
    blendState.pAttachments = blends.data();

    VkGraphicsPipelineCreateInfo info{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
    info.stageCount = 2;
    info.pStages = stages.data();
    info.pVertexInputState = &vertexInput;
    info.pInputAssemblyState = &assembly;
    info.pViewportState = &viewportState;
    info.pRasterizationState = &raster;
    info.pMultisampleState = &multisample;
    info.pDepthStencilState = &depthState;
    info.pColorBlendState = &blendState;
    info.layout = pipelineLayout.get();
    info.renderPass = desc.renderPass;
    VkPipeline pipeline = VK_NULL_HANDLE;
    PNSPLAT_VK_CHECK(vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline));
    return {device, pipeline, vkDestroyPipeline};
}

void SplatRenderer::Impl::createGraphics() {
    depth = createImage(context, extent(), kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                        VK_IMAGE_ASPECT_DEPTH_BIT);
    constexpr VkImageUsageFlags kAccumUsage =
        VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
    accumColour = createImage(context, extent(), kAccumFormat, kAccumUsage, VK_IMAGE_ASPECT_COLOR_BIT);
    accumNormal = createImage(context, extent(), kAccumFormat, kAccumUsage, VK_IMAGE_ASPECT_COLOR_BIT);
    outputImage = createImage(context, extent(), kOutputFormat,
                              VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                              VK_IMAGE_ASPECT_COLOR_BIT);

    VkSamplerCreateInfo samplerInfo{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
    samplerInfo.magFilter = samplerInfo.minFilter = VK_FILTER_NEAREST;
    samplerInfo.addressModeU = samplerInfo.addressModeV = samplerInfo.addressModeW =
        VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    sampler = PNSPLAT_VK_CREATE(Sampler, device, samplerInfo);

    constexpr VkPipelineStageFlags kTests =
        VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
    constexpr VkAccessFlags kDepthRW =
        VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    // Pass 1: depth only.
    renderPasses[0] =
        createRenderPass(device,
                         {attachment(kDepthFormat, VK_ATTACHMENT_LOAD_OP_CLEAR, VK_IMAGE_LAYOUT_UNDEFINED,
                                     VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL)},
                         0, true, {{VK_SUBPASS_EXTERNAL, 0, kTests, kTests, kDepthRW, kDepthRW, 0}});
    // Pass 2: two float targets, depth read (after pass 1; the targets after the last frame's pass 3).
    renderPasses[1] = createRenderPass(
        device,
        {attachment(kAccumFormat, VK_ATTACHMENT_LOAD_OP_CLEAR, VK_IMAGE_LAYOUT_UNDEFINED,
                    VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL),
         attachment(kAccumFormat, VK_ATTACHMENT_LOAD_OP_CLEAR, VK_IMAGE_LAYOUT_UNDEFINED,
                    VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL),
         attachment(kDepthFormat, VK_ATTACHMENT_LOAD_OP_LOAD,
                    VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                    VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL)},
        2, true,
        {{VK_SUBPASS_EXTERNAL, 0, kTests | VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT,
          kTests | VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
          VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
          kDepthRW | VK_ACCESS_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT, 0},
         {0, VK_SUBPASS_EXTERNAL, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
          VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
          VK_ACCESS_SHADER_READ_BIT, 0}});
    // Pass 3: the 8-bit output, then copied to the read-back buffer.
    renderPasses[2] =
        createRenderPass(device,
                         {attachment(kOutputFormat, VK_ATTACHMENT_LOAD_OP_DONT_CARE,
                                     VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL)},
                         1, false,
                         {{VK_SUBPASS_EXTERNAL, 0,
                           VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                           VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                           VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT, VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT, 0},
                          {0, VK_SUBPASS_EXTERNAL, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                           VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
                           VK_ACCESS_TRANSFER_READ_BIT, 0}});

    const std::array<std::vector<VkImageView>, 3> views{
        {{depth.view.get()},
         {accumColour.view.get(), accumNormal.view.get(), depth.view.get()},
         {outputImage.view.get()}}};
    for (int k = 0; k < 3; ++k) {
        VkFramebufferCreateInfo info{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
        info.renderPass = renderPasses[k].get();
        info.attachmentCount = static_cast<std::uint32_t>(views[k].size());
        info.pAttachments = views[k].data();
        info.width = settings.width;
        info.height = settings.height;
        info.layers = 1;
        framebuffers[k] = PNSPLAT_VK_CREATE(Framebuffer, device, info);
    }

    const auto splatVert = shaderModule(device, k_splat_vert);
    const auto visibilityFrag = shaderModule(device, k_graphics_visibility_frag);
    const auto accumulateFrag = shaderModule(device, k_graphics_accumulate_frag);
    const auto fullscreenVert = shaderModule(device, k_fullscreen_vert);
    const auto normalizeFrag = shaderModule(device, k_graphics_normalize_frag);
    constexpr VkPrimitiveTopology kTriangles = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
    pipelines = {graphicsPipeline({kTriangles, splatVert.get(), visibilityFrag.get(), renderPasses[0].get(),
                                   0, true, true, false}),
                 graphicsPipeline({kTriangles, splatVert.get(), accumulateFrag.get(), renderPasses[1].get(),
                                   2, true, false, true}),
                 graphicsPipeline({kTriangles, fullscreenVert.get(), normalizeFrag.get(),
                                   renderPasses[2].get(), 1, false, false, false})};
}

void SplatRenderer::Impl::createPlainPoints() {
    depth = createImage(context, extent(), kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                        VK_IMAGE_ASPECT_DEPTH_BIT);
    outputImage = createImage(context, extent(), kOutputFormat,
                              VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                              VK_IMAGE_ASPECT_COLOR_BIT);
    constexpr VkPipelineStageFlags kStages = VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT |
                                             VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT |
                                             VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    renderPasses[0] = createRenderPass(
        device,
        {attachment(kOutputFormat, VK_ATTACHMENT_LOAD_OP_CLEAR, VK_IMAGE_LAYOUT_UNDEFINED,
                    VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL),
         attachment(kDepthFormat, VK_ATTACHMENT_LOAD_OP_CLEAR, VK_IMAGE_LAYOUT_UNDEFINED,
                    VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL)},
        1, true,
        {{VK_SUBPASS_EXTERNAL, 0, kStages | VK_PIPELINE_STAGE_TRANSFER_BIT, kStages,
          VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
          VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT |
              VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
          0},
         {0, VK_SUBPASS_EXTERNAL, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
          VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT, VK_ACCESS_TRANSFER_READ_BIT,
          0}});
    const std::array<VkImageView, 2> views{outputImage.view.get(), depth.view.get()};
    VkFramebufferCreateInfo info{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
    info.renderPass = renderPasses[0].get();
    info.attachmentCount = 2;
    info.pAttachments = views.data();
    info.width = settings.width;
    info.height = settings.height;
    info.layers = 1;
    framebuffers[0] = PNSPLAT_VK_CREATE(Framebuffer, device, info);
    const auto vert = shaderModule(device, k_plain_point_vert);
    const auto frag = shaderModule(device, k_plain_point_frag);
    pipelines[0] = graphicsPipeline({VK_PRIMITIVE_TOPOLOGY_POINT_LIST, vert.get(), frag.get(),
                                     renderPasses[0].get(), 1, true, true, false});
}

void SplatRenderer::Impl::ensureRangeCapacity(Slot& slot, std::size_t items) {
    const VkDeviceSize bytes = std::max<std::size_t>(items, 1) * 2 * sizeof(std::uint32_t);
    if (slot.ranges.size >= bytes) return;
    // The slot's last frame has finished (FrameRing::begin): its old buffer can go at once.
    slot.ranges = createBuffer(context, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Upload);
}

void SplatRenderer::Impl::writeDescriptors(const Slot& slot, const Buffer& splats) {
    std::vector<VkDescriptorBufferInfo> buffers;
    buffers.reserve(6);
    std::vector<VkDescriptorImageInfo> images;
    images.reserve(2);
    std::vector<VkWriteDescriptorSet> writes;
    // One descriptor at `binding`; the caller points it at its buffer or image.
    const auto write = [&](std::uint32_t binding, VkDescriptorType type) -> VkWriteDescriptorSet& {
        VkWriteDescriptorSet& w =
            writes.emplace_back(VkWriteDescriptorSet{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET});
        w.dstSet = slot.set;
        w.dstBinding = binding;
        w.descriptorCount = 1;
        w.descriptorType = type;
        return w;
    };
    const auto writeBuffer = [&](std::uint32_t binding, VkDescriptorType type, const Buffer& buffer) {
        buffers.push_back({buffer.buffer.get(), 0, VK_WHOLE_SIZE});
        write(binding, type).pBufferInfo = &buffers.back();
    };
    writeBuffer(gpu::kBindingFrame, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, slot.uniforms);
    writeBuffer(gpu::kBindingSplats, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, splats);
    if (compute()) {
        writeBuffer(gpu::kBindingItems, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, slot.ranges);
        writeBuffer(gpu::kBindingDepth, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, depthBits);
        writeBuffer(gpu::kBindingAccum, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, accum);
        writeBuffer(gpu::kBindingOutput, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, output);
    } else if (!plain()) {
        for (const auto& [binding, image] : {std::pair{gpu::kBindingAccumColour, &accumColour},
                                             std::pair{gpu::kBindingAccumNormal, &accumNormal}}) {
            images.push_back({sampler.get(), image->view.get(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL});
            write(binding, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER).pImageInfo = &images.back();
        }
    }
    vkUpdateDescriptorSets(device, static_cast<std::uint32_t>(writes.size()), writes.data(), 0, nullptr);
}

void SplatRenderer::Impl::recordCompute(VkCommandBuffer cmd, const Slot& slot, int pass, bool cleared) {
    // `cleared`: the sums are zero already (buffersCleared).
    constexpr VkPipelineStageFlags kCompute = VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT;
    constexpr VkAccessFlags kRW = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
    if (pass == 0) {
        bufferBarrier(cmd, kCompute | VK_PIPELINE_STAGE_TRANSFER_BIT,
                      VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT,
                      VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT);
        vkCmdFillBuffer(cmd, depthBits.buffer.get(), 0, VK_WHOLE_SIZE, gpu::kDepthCleared);
        if (!cleared) vkCmdFillBuffer(cmd, accum.buffer.get(), 0, VK_WHOLE_SIZE, 0u);
        bufferBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, kCompute, kRW);
    } else if (pass == 2) {
        // The output buffer was last read by the previous frame's copies.
        bufferBarrier(cmd, kCompute | VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_SHADER_WRITE_BIT, kCompute,
                      kRW);
    } else {
        bufferBarrier(cmd, kCompute, VK_ACCESS_SHADER_WRITE_BIT, kCompute, kRW);
    }
    const VkPipeline pipeline =
        pass > 0 && slot.oneColour ? oneColourPipelines[pass - 1].get() : pipelines[pass].get();
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipelineLayout.get(), 0, 1, &slot.set, 0,
                            nullptr);
    if (pass < 2) {
        // Work items in rows of at most maxComputeWorkGroupCount[0] groups.
        const std::uint32_t row =
            std::min(slot.workItems, context.properties().limits.maxComputeWorkGroupCount[0]);
        if (slot.workItems > 0) vkCmdDispatch(cmd, row, (slot.workItems + row - 1) / row, 1);
    } else {
        vkCmdDispatch(cmd, (settings.width + 31) / 32, (settings.height + 31) / 32, 1);
    }
}

void SplatRenderer::Impl::recordGraphics(VkCommandBuffer cmd, const Slot& slot, int pass,
                                         std::span<const DrawRange> draws) {
    std::array<VkClearValue, 3> clears{};
    std::uint32_t clearCount = 0;
    if (plain()) {
        clears[0].color = {{0.0f, 0.0f, 0.0f, 1.0f}};
        clears[1].depthStencil = {1.0f, 0};
        clearCount = 2;
    } else if (pass == 0) {
        clears[0].depthStencil = {1.0f, 0};
        clearCount = 1;
    } else if (pass == 1) {
        clearCount = 2; // the two float targets, to zero
    }
    VkRenderPassBeginInfo begin{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
    begin.renderPass = renderPasses[pass].get();
    begin.framebuffer = framebuffers[pass].get();
    begin.renderArea = {{0, 0}, extent()};
    begin.clearValueCount = clearCount;
    begin.pClearValues = clears.data();
    vkCmdBeginRenderPass(cmd, &begin, VK_SUBPASS_CONTENTS_INLINE);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelines[pass].get());
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelineLayout.get(), 0, 1, &slot.set, 0,
                            nullptr);
    if (plain()) {
        for (const DrawRange& d : draws) vkCmdDraw(cmd, d.count, 1, d.first, 0);
    } else if (pass < 2) {
        for (const DrawRange& d : draws) vkCmdDraw(cmd, 6 * d.count, 1, 6 * d.first, 0);
    } else {
        vkCmdDraw(cmd, 3, 1, 0, 0);
    }
    vkCmdEndRenderPass(cmd);
}

void SplatRenderer::Impl::submit(FrameRing& frames, const Buffer& splats,
                                 std::optional<std::uint32_t> oneColour, std::span<const DrawRange> ranges,
                                 const Camera& camera, DepthRange range, const FrameOutput& out) {
    Slot& slot = slots[frames.slot()];
    slot.frame = frames.index();
    slot.readBack = out.readBack;
    // The heat map gives each splat a colour of its own. The one-word sums (gpu_types.h) carry past a
    // weight of 512 at a pixel and keep weights to 1/4096: about 9 splats cover a pixel at the
    // default look (a weight of about 4), 16 times as many at 4 times the radius, and a wider depth
    // band or a sharper Gaussian lets more in or keeps less of the rim, so past those bounds the
    // four sums are used.
    slot.oneColour = oneColour.has_value() && !(settings.heatMapPx > 0.0f) &&
                     settings.radiusScale <= kOneWordMaxScale && settings.depthOffset <= kOneWordMaxScale &&
                     settings.sharpness <= kOneWordMaxScale;
    const float aspect = float(settings.width) / float(settings.height);
    const float tanY = std::tan(camera.fovY * 0.5f);

    // Adjacent ranges merged: one draw each on the graphics path; cut into work items of at most
    // kLocalSize splats, one workgroup each, on the compute path (so no workgroup idles on a long
    // run's tail).
    std::vector<DrawRange> draws;
    for (const DrawRange& r : ranges) {
        if (r.count == 0) continue;
        if (!draws.empty() && draws.back().first + draws.back().count == r.first) {
            draws.back().count += r.count;
        } else {
            draws.push_back(r);
        }
    }
    std::size_t items = 0;
    for (const DrawRange& d : draws) items += (d.count + gpu::kLocalSize - 1) / gpu::kLocalSize;
    ensureRangeCapacity(slot, items);
    auto* item = static_cast<std::array<std::uint32_t, 2>*>(slot.ranges.mapped);
    slot.workItems = 0;
    for (const DrawRange& d : draws)
        for (std::uint32_t done = 0; done < d.count; done += gpu::kLocalSize)
            item[slot.workItems++] = {d.first + done, std::min(gpu::kLocalSize, d.count - done)};

    gpu::FrameUniforms frame{};
    frame.view = camera.view();
    frame.projection = projection(camera.fovY, aspect, range);
    frame.background = {settings.background, 1.0f};
    frame.viewport = {float(settings.width), float(settings.height), 1.0f / float(settings.width),
                      1.0f / float(settings.height)};
    frame.rayScale = {tanY * aspect, tanY, range.near, 0.0f};
    frame.splat = {settings.radiusScale, settings.depthOffset, settings.sharpness, settings.heatMapPx};
    frame.flags = {settings.normalize ? 1u : 0u, slot.workItems, 0u, 0u};
    if (slot.oneColour) frame.colour = glm::vec4(linearColour(*oneColour), 1.0f);
    std::memcpy(slot.uniforms.mapped, &frame, sizeof(frame));
    writeDescriptors(slot, splats);

    const bool cleared = buffersCleared;
    buffersCleared = false; // until the normalization pass has been submitted
    for (int pass = 0; pass < passCount(); ++pass) {
        const VkCommandBuffer cmd = frames.commandBuffer();
        const bool last = pass + 1 == passCount();
        if (pass == 0) {
            // Splats copied into the buffer earlier in this frame, before any pass reads them.
            bufferBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                          VK_PIPELINE_STAGE_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                          VK_ACCESS_SHADER_READ_BIT);
        }
        if (slot.timestamps) {
            vkCmdResetQueryPool(cmd, slot.timestamps.get(), std::uint32_t(2 * pass), 2);
            vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, slot.timestamps.get(),
                                std::uint32_t(2 * pass));
        }
        if (compute()) {
            recordCompute(cmd, slot, pass, cleared);
        } else {
            recordGraphics(cmd, slot, pass, draws);
        }
        if (slot.timestamps)
            vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, slot.timestamps.get(),
                                std::uint32_t(2 * pass + 1));
        if (last) {
            FrameOutput::Source source;
            if (compute()) {
                bufferBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
                              VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_READ_BIT);
                source.buffer = output.buffer.get();
            } else {
                source.image = outputImage.image.get(); // TRANSFER_SRC_OPTIMAL after the render pass
            }
            if (out.readBack) {
                if (compute()) {
                    const VkBufferCopy region{0, 0, pixelCount() * 4};
                    vkCmdCopyBuffer(cmd, output.buffer.get(), slot.readback.buffer.get(), 1, &region);
                } else {
                    VkBufferImageCopy region{};
                    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
                    region.imageExtent = {settings.width, settings.height, 1};
                    vkCmdCopyImageToBuffer(cmd, outputImage.image.get(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                                           slot.readback.buffer.get(), 1, &region);
                }
                bufferBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                              VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_HOST_READ_BIT);
            }
            if (slot.timestamps) {
                vkCmdCopyQueryPoolResults(cmd, slot.timestamps.get(), 0, std::uint32_t(2 * passCount()),
                                          slot.ticks.buffer.get(), 0, sizeof(std::uint64_t),
                                          VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
                bufferBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                              VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_HOST_READ_BIT);
            }
            if (out.record) out.record(cmd, source);
        }
        frames.submit(cmd, last, last ? out.wait : VK_NULL_HANDLE, last ? out.waitStage : 0,
                      last ? out.signal : VK_NULL_HANDLE);
    }
    buffersCleared = compute();
}

Result<std::unique_ptr<SplatRenderer>> SplatRenderer::create(Context& context,
                                                             const RenderSettings& settings) {
    const auto& limits = context.properties().limits;
    if (settings.width == 0 || settings.height == 0)
        return Error{"image size " + std::to_string(settings.width) + "x" + std::to_string(settings.height) +
                     " is empty"};
    if (settings.width > limits.maxImageDimension2D || settings.height > limits.maxImageDimension2D)
        return Error{"image size " + std::to_string(settings.width) + "x" + std::to_string(settings.height) +
                     " exceeds the device's limit of " + std::to_string(limits.maxImageDimension2D)};
    if (!lookInRange(settings))
        return Error{"render settings: radius scale must be positive, depth offset, sharpness and heat map "
                     "diameter non-negative"};
    if (settings.path == RenderPath::Compute) {
        if (!context.hasInt64Atomics())
            return Error{"the compute path needs 64-bit storage buffer atomics, which " +
                         context.deviceName() + " lacks; use the graphics path"};
        const std::size_t accumBytes = std::size_t{settings.width} * settings.height * gpu::kAccumStride * 8;
        if (accumBytes > limits.maxStorageBufferRange)
            return Error{"image size " + std::to_string(settings.width) + "x" +
                         std::to_string(settings.height) +
                         " is too large for the compute path on this device; use the graphics path"};
    }
    auto impl = std::make_unique<Impl>(context, settings);
    try {
        impl->createCommon();
        if (impl->compute())
            impl->createCompute();
        else if (impl->plain())
            impl->createPlainPoints();
        else
            impl->createGraphics();
    } catch (const VulkanError& e) {
        return Error{std::string("Vulkan: ") + e.what()};
    }
    return std::unique_ptr<SplatRenderer>(new SplatRenderer(std::move(impl)));
}

SplatRenderer::SplatRenderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
SplatRenderer::~SplatRenderer() = default;

const RenderSettings& SplatRenderer::settings() const {
    return impl_->settings;
}

bool SplatRenderer::adjust(const RenderSettings& settings) {
    const RenderSettings& current = impl_->settings;
    if (settings.width != current.width || settings.height != current.height ||
        settings.path != current.path || !lookInRange(settings))
        return false;
    impl_->settings = settings;
    return true;
}

void SplatRenderer::submit(FrameRing& frames, const Buffer& splats, std::optional<std::uint32_t> oneColour,
                           std::span<const DrawRange> ranges, const Camera& camera, DepthRange depth,
                           const FrameOutput& output) {
    assert(camera.valid());
    impl_->submit(frames, splats, oneColour, ranges, camera, depth, output);
}

PassTimes SplatRenderer::passTimes(std::uint64_t frame) const {
    const Impl::Slot& slot = impl_->slots[frame % kFramesInFlight];
    PassTimes times;
    if (!slot.timestamps || slot.frame != frame) return times;
    std::array<std::uint64_t, 6> ticks{};
    std::memcpy(ticks.data(), slot.ticks.mapped, sizeof(ticks));
    const double period = double(impl_->context.properties().limits.timestampPeriod) * 1e-6;
    const auto span = [&](int pass) {
        return pass < impl_->passCount() ? double(ticks[2 * pass + 1] - ticks[2 * pass]) * period : 0.0;
    };
    times.visibilityMs = span(0); // the whole draw for PlainPoints
    times.accumulationMs = span(1);
    times.normalizationMs = span(2);
    return times;
}

std::optional<std::size_t> SplatRenderer::coveredPixels(std::uint64_t frame) const {
    const Impl::Slot& slot = impl_->slots[frame % kFramesInFlight];
    if (slot.frame != frame || !slot.readBack) return std::nullopt;
    const std::size_t bytes = 4 * std::size_t{impl_->settings.width} * impl_->settings.height;
    return engine::coveredPixels({static_cast<const std::uint8_t*>(slot.readback.mapped), bytes},
                                 backgroundPixel(impl_->settings.background));
}

RgbaImage SplatRenderer::image(std::uint64_t frame) const {
    const Impl::Slot& slot = impl_->slots[frame % kFramesInFlight];
    assert(slot.frame == frame && slot.readBack);
    RgbaImage image(impl_->settings.width, impl_->settings.height);
    std::memcpy(image.pixels.data(), slot.readback.mapped, image.pixels.size());
    return image;
}

} // namespace pnsplat::engine
