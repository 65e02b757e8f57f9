#include "pnsplat/engine/splat_renderer.h"

#include <algorithm>
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
#include "render_passes.h"

namespace pnsplat::engine {

namespace {

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

// The settings that only the frame's uniforms carry are finite, and positive where they must be.
bool lookInRange(const RenderSettings& s) {
    return s.radiusScale > 0.0f && std::isfinite(s.radiusScale) && s.depthOffset >= 0.0f &&
           std::isfinite(s.depthOffset) && s.sharpness >= 0.0f && std::isfinite(s.sharpness) &&
           s.heatMapPx >= 0.0f && std::isfinite(s.heatMapPx);
}

} // namespace

void bufferBarrier(VkCommandBuffer cmd, VkPipelineStageFlags srcStage, VkAccessFlags srcAccess,
                   VkPipelineStageFlags dstStage, VkAccessFlags dstAccess) {
    VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    barrier.srcAccessMask = srcAccess;
    barrier.dstAccessMask = dstAccess;
    vkCmdPipelineBarrier(cmd, srcStage, dstStage, 0, 1, &barrier, 0, nullptr, 0, nullptr);
}

VkWriteDescriptorSet& DescriptorWrites::add(std::uint32_t binding, VkDescriptorType type) {
    VkWriteDescriptorSet& w =
        writes_.emplace_back(VkWriteDescriptorSet{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET});
    w.dstSet = set_;
    w.dstBinding = binding;
    w.descriptorCount = 1;
    w.descriptorType = type;
    return w;
}

void DescriptorWrites::buffer(std::uint32_t binding, VkDescriptorType type, VkBuffer buffer) {
    add(binding, type).pBufferInfo = &buffers_.emplace_back(VkDescriptorBufferInfo{buffer, 0, VK_WHOLE_SIZE});
}

void DescriptorWrites::image(std::uint32_t binding, VkSampler sampler, VkImageView view) {
    add(binding, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER).pImageInfo =
        &images_.emplace_back(VkDescriptorImageInfo{sampler, view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL});
}

void DescriptorWrites::texelBuffer(std::uint32_t binding, VkBufferView view) {
    add(binding, VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER).pTexelBufferView =
        &texelBuffers_.emplace_back(view);
}

void DescriptorWrites::update(VkDevice device) const {
    vkUpdateDescriptorSets(device, static_cast<std::uint32_t>(writes_.size()), writes_.data(), 0, nullptr);
}

struct SplatRenderer::Impl {
    Context& context;
    RenderSettings settings;
    VkDevice device;
    // What one frame in flight owns (frames.h): written by the CPU while the other frame draws.
    struct Slot {
        Buffer uniforms, ranges, readback;
        Unique<VkBufferView> rangeTexels; // `ranges` as the compute path reads them (gpu::kBindingItems)
        Buffer ticks;                     // the timestamps, copied here by the frame (host-visible)
        Unique<VkQueryPool> timestamps;
        VkDescriptorSet set = VK_NULL_HANDLE;
        std::uint32_t workgroups = 0; // of its frame (compute path)
        bool oneColour = false;       // its splats have one colour (compute path: one word a pixel)
        std::uint64_t frame = ~std::uint64_t{0};
        bool readBack = false;
    };
    std::array<Slot, kFramesInFlight> slots;
    Unique<VkDescriptorSetLayout> setLayout;
    Unique<VkPipelineLayout> pipelineLayout;
    Unique<VkDescriptorPool> descriptorPool;
    std::unique_ptr<RenderPasses> passes; // the path's; destroyed first, its pipelines before the layout

    Impl(Context& c, const RenderSettings& s) : context(c), settings(s), device(c.device()) {}

    std::size_t pixelCount() const { return std::size_t{settings.width} * settings.height; }

    void createCommon();
    void ensureRangeCapacity(Slot& slot, std::size_t items);
    void submit(FrameRing& frames, VkBufferView splats, std::optional<std::uint32_t> oneColour,
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

    // One set for all passes of a path: the frame's uniforms and the splats, then the path's own.
    std::vector<VkDescriptorSetLayoutBinding> bindings{
        {gpu::kBindingFrame, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_ALL, nullptr},
        {gpu::kBindingSplats, VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, 1, VK_SHADER_STAGE_ALL, nullptr}};
    for (const VkDescriptorSetLayoutBinding& b : passes->bindings()) bindings.push_back(b);
    VkDescriptorSetLayoutCreateInfo layoutInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    layoutInfo.bindingCount = static_cast<std::uint32_t>(bindings.size());
    layoutInfo.pBindings = bindings.data();
    setLayout = PNSPLAT_VK_CREATE(DescriptorSetLayout, device, layoutInfo);
    const VkDescriptorSetLayout layout = setLayout.get();

    VkPipelineLayoutCreateInfo pipelineInfo{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    pipelineInfo.setLayoutCount = 1;
    pipelineInfo.pSetLayouts = &layout;
    pipelineLayout = PNSPLAT_VK_CREATE(PipelineLayout, device, pipelineInfo);

    // The pool holds each slot's set: a descriptor of each binding.
    std::vector<VkDescriptorPoolSize> sizes;
    for (const VkDescriptorSetLayoutBinding& b : bindings) {
        const auto same = std::ranges::find(sizes, b.descriptorType, &VkDescriptorPoolSize::type);
        if (same != sizes.end()) {
            same->descriptorCount += kFramesInFlight;
        } else {
            sizes.push_back({b.descriptorType, kFramesInFlight});
        }
    }
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
    passes->create(pipelineLayout.get());
}

void SplatRenderer::Impl::ensureRangeCapacity(Slot& slot, std::size_t items) {
    const VkDeviceSize bytes = std::max<std::size_t>(items, 1) * 2 * sizeof(std::uint32_t);
    if (slot.ranges.size >= bytes) return;
    // The slot's last frame has finished (FrameRing::begin): its old buffer can go at once.
    slot.rangeTexels = {};
    slot.ranges = createBuffer(context, bytes, VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT, MemoryUse::Upload);
    slot.rangeTexels = createTexelView(context, slot.ranges, VK_FORMAT_R32G32_UINT);
}

void SplatRenderer::Impl::submit(FrameRing& frames, VkBufferView splats,
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

    // Adjacent ranges merged: one draw each on the graphics path. On the compute path, cut into
    // pieces of at most kLocalSize splats, and consecutive pieces gathered into workgroups of at
    // most kLocalSize splats and kGroupRanges pieces (so no workgroup idles on a run's tail: with a
    // workgroup a piece, the lion's and the nefertiti's passes took 6-10 % longer, docs/REALTIME.md).
    std::vector<DrawRange> draws;
    for (const DrawRange& r : ranges) {
        if (r.count == 0) continue;
        if (!draws.empty() && draws.back().first + draws.back().count == r.first) {
            draws.back().count += r.count;
        } else {
            draws.push_back(r);
        }
    }
    std::vector<std::array<std::uint32_t, 2>> pieces, groups; // (first splat, count), (first piece, pieces)
    for (const DrawRange& d : draws)
        for (std::uint32_t done = 0; done < d.count; done += gpu::kLocalSize)
            pieces.push_back({d.first + done, std::min(gpu::kLocalSize, d.count - done)});
    for (std::uint32_t k = 0, splatsInGroup = 0; k < pieces.size(); ++k) {
        if (groups.empty() || splatsInGroup + pieces[k][1] > gpu::kLocalSize ||
            groups.back()[1] == gpu::kGroupRanges) {
            groups.push_back({k, 0});
            splatsInGroup = 0;
        }
        ++groups.back()[1];
        splatsInGroup += pieces[k][1];
    }
    ensureRangeCapacity(slot, groups.size() + pieces.size());
    auto* item = static_cast<std::array<std::uint32_t, 2>*>(slot.ranges.mapped);
    slot.workgroups = static_cast<std::uint32_t>(groups.size());
    for (std::size_t g = 0; g < groups.size(); ++g) item[g] = {slot.workgroups + groups[g][0], groups[g][1]};
    std::copy(pieces.begin(), pieces.end(), item + groups.size());

    gpu::FrameUniforms frame{};
    frame.view = camera.view();
    frame.projection = projection(camera.fovY, aspect, range);
    frame.background = {settings.background, 1.0f};
    frame.viewport = {float(settings.width), float(settings.height), 1.0f / float(settings.width),
                      1.0f / float(settings.height)};
    frame.rayScale = {tanY * aspect, tanY, range.near, 0.0f};
    frame.splat = {settings.radiusScale, settings.depthOffset, settings.sharpness, settings.heatMapPx};
    frame.flags = {settings.normalize ? 1u : 0u, slot.workgroups, settings.smoothEdges ? 1u : 0u,
                   settings.fillPinholes ? 1u : 0u};
    if (slot.oneColour) frame.colour = glm::vec4(linearColour(*oneColour), 1.0f);
    const glm::uvec2 tiles = normalizationTiles(settings.width, settings.height);
    frame.picture = {tiles.x, backgroundWord(settings.background), tiles.x * tiles.y, 0u};
    std::memcpy(slot.uniforms.mapped, &frame, sizeof(frame));
    const PathFrame pathFrame{pipelineLayout.get(), slot.set,       slot.rangeTexels.get(),
                              slot.workgroups,      slot.oneColour, draws};
    DescriptorWrites writes(slot.set);
    writes.buffer(gpu::kBindingFrame, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, slot.uniforms.buffer.get());
    writes.texelBuffer(gpu::kBindingSplats, splats);
    passes->write(writes, pathFrame);
    writes.update(device);

    const int count = passes->count();
    for (int pass = 0; pass < count; ++pass) {
        const VkCommandBuffer cmd = frames.commandBuffer();
        const bool last = pass + 1 == count;
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
        passes->record(cmd, pass, pathFrame);
        if (slot.timestamps)
            vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, slot.timestamps.get(),
                                std::uint32_t(2 * pass + 1));
        if (last) {
            FrameOutput::Source source = passes->output(cmd);
            source.slot = frames.slot();
            if (out.readBack) {
                passes->copyOutput(cmd, slot.readback.buffer.get());
                bufferBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                              VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_HOST_READ_BIT);
            }
            if (slot.timestamps) {
                vkCmdCopyQueryPoolResults(cmd, slot.timestamps.get(), 0, std::uint32_t(2 * count),
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
}

std::optional<std::string> computePathProblem(const VkPhysicalDeviceLimits& limits, bool int64Atomics,
                                              const std::string& device) {
    if (!int64Atomics)
        return "the compute path needs 64-bit storage buffer atomics, which " + device +
               " lacks; use the graphics path";
    // The splat passes' workgroups (splat_compute.glsl) and the normalization's (compute_normalize.comp).
    constexpr std::uint32_t kNormalizeSide = 32;
    const std::uint32_t invocations = std::max(gpu::kLocalSize, kNormalizeSide * kNormalizeSide);
    if (limits.maxComputeWorkGroupInvocations < invocations ||
        limits.maxComputeWorkGroupSize[0] < gpu::kLocalSize ||
        limits.maxComputeWorkGroupSize[1] < kNormalizeSide)
        return "the compute path needs workgroups of " + std::to_string(invocations) + " invocations, " +
               std::to_string(gpu::kLocalSize) + " in x, which " + device + " does not allow (at most " +
               std::to_string(limits.maxComputeWorkGroupInvocations) + "); use the graphics path";
    return std::nullopt;
}

std::optional<std::string> computePathProblem(const Context& context) {
    return computePathProblem(context.properties().limits, context.hasInt64Atomics(), context.deviceName());
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
        if (const auto problem = computePathProblem(context)) return Error{*problem};
        // The sums as storage (one or kAccumStride words a pixel) and as RG32UI texels.
        const std::size_t accumWords = std::size_t{settings.width} * settings.height * gpu::kAccumStride;
        // The normalization's tiles: a workgroup each, in one row of its indirect dispatch.
        const glm::uvec2 grid = normalizationTiles(settings.width, settings.height);
        const std::size_t tiles = std::size_t{grid.x} * grid.y;
        if (accumWords * 8 > limits.maxStorageBufferRange || accumWords > limits.maxTexelBufferElements ||
            tiles > limits.maxComputeWorkGroupCount[0])
            return Error{"image size " + std::to_string(settings.width) + "x" +
                         std::to_string(settings.height) +
                         " is too large for the compute path on this device; use the graphics path"};
    }
    auto impl = std::make_unique<Impl>(context, settings);
    try {
        switch (settings.path) {
        case RenderPath::Compute:
            impl->passes = makeComputePasses(context, impl->settings);
            break;
        case RenderPath::Graphics:
            impl->passes = makeGraphicsPasses(context, impl->settings);
            break;
        case RenderPath::PlainPoints:
            impl->passes = makePlainPointPasses(context, impl->settings);
            break;
        }
        impl->createCommon();
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

void SplatRenderer::submit(FrameRing& frames, VkBufferView splats, std::optional<std::uint32_t> oneColour,
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
        return pass < impl_->passes->count() ? double(ticks[2 * pass + 1] - ticks[2 * pass]) * period : 0.0;
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
