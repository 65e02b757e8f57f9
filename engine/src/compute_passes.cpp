// The compute path's passes (render_passes.h; ALGORITHM.md §11.5): one invocation per splat walks
// the pixels of its footprint, with atomics on storage buffers of one word (depth) and one or four
// words (sums) a pixel; the passes after the first read the depth, the normalization the sums, as
// texels. A splat pass lists the splats too large for one invocation (gpu::kBigSplatPixels) and
// draws them in a second, indirect dispatch, with workgroups of their own. The normalization draws only the
// tiles that splats reached, listed by a first dispatch of its shader; the picture is filled with
// the background before.
#include <algorithm>
#include <array>

#include "gpu_types.h"
#include "pnsplat/engine/buffer.h"
#include "render_passes.h"
#include "spirv/compute_accumulate_comp.h"
#include "spirv/compute_normalize_comp.h"
#include "spirv/compute_visibility_comp.h"

namespace pnsplat::engine {

namespace {

class ComputePasses final : public RenderPasses {
  public:
    ComputePasses(Context& context, const RenderSettings& settings)
        : context_(context), settings_(settings), device_(context.device()) {}

    int count() const override { return 3; }
    std::vector<VkDescriptorSetLayoutBinding> bindings() const override {
        std::vector<VkDescriptorSetLayoutBinding> out;
        for (const std::uint32_t b :
             {gpu::kBindingDepth, gpu::kBindingAccum, gpu::kBindingOutput, gpu::kBindingTiles})
            out.push_back({b, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_ALL, nullptr});
        for (const std::uint32_t b : {gpu::kBindingItems, gpu::kBindingDepthTexels, gpu::kBindingAccumTexels})
            out.push_back({b, VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, 1, VK_SHADER_STAGE_ALL, nullptr});
        return out;
    }
    void create(VkPipelineLayout layout) override;
    void write(DescriptorWrites& writes, const PathFrame& frame) const override {
        writes.texelBuffer(gpu::kBindingItems, frame.items);
        writes.texelBuffer(gpu::kBindingDepthTexels, depthTexels_.get());
        writes.texelBuffer(gpu::kBindingAccumTexels, accumTexels_.get());
        writes.buffer(gpu::kBindingDepth, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, depthBits_.buffer.get());
        writes.buffer(gpu::kBindingAccum, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, accum_.buffer.get());
        writes.buffer(gpu::kBindingOutput, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, output_.buffer.get());
        writes.buffer(gpu::kBindingTiles, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, tiles_.buffer.get());
    }
    void record(VkCommandBuffer cmd, int pass, const PathFrame& frame) override;
    FrameOutput::Source output(VkCommandBuffer cmd) override {
        bufferBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
                      VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_READ_BIT);
        return {output_.buffer.get(), VK_NULL_HANDLE};
    }
    void copyOutput(VkCommandBuffer cmd, VkBuffer readback) const override {
        const VkBufferCopy region{0, 0, std::size_t{settings_.width} * settings_.height * 4};
        vkCmdCopyBuffer(cmd, output_.buffer.get(), readback, 1, &region);
    }

  private:
    // `oneColour` sets the shader's specialization constant 0 (kOneColour of compute_accumulate.comp
    // and compute_normalize.comp), `tileScan` its constant 1 (kTileScan of compute_normalize.comp),
    // `bigSplats` its constant 3 (kBigSplats of splat_compute.glsl) and its workgroup's size, constant
    // 4 (gpu::kBigSplatGroup instead of kLocalSize).
    Unique<VkPipeline> pipeline(VkShaderModule module, VkPipelineLayout layout, bool oneColour = false,
                                bool tileScan = false, bool bigSplats = false) const;
    glm::uvec2 tiles() const { return normalizationTiles(settings_.width, settings_.height); }
    // Where the big splats' two indirect dispatches begin in tiles_ (splat_compute.glsl,
    // bigSplatsAt), in bytes.
    VkDeviceSize bigSplatsAt() const {
        return sizeof(VkDispatchIndirectCommand) + VkDeviceSize{tiles().x} * tiles().y * 8;
    }
    // Workgroups a big splat takes (the y of its dispatch): enough for a footprint of the whole
    // picture with at most gpu::kBigSplatRuns runs an invocation.
    std::uint32_t bigSplatParts() const {
        const std::uint32_t runs = (settings_.width + gpu::kBigSplatRun - 1) / gpu::kBigSplatRun;
        const std::uint32_t perPart = gpu::kBigSplatGroup * gpu::kBigSplatRuns;
        return (settings_.height * runs + perPart - 1) / perPart;
    }
    void dispatchBigSplats(VkCommandBuffer cmd, int pass, const PathFrame& frame) const;

    Context& context_;
    const RenderSettings& settings_;
    VkDevice device_;
    Buffer depthBits_, accum_, output_;
    // The normalization's indirect dispatch (the count of tiles reached, 1, 1), a flag per tile and
    // the list of those reached, then the splat passes' big splats (gpu::kBindingTiles).
    Buffer tiles_;
    Unique<VkBufferView> depthTexels_, accumTexels_; // R32UI and RG32UI (gpu::kBindingDepthTexels, ...)
    std::array<Unique<VkPipeline>, 3> pipelines_;    // visibility, accumulation, normalization
    // Splats of one colour: accumulation and normalization.
    std::array<Unique<VkPipeline>, 2> oneColourPipelines_;
    Unique<VkPipeline> tileScan_; // the normalization's first dispatch
    // The splat passes' dispatches of their big splats: visibility, accumulation, and accumulation
    // of splats of one colour.
    std::array<Unique<VkPipeline>, 3> bigSplatPipelines_;
};

Unique<VkPipeline> ComputePasses::pipeline(VkShaderModule module, VkPipelineLayout layout, bool oneColour,
                                           bool tileScan, bool bigSplats) const {
    // kOneColour, kTileScan, the normalization's rows of invocations (the scan's one; the splat
    // passes have no constant 2), kBigSplats and the splat passes' workgroup size (the
    // normalization has no constants 3 and 4).
    const std::array<std::uint32_t, 5> values{
        oneColour ? VK_TRUE : VK_FALSE, tileScan ? VK_TRUE : VK_FALSE, tileScan ? 1u : gpu::kTileHeight,
        bigSplats ? VK_TRUE : VK_FALSE, bigSplats ? gpu::kBigSplatGroup : gpu::kLocalSize};
    std::array<VkSpecializationMapEntry, 5> entries{};
    for (std::uint32_t k = 0; k < entries.size(); ++k) entries[k] = {k, 4 * k, 4};
    const VkSpecializationInfo specialization{5, entries.data(), sizeof(values), values.data()};
    VkComputePipelineCreateInfo info{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    info.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    info.stage.module = module;
    info.stage.pName = "main";
    info.stage.pSpecializationInfo = &specialization;
    info.layout = layout;
    VkPipeline made = VK_NULL_HANDLE;
    PNSPLAT_VK_CHECK(vkCreateComputePipelines(device_, VK_NULL_HANDLE, 1, &info, nullptr, &made));
    return {device_, made, vkDestroyPipeline};
}

void ComputePasses::create(VkPipelineLayout layout) {
    constexpr VkBufferUsageFlags kStorage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT |
                                            VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                            VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
    constexpr VkBufferUsageFlags kTexels = kStorage | VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT; // read so too
    const std::size_t pixels = std::size_t{settings_.width} * settings_.height;
    depthBits_ = createBuffer(context_, pixels * 4, kTexels, MemoryUse::Device);
    accum_ = createBuffer(context_, pixels * gpu::kAccumStride * 8, kTexels, MemoryUse::Device);
    output_ = createBuffer(context_, pixels * 4, kStorage, MemoryUse::Device);
    // After the tiles, two indirect dispatches of 4 words each and two lists.
    tiles_ = createBuffer(context_, bigSplatsAt() + 8 * 4 + 2 * std::size_t{gpu::kBigSplatCapacity} * 4,
                          kStorage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, MemoryUse::Device);
    depthTexels_ = createTexelView(context_, depthBits_, VK_FORMAT_R32_UINT);
    accumTexels_ = createTexelView(context_, accum_, VK_FORMAT_R32G32_UINT);
    const auto visibility = shaderModule(device_, k_compute_visibility_comp);
    const auto accumulate = shaderModule(device_, k_compute_accumulate_comp);
    const auto normalize = shaderModule(device_, k_compute_normalize_comp);
    pipelines_ = {pipeline(visibility.get(), layout), pipeline(accumulate.get(), layout),
                  pipeline(normalize.get(), layout)};
    oneColourPipelines_ = {pipeline(accumulate.get(), layout, true), pipeline(normalize.get(), layout, true)};
    tileScan_ = pipeline(normalize.get(), layout, false, true);
    bigSplatPipelines_ = {pipeline(visibility.get(), layout, false, false, true),
                          pipeline(accumulate.get(), layout, false, false, true),
                          pipeline(accumulate.get(), layout, true, false, true)};
}

void ComputePasses::dispatchBigSplats(VkCommandBuffer cmd, int pass, const PathFrame& frame) const {
    // After the first dispatch has listed them and counted them into the indirect dispatch.
    bufferBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
                  VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT,
                  VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                      VK_ACCESS_INDIRECT_COMMAND_READ_BIT);
    const int which = pass == 1 && frame.oneColour ? 2 : pass;
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, bigSplatPipelines_[which].get());
    vkCmdDispatchIndirect(cmd, tiles_.buffer.get(), bigSplatsAt() + 16 * VkDeviceSize(pass));
}

void ComputePasses::record(VkCommandBuffer cmd, int pass, const PathFrame& frame) {
    constexpr VkPipelineStageFlags kCompute = VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT;
    constexpr VkAccessFlags kRW = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
    if (pass == 0) {
        // After the previous frame's passes, its indirect dispatch and its copies of the picture.
        bufferBarrier(cmd, kCompute | VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT,
                      VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT,
                      VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT);
        // Memsets on lavapipe: cheaper than a store per pixel in the normalization, which lavapipe
        // makes one lane at a time (the normalization cleared the sums it read until the
        // thirty-fourth session; docs/REALTIME.md, "What a frame costs on lavapipe").
        vkCmdFillBuffer(cmd, depthBits_.buffer.get(), 0, VK_WHOLE_SIZE, gpu::kDepthCleared);
        // The words of the sums the frame uses: one a pixel for splats of one colour.
        const std::size_t words =
            std::size_t{settings_.width} * settings_.height * (frame.oneColour ? 1 : gpu::kAccumStride);
        vkCmdFillBuffer(cmd, accum_.buffer.get(), 0, words * 8, 0u);
        // The picture is the background where the normalization draws no tile; no tile listed yet.
        vkCmdFillBuffer(cmd, output_.buffer.get(), 0, VK_WHOLE_SIZE, backgroundWord(settings_.background));
        // No tile listed, no tile flagged (the list after the flags is written before it is read).
        const std::size_t flags = std::size_t{tiles().x} * tiles().y * 4;
        vkCmdFillBuffer(cmd, tiles_.buffer.get(), 0, 4, 0u);
        vkCmdFillBuffer(cmd, tiles_.buffer.get(), 4, 8, 1u);
        vkCmdFillBuffer(cmd, tiles_.buffer.get(), sizeof(VkDispatchIndirectCommand), flags, 0u);
        // No big splat listed: the two dispatches (0, bigSplatParts(), 1).
        for (const VkDeviceSize at : {bigSplatsAt(), bigSplatsAt() + 16}) {
            vkCmdFillBuffer(cmd, tiles_.buffer.get(), at, 4, 0u);
            vkCmdFillBuffer(cmd, tiles_.buffer.get(), at + 4, 4, bigSplatParts());
            vkCmdFillBuffer(cmd, tiles_.buffer.get(), at + 8, 4, 1u);
        }
        bufferBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, kCompute, kRW);
    } else if (pass == 2) {
        bufferBarrier(cmd, kCompute, VK_ACCESS_SHADER_WRITE_BIT, kCompute, kRW);
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, tileScan_.get());
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, frame.layout, 0, 1, &frame.set, 0,
                                nullptr);
        vkCmdDispatch(cmd, tiles().x, tiles().y, 1);
        bufferBarrier(cmd, kCompute, VK_ACCESS_SHADER_WRITE_BIT,
                      kCompute | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT,
                      kRW | VK_ACCESS_INDIRECT_COMMAND_READ_BIT);
    } else {
        bufferBarrier(cmd, kCompute, VK_ACCESS_SHADER_WRITE_BIT, kCompute, kRW);
    }
    const VkPipeline pipeline =
        pass > 0 && frame.oneColour ? oneColourPipelines_[pass - 1].get() : pipelines_[pass].get();
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, frame.layout, 0, 1, &frame.set, 0, nullptr);
    if (pass < 2) {
        // Workgroups in rows of at most maxComputeWorkGroupCount[0].
        const std::uint32_t row =
            std::min(frame.workgroups, context_.properties().limits.maxComputeWorkGroupCount[0]);
        if (frame.workgroups > 0) vkCmdDispatch(cmd, row, (frame.workgroups + row - 1) / row, 1);
        dispatchBigSplats(cmd, pass, frame);
    } else {
        vkCmdDispatchIndirect(cmd, tiles_.buffer.get(), 0); // the tiles listed, pairs of pixels
    }
}

} // namespace

std::unique_ptr<RenderPasses> makeComputePasses(Context& context, const RenderSettings& settings) {
    return std::make_unique<ComputePasses>(context, settings);
}

} // namespace pnsplat::engine
