// Surface splatting in three passes (ALGORITHM.md §11): visibility, Gaussian accumulation, normalization
// with deferred shading, on one of two paths that give the same picture:
//  - Compute: one invocation per splat walks its screen footprint; 32-bit atomicMin on depth,
//    fixed-point accumulation by 64-bit atomicAdd (shaderBufferInt64Atomics), a per-pixel
//    normalization. The default: on lavapipe it is several times faster than the raster pipeline.
//  - Graphics: each splat drawn as its bounding square in the disk plane (no size limit),
//    depth test and additive blending into float targets, a full-screen normalization.
// The renderer draws ranges of a splat buffer (the engine's cache, engine.h, which chooses them);
// it keeps per-frame resources for kFramesInFlight frames (frames.h), so that frames pipeline.
//
// Thread use: the render thread only.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>

#include <glm/vec3.hpp>

#include "pnsplat/engine/buffer.h"
#include "pnsplat/engine/camera.h"
#include "pnsplat/engine/context.h"
#include "pnsplat/engine/frames.h"
#include "pnsplat/engine/image.h"

namespace pnsplat::engine {

enum class RenderPath {
    Compute,
    Graphics,
    // Not splatting: every splat centre as a plain 1-pixel point through the raster pipeline, with
    // a depth test. The benchmark's baseline (on lavapipe, raster cost is per primitive).
    PlainPoints,
};

// Why a device cannot run the compute path, or nothing: it needs 64-bit storage buffer atomics,
// and workgroups of gpu::kLocalSize (1,024) invocations in one row for the splat passes and of
// 32 × 32 for the normalization, where Vulkan guarantees only 128 invocations (lavapipe and most
// GPUs allow 1,024). `device` names it in the message.
std::optional<std::string> computePathProblem(const VkPhysicalDeviceLimits& limits, bool int64Atomics,
                                              const std::string& device);
std::optional<std::string> computePathProblem(const Context& context);

struct RenderSettings {
    std::uint32_t width = 1280, height = 720;
    RenderPath path = RenderPath::Compute;
    glm::vec3 background{1.0f}; // sRGB, each in [0, 1]
    float radiusScale = 1.0f;   // splat radius = point radius × this
    // ε of the visibility pass in splat radii: splats within ε·r behind the nearest surface blend
    // into it. Choice: 1, since neighbouring splats of one surface differ in depth by up to about
    // one radius at grazing angles, while separate layers of a model are farther apart.
    float depthOffset = 1.0f;
    // Gaussian w = exp(-k ρ²) with ρ the distance from the centre over the radius. Choice: k = 2
    // (σ = r / 2): weight 0.14 at the rim, so the disk's cut-off barely shows.
    float sharpness = 2.0f;
    // The outer silhouette smoothed: a pixel beside the background blends toward it by its
    // accumulated weight (gpu::kEdgeWeight), so that the contour is antialiased and a contour moved
    // by a fraction of a pixel changes pixels by a fraction. false: every covered pixel whole.
    bool smoothEdges = true;
    // A pixel no splat reached whose four neighbours splats reached (a pinhole) drawn as its
    // horizontal neighbour (splat_common.glsl, pinholeIn). false: as background.
    bool fillPinholes = true;
    bool normalize = true; // false shows raw accumulated colour (a switch for tests)
    bool cullNodes = true; // false draws every node (a switch for tests of the culling)
    // The heat map of splat size, in pixels (>= 0; 0: off): each splat is coloured by its projected
    // diameter over this (blue for a quarter or less, green just below 1, yellow just above, red for
    // 4 or more; splat_common.glsl, heatColour), then shaded as usual. Both splatting paths.
    float heatMapPx = 0.0f;
};

// The GPU time of each pass of one frame, from timestamps around each pass (each pass is its own
// submission, since lavapipe writes timestamps between compute dispatches late); 0 when the device
// has no timestamps. PlainPoints has one pass (visibility).
struct PassTimes {
    double visibilityMs = 0.0, accumulationMs = 0.0, normalizationMs = 0.0;
};

// A run of consecutive splats of the splat buffer to draw.
struct DrawRange {
    std::uint32_t first = 0, count = 0;
};

// Where the 8-bit image of a frame goes besides the renderer: `record` is called with the last
// command buffer of the frame after the normalization pass, with the image to copy from (a swapchain
// shell blits it into its image there); the last submission waits for `wait` at `waitStage` and
// signals `signal` (each may be VK_NULL_HANDLE).
struct FrameOutput {
    // The compute path's result is a buffer of width × height RGBA8 texels, rows top to bottom, ready
    // for transfer reads; the graphics path's an RGBA8 image in TRANSFER_SRC_OPTIMAL layout.
    struct Source {
        VkBuffer buffer = VK_NULL_HANDLE;
        VkImage image = VK_NULL_HANDLE;
        // The frame's slot of its FrameRing (frames.h): what `record` keeps per frame in flight is
        // free again in a slot, since the frame that used it last has finished before this one began.
        std::uint32_t slot = 0;
    };
    bool readBack = false; // keep the frame's image for image()
    std::function<void(VkCommandBuffer, const Source&)> record;
    VkSemaphore wait = VK_NULL_HANDLE;
    VkPipelineStageFlags waitStage = 0;
    VkSemaphore signal = VK_NULL_HANDLE;
};

class SplatRenderer {
  public:
    // Fails for a zero or too large image size, a compute path the device cannot run, or a Vulkan
    // error.
    static Result<std::unique_ptr<SplatRenderer>> create(Context& context, const RenderSettings& settings);
    ~SplatRenderer();
    SplatRenderer(const SplatRenderer&) = delete;
    SplatRenderer& operator=(const SplatRenderer&) = delete;

    // Records and submits the passes of the current frame of `frames` (begun by the caller), drawing
    // `ranges` of `splats` (a texel view of gpu::Splats, ChunkCache::texels) from `camera` (valid) with the
    // depth range `depth`. `oneColour`: every splat drawn has this colour (packed as gpu::Splat::colour), so
    // that the compute path accumulates two sums a pixel instead of four (without the heat map). Does not
    // wait: the frame's fence signals when it is done. Throws VulkanError.
    void submit(FrameRing& frames, VkBufferView splats, std::optional<std::uint32_t> oneColour,
                std::span<const DrawRange> ranges, const Camera& camera, DepthRange depth,
                const FrameOutput& output);
    // The pass times and, when read back, the image of frame `frame` of `frames`; the frame must have
    // finished (FrameRing::completed() > frame) and its slot not have been begun again since. The
    // timestamps are copied into host memory by the frame's last command buffer: asking the query
    // pool for them would stall lavapipe, whose vkGetQueryPoolResults waits for the device to idle.
    PassTimes passTimes(std::uint64_t frame) const;
    RgbaImage image(std::uint64_t frame) const;
    // The pixels of that image a splat covers (not of the background colour: coveredPixels in
    // image.h), counted in host memory without a copy; nullopt when the frame was not read back.
    std::optional<std::size_t> coveredPixels(std::uint64_t frame) const;

    const RenderSettings& settings() const;
    // Takes `settings` for the frames submitted from now on, without waiting, when they differ from
    // the current ones only in what the frame's uniforms carry (background, radius scale, depth
    // offset, sharpness, smooth edges, normalize, heat map), and returns true; false, with nothing changed,
    // when the size or path differ (a new renderer is needed) or a value is out of range.
    bool adjust(const RenderSettings& settings);

  private:
    struct Impl;
    explicit SplatRenderer(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

} // namespace pnsplat::engine
