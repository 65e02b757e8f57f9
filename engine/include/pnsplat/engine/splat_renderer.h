// Surface splatting in three passes (ALGORITHM.md §11): visibility, Gaussian accumulation, normalization
// with deferred shading, on one of two paths that give the same picture:
//  - Compute: one invocation per splat walks its screen footprint; 32-bit atomicMin on depth,
//    fixed-point accumulation by 64-bit atomicAdd (shaderBufferInt64Atomics), a per-pixel
//    normalization. The default: on lavapipe it is several times faster than the raster pipeline.
//  - Graphics: each splat drawn as its bounding square in the disk plane (no size limit),
//    depth test and additive blending into float targets, a full-screen normalization.
// Nodes outside the view frustum are skipped on the CPU before either path.
//
// Thread use: one thread at a time per renderer; render() waits for the GPU and returns the image.
#pragma once

#include <cstdint>
#include <memory>

#include <glm/vec3.hpp>

#include "pnsplat/engine/camera.h"
#include "pnsplat/engine/context.h"
#include "pnsplat/engine/image.h"
#include "pnsplat/engine/splat_scene.h"

namespace pnsplat::engine {

enum class RenderPath {
    Compute,
    Graphics,
    // Not splatting: every splat centre as a plain 1-pixel point through the raster pipeline, with
    // a depth test. The benchmark's baseline (on lavapipe, raster cost is per primitive).
    PlainPoints,
};

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
    bool normalize = true; // false shows raw accumulated colour (a switch for tests)
    bool cullNodes = true; // false draws every node (a switch for tests of the culling)
};

struct FrameStats {
    std::size_t splats = 0, splatsDrawn = 0; // in the scene; in its visible nodes
    std::size_t nodes = 0, nodesVisible = 0;
    // Per pass, from GPU timestamps around each pass (each pass is its own submission, since
    // lavapipe writes timestamps between compute dispatches late); 0 when the device has none.
    double visibilityMs = 0.0, accumulationMs = 0.0, normalizationMs = 0.0;
    double wallMs = 0.0; // first submission to the image in host memory, read-back included
};

class SplatRenderer {
  public:
    // Fails for a zero or too large image size, a compute path the device cannot run, or a Vulkan error.
    static Result<std::unique_ptr<SplatRenderer>> create(Context& context, const RenderSettings& settings);
    ~SplatRenderer();
    SplatRenderer(const SplatRenderer&) = delete;
    SplatRenderer& operator=(const SplatRenderer&) = delete;

    // Renders `scene` (created on the same context) seen from `camera`; an invalid camera is an
    // error, a camera that sees nothing gives the background.
    Result<RgbaImage> render(const SplatScene& scene, const Camera& camera, FrameStats* stats = nullptr);
    const RenderSettings& settings() const;

  private:
    struct Impl;
    explicit SplatRenderer(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

} // namespace pnsplat::engine
