// The raster pipeline's passes (render_passes.h): the graphics path (ALGORITHM.md §11.5: each
// splat drawn as the square around its disk, in the disk's plane; depth, then additive float
// targets, then a full-screen normalization) and the plain points (every splat centre a 1-pixel
// point with a depth test, the benchmark's baseline).
#include <array>
#include <vector>

#include "gpu_types.h"
#include "pnsplat/engine/buffer.h"
#include "render_passes.h"
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

struct GraphicsPipelineDesc {
    VkPrimitiveTopology topology;
    VkShaderModule vertex, fragment;
    VkRenderPass renderPass;
    std::uint32_t colourCount;
    bool depthTest, depthWrite, additive;
};

// What both raster paths have: a depth buffer, the RGBA8 output image, and up to three render
// passes, framebuffers and pipelines; a pass begins and ends its render pass around its draws.
class RasterPasses : public RenderPasses {
  public:
    RasterPasses(Context& context, const RenderSettings& settings)
        : context_(context), settings_(settings), device_(context.device()) {}

    FrameOutput::Source output(VkCommandBuffer) override {
        return {VK_NULL_HANDLE, outputImage_.image.get()}; // TRANSFER_SRC_OPTIMAL after the render pass
    }
    void copyOutput(VkCommandBuffer cmd, VkBuffer readback) const override {
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageExtent = {settings_.width, settings_.height, 1};
        vkCmdCopyImageToBuffer(cmd, outputImage_.image.get(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback,
                               1, &region);
    }

  protected:
    VkExtent2D extent() const { return {settings_.width, settings_.height}; }
    Unique<VkPipeline> graphicsPipeline(const GraphicsPipelineDesc& desc) const;
    // Begins render pass `pass` with `clears` and binds its pipeline and the frame's set.
    void begin(VkCommandBuffer cmd, int pass, const PathFrame& frame,
               std::span<const VkClearValue> clears) const {
        VkRenderPassBeginInfo info{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
        info.renderPass = renderPasses_[pass].get();
        info.framebuffer = framebuffers_[pass].get();
        info.renderArea = {{0, 0}, extent()};
        info.clearValueCount = static_cast<std::uint32_t>(clears.size());
        info.pClearValues = clears.data();
        vkCmdBeginRenderPass(cmd, &info, VK_SUBPASS_CONTENTS_INLINE);
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelines_[pass].get());
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, frame.layout, 0, 1, &frame.set, 0,
                                nullptr);
    }

    Context& context_;
    const RenderSettings& settings_;
    VkDevice device_;
    VkPipelineLayout layout_ = VK_NULL_HANDLE;
    Image depth_, outputImage_;
    Image accumColour_, accumNormal_; // the graphics path's (destroyed after the framebuffers)
    Unique<VkSampler> sampler_;
    std::array<Unique<VkRenderPass>, 3> renderPasses_;
    std::array<Unique<VkFramebuffer>, 3> framebuffers_;
    std::array<Unique<VkPipeline>, 3> pipelines_;
};

Unique<VkPipeline> RasterPasses::graphicsPipeline(const GraphicsPipelineDesc& desc) const {
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
    const VkViewport viewport{0.0f, 0.0f, float(settings_.width), float(settings_.height), 0.0f, 1.0f};
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
    info.layout = layout_;
    info.renderPass = desc.renderPass;
    VkPipeline pipeline = VK_NULL_HANDLE;
    PNSPLAT_VK_CHECK(vkCreateGraphicsPipelines(device_, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline));
    return {device_, pipeline, vkDestroyPipeline};
}

class GraphicsPasses final : public RasterPasses {
  public:
    using RasterPasses::RasterPasses;
    int count() const override { return 3; }
    std::vector<VkDescriptorSetLayoutBinding> bindings() const override {
        return {{gpu::kBindingAccumColour, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_ALL,
                 nullptr},
                {gpu::kBindingAccumNormal, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_ALL,
                 nullptr}};
    }
    void create(VkPipelineLayout layout) override;
    void write(DescriptorWrites& writes, const PathFrame&) const override {
        writes.image(gpu::kBindingAccumColour, sampler_.get(), accumColour_.view.get());
        writes.image(gpu::kBindingAccumNormal, sampler_.get(), accumNormal_.view.get());
    }
    void record(VkCommandBuffer cmd, int pass, const PathFrame& frame) override {
        std::array<VkClearValue, 2> clears{}; // pass 1: the two float targets, to zero
        if (pass == 0) clears[0].depthStencil = {1.0f, 0};
        begin(cmd, pass, frame, std::span(clears).first(pass == 0 ? 1 : pass == 1 ? 2 : 0));
        if (pass < 2) {
            for (const DrawRange& d : frame.draws) vkCmdDraw(cmd, 6 * d.count, 1, 6 * d.first, 0);
        } else {
            vkCmdDraw(cmd, 3, 1, 0, 0);
        }
        vkCmdEndRenderPass(cmd);
    }
};

void GraphicsPasses::create(VkPipelineLayout layout) {
    layout_ = layout;
    depth_ = createImage(context_, extent(), kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                         VK_IMAGE_ASPECT_DEPTH_BIT);
    constexpr VkImageUsageFlags kAccumUsage =
        VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
    accumColour_ = createImage(context_, extent(), kAccumFormat, kAccumUsage, VK_IMAGE_ASPECT_COLOR_BIT);
    accumNormal_ = createImage(context_, extent(), kAccumFormat, kAccumUsage, VK_IMAGE_ASPECT_COLOR_BIT);
    outputImage_ = createImage(context_, extent(), kOutputFormat,
                               VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                               VK_IMAGE_ASPECT_COLOR_BIT);

    VkSamplerCreateInfo samplerInfo{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
    samplerInfo.magFilter = samplerInfo.minFilter = VK_FILTER_NEAREST;
    samplerInfo.addressModeU = samplerInfo.addressModeV = samplerInfo.addressModeW =
        VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    sampler_ = PNSPLAT_VK_CREATE(Sampler, device_, samplerInfo);

    constexpr VkPipelineStageFlags kTests =
        VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
    constexpr VkAccessFlags kDepthRW =
        VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    // Pass 1: depth only.
    renderPasses_[0] =
        createRenderPass(device_,
                         {attachment(kDepthFormat, VK_ATTACHMENT_LOAD_OP_CLEAR, VK_IMAGE_LAYOUT_UNDEFINED,
                                     VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL)},
                         0, true, {{VK_SUBPASS_EXTERNAL, 0, kTests, kTests, kDepthRW, kDepthRW, 0}});
    // Pass 2: two float targets, depth read (after pass 1; the targets after the last frame's pass 3).
    renderPasses_[1] = createRenderPass(
        device_,
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
    renderPasses_[2] =
        createRenderPass(device_,
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
        {{depth_.view.get()},
         {accumColour_.view.get(), accumNormal_.view.get(), depth_.view.get()},
         {outputImage_.view.get()}}};
    for (int k = 0; k < 3; ++k) {
        VkFramebufferCreateInfo info{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
        info.renderPass = renderPasses_[k].get();
        info.attachmentCount = static_cast<std::uint32_t>(views[k].size());
        info.pAttachments = views[k].data();
        info.width = settings_.width;
        info.height = settings_.height;
        info.layers = 1;
        framebuffers_[k] = PNSPLAT_VK_CREATE(Framebuffer, device_, info);
    }

    const auto splatVert = shaderModule(device_, k_splat_vert);
    const auto visibilityFrag = shaderModule(device_, k_graphics_visibility_frag);
    const auto accumulateFrag = shaderModule(device_, k_graphics_accumulate_frag);
    const auto fullscreenVert = shaderModule(device_, k_fullscreen_vert);
    const auto normalizeFrag = shaderModule(device_, k_graphics_normalize_frag);
    constexpr VkPrimitiveTopology kTriangles = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
    pipelines_ = {graphicsPipeline({kTriangles, splatVert.get(), visibilityFrag.get(), renderPasses_[0].get(),
                                    0, true, true, false}),
                  graphicsPipeline({kTriangles, splatVert.get(), accumulateFrag.get(), renderPasses_[1].get(),
                                    2, true, false, true}),
                  graphicsPipeline({kTriangles, fullscreenVert.get(), normalizeFrag.get(),
                                    renderPasses_[2].get(), 1, false, false, false})};
}

class PlainPointPasses final : public RasterPasses {
  public:
    using RasterPasses::RasterPasses;
    int count() const override { return 1; }
    std::vector<VkDescriptorSetLayoutBinding> bindings() const override { return {}; }
    void create(VkPipelineLayout layout) override;
    void write(DescriptorWrites&, const PathFrame&) const override {}
    void record(VkCommandBuffer cmd, int pass, const PathFrame& frame) override {
        std::array<VkClearValue, 2> clears{};
        clears[0].color = {{0.0f, 0.0f, 0.0f, 1.0f}};
        clears[1].depthStencil = {1.0f, 0};
        begin(cmd, pass, frame, clears);
        for (const DrawRange& d : frame.draws) vkCmdDraw(cmd, d.count, 1, d.first, 0);
        vkCmdEndRenderPass(cmd);
    }
};

void PlainPointPasses::create(VkPipelineLayout layout) {
    layout_ = layout;
    depth_ = createImage(context_, extent(), kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                         VK_IMAGE_ASPECT_DEPTH_BIT);
    outputImage_ = createImage(context_, extent(), kOutputFormat,
                               VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                               VK_IMAGE_ASPECT_COLOR_BIT);
    constexpr VkPipelineStageFlags kStages = VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT |
                                             VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT |
                                             VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    renderPasses_[0] = createRenderPass(
        device_,
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
    const std::array<VkImageView, 2> views{outputImage_.view.get(), depth_.view.get()};
    VkFramebufferCreateInfo info{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
    info.renderPass = renderPasses_[0].get();
    info.attachmentCount = 2;
    info.pAttachments = views.data();
    info.width = settings_.width;
    info.height = settings_.height;
    info.layers = 1;
    framebuffers_[0] = PNSPLAT_VK_CREATE(Framebuffer, device_, info);
    const auto vert = shaderModule(device_, k_plain_point_vert);
    const auto frag = shaderModule(device_, k_plain_point_frag);
    pipelines_[0] = graphicsPipeline({VK_PRIMITIVE_TOPOLOGY_POINT_LIST, vert.get(), frag.get(),
                                      renderPasses_[0].get(), 1, true, true, false});
}

} // namespace

std::unique_ptr<RenderPasses> makeGraphicsPasses(Context& context, const RenderSettings& settings) {
    return std::make_unique<GraphicsPasses>(context, settings);
}

std::unique_ptr<RenderPasses> makePlainPointPasses(Context& context, const RenderSettings& settings) {
    return std::make_unique<PlainPointPasses>(context, settings);
}

} // namespace pnsplat::engine
