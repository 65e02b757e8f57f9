// The passes of one render path (RenderPath, splat_renderer.h), a type each: the compute path
// (compute_passes.cpp), the graphics path and the plain points (graphics_passes.cpp). The renderer
// (splat_renderer.cpp) owns what the paths share: the frame slots, the frame's uniforms and work
// items, the descriptor set of all passes (gpu::kBindingFrame and gpu::kBindingSplats, then the
// path's own bindings), the timestamps and the read-back; a path makes its targets and pipelines and
// records its passes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <span>
#include <vector>

#include <glm/vec2.hpp>

#include "gpu_types.h"
#include "pnsplat/engine/context.h"
#include "pnsplat/engine/image.h"
#include "pnsplat/engine/splat_renderer.h"
#include "pnsplat/engine/vulkan.h"

namespace pnsplat::engine {

// The descriptor writes of one frame's set; the infos they point at stay in place until update().
class DescriptorWrites {
  public:
    explicit DescriptorWrites(VkDescriptorSet set) : set_(set) {}
    void buffer(std::uint32_t binding, VkDescriptorType type, VkBuffer buffer);
    void image(std::uint32_t binding, VkSampler sampler, VkImageView view); // a sampled image
    void texelBuffer(std::uint32_t binding, VkBufferView view);             // a uniform texel buffer
    void update(VkDevice device) const;

  private:
    VkWriteDescriptorSet& add(std::uint32_t binding, VkDescriptorType type);
    VkDescriptorSet set_;
    std::deque<VkDescriptorBufferInfo> buffers_;
    std::deque<VkDescriptorImageInfo> images_;
    std::deque<VkBufferView> texelBuffers_;
    std::vector<VkWriteDescriptorSet> writes_;
};

// What one frame's passes draw.
struct PathFrame {
    VkPipelineLayout layout = VK_NULL_HANDLE; // the set's
    VkDescriptorSet set = VK_NULL_HANDLE;
    // The compute path's work items (gpu::kBindingItems): per workgroup its ranges, then the ranges.
    VkBufferView items = VK_NULL_HANDLE;
    std::uint32_t workgroups = 0;
    bool oneColour = false;           // the compute path's one-word sums (gpu_types.h)
    std::span<const DrawRange> draws; // the graphics paths': adjacent ranges merged
};

class RenderPasses {
  public:
    virtual ~RenderPasses() = default;
    // The passes of a frame: visibility, accumulation, normalization; or the plain points' one.
    virtual int count() const = 0;
    // The path's own bindings of the shared set.
    virtual std::vector<VkDescriptorSetLayoutBinding> bindings() const = 0;
    // Makes the targets and pipelines, on the set's pipeline layout. Throws VulkanError.
    virtual void create(VkPipelineLayout layout) = 0;
    virtual void write(DescriptorWrites& writes, const PathFrame& frame) const = 0;
    // Records pass `pass` of a frame in `cmd` (each pass is a submission of its own).
    virtual void record(VkCommandBuffer cmd, int pass, const PathFrame& frame) = 0;
    // After the last pass, in its command buffer: the frame's RGBA8 image, ready for transfer
    // reads; and its copy into `readback` (width × height × 4 bytes).
    virtual FrameOutput::Source output(VkCommandBuffer cmd) = 0;
    virtual void copyOutput(VkCommandBuffer cmd, VkBuffer readback) const = 0;
};

// `settings` outlives the passes (the renderer's own; its size and path never change).
std::unique_ptr<RenderPasses> makeComputePasses(Context& context, const RenderSettings& settings);
std::unique_ptr<RenderPasses> makeGraphicsPasses(Context& context, const RenderSettings& settings);
std::unique_ptr<RenderPasses> makePlainPointPasses(Context& context, const RenderSettings& settings);

// The background pixel as one RGBA8 word (red in the low byte, alpha 255): the compute path fills
// the picture with it at a frame's start, and both paths' normalizations write it for their
// background pixels (gpu::FrameUniforms::picture).
inline std::uint32_t backgroundWord(glm::vec3 background) {
    const glm::u8vec3 c = backgroundPixel(background);
    return std::uint32_t{c.x} | std::uint32_t{c.y} << 8 | std::uint32_t{c.z} << 16 | 0xFF000000u;
}

// The compute path's normalization tiles (gpu::kTileWidth × kTileHeight pixels) across and down a
// picture of `width` × `height`.
inline glm::uvec2 normalizationTiles(std::uint32_t width, std::uint32_t height) {
    return {(width + gpu::kTileWidth - 1) / gpu::kTileWidth,
            (height + gpu::kTileHeight - 1) / gpu::kTileHeight};
}

void bufferBarrier(VkCommandBuffer cmd, VkPipelineStageFlags srcStage, VkAccessFlags srcAccess,
                   VkPipelineStageFlags dstStage, VkAccessFlags dstAccess);

template <std::size_t N>
Unique<VkShaderModule> shaderModule(VkDevice device, const std::uint32_t (&code)[N]) {
    VkShaderModuleCreateInfo info{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    info.codeSize = sizeof(code);
    info.pCode = code;
    return PNSPLAT_VK_CREATE(ShaderModule, device, info);
}

} // namespace pnsplat::engine
