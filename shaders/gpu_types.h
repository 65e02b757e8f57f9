// GPU structs and constants shared by C++ (engine/) and GLSL (shaders/). One definition, two
// languages: in C++ the GLSL types map to GLM and engine/src/gpu_layout.cpp checks every size and
// offset with static_assert. Splat is 32 bytes, read as two RGBA32UI texels (splat_common.glsl,
// splatAt); FrameUniforms is std140 (a uniform buffer), so every member of it is 16-byte aligned.
#ifndef PNSPLAT_GPU_TYPES_H
#define PNSPLAT_GPU_TYPES_H

#ifdef __cplusplus
#include <cstdint>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
namespace pnsplat::gpu {
using vec3 = glm::vec3;
using vec4 = glm::vec4;
using uvec4 = glm::uvec4;
using mat4 = glm::mat4;
using uint = std::uint32_t;
#define PNSPLAT_CONST inline constexpr
#else
#define PNSPLAT_CONST const
#endif

// Compute path: invocations per workgroup (one splat each), and the most splats a node of the
// scene holds (its splats are contiguous). A workgroup draws up to kGroupRanges ranges of splats,
// kLocalSize splats in all (splat_compute.glsl, invocationSplat).
PNSPLAT_CONST uint kLocalSize = 1024;
PNSPLAT_CONST uint kChunkSize = 1024;
PNSPLAT_CONST uint kGroupRanges = 16;
// Compute path: a splat whose footprint's box holds more than kBigSplatPixels pixels is listed by
// the splat pass instead of drawn, and a second dispatch of the pass draws each listed splat with
// workgroups of kBigSplatGroup invocations, a row's run of at most kBigSplatRun pixels at a time
// (splat_compute.glsl, drawnSplat). lavapipe ends the loops of a batch of SIMD lanes (8, or 16)
// after 65,535 iterations in all, so a batch whose splats held more pixels was cut off
// (docs/REALTIME.md, "Splats too large for one invocation"): 16 splats of kBigSplatPixels make
// 49,152 at most, their rows 3,072 more. A listed splat gets enough workgroups (compute_passes.cpp,
// bigSplatParts) that no invocation walks more than kBigSplatRuns runs. At most kBigSplatCapacity
// are listed a pass and frame (a dispatch's most workgroups in x that every device allows); past
// them, a splat is drawn by one invocation, as the others.
PNSPLAT_CONST uint kBigSplatPixels = 3072;
PNSPLAT_CONST uint kBigSplatGroup = 256;
PNSPLAT_CONST uint kBigSplatRun = 256;
PNSPLAT_CONST uint kBigSplatRuns = 64;
PNSPLAT_CONST uint kBigSplatCapacity = 65535;
// The compute path accumulates in fixed point with 64-bit integer atomicAdd (native on CPUs, where
// float atomics are compare-and-swap loops): per pixel kAccumStride 64-bit words, each two 32-bit
// sums of values in [0, w] scaled by kFixedScale: (w·r, w·g), (w·b, w), (w·n'x, w·n'y), (w·n'z, 0)
// with n' = (n + 1) / 2. A low half cannot carry into its high half while the weights of a pixel
// sum to less than 2^32 / kFixedScale = 65536 (each w ≤ 1); each value is rounded to 1/65536.
// When every splat drawn has one colour (FrameUniforms::colour), one word a pixel: three
// fields of kOneColourBits, w, w·(a + 1) / 2 and w·(b + 1) / 2 with a, b the normal's two
// components across the pixel's ray (compute_accumulate.comp, packAcrossRay), each scaled by
// kOneColourScale: a field cannot carry into the next while the weights sum to less than
// 2^21 / 4096 = 512, and each value is rounded to 1/4096 (about 0.1 % of a typical pixel's weight).
// The renderer uses it only for the default look or near it (splat_renderer.cpp,
// kOneWordMaxScale).
PNSPLAT_CONST uint kAccumStride = 4;
PNSPLAT_CONST float kFixedScale = 65536.0f;
PNSPLAT_CONST uint kOneColourBits = 21;
PNSPLAT_CONST float kOneColourScale = 4096.0f;
// The compute path's cleared depth: +infinity as float bits, filled at each frame's start (the sums
// are filled with zero then too).
PNSPLAT_CONST uint kDepthCleared = 0x7F800000u;
// The outer silhouette, smoothed (RenderSettings::smoothEdges): a pixel beside the background (one
// of its four neighbours covered by no splat, and no pinhole: splat_common.glsl) whose accumulated
// weight w is below kEdgeWeight is drawn as mix(background, its colour, w / kEdgeWeight), so that a
// contour moved by a fraction of a pixel changes pixels by a fraction, not whole (smoothEdge).
PNSPLAT_CONST float kEdgeWeight = 1.0f;
// Compute path: the normalization draws the picture a tile at a time, one workgroup of 32 × 32
// invocations a tile, each a pair of pixels; tiles no splat reached are left as the background
// that fills the picture at the frame's start (compute_normalize.comp).
PNSPLAT_CONST uint kTileWidth = 64;
PNSPLAT_CONST uint kTileHeight = 32;

// The bindings of the one descriptor set (set 0) that all passes of a path share
// (splat_renderer.cpp makes it): the frame's uniforms and the splats on every path, then the
// path's own. Named once here, for the C++ that binds and the GLSL that reads.
PNSPLAT_CONST uint kBindingFrame = 0;  // FrameUniforms (uniform buffer)
PNSPLAT_CONST uint kBindingSplats = 1; // the cache's Splats (uniform texel buffer, RGBA32UI)
// Compute path: storage buffers, but the work items, per workgroup (its first range, its ranges), then
// the ranges (first splat, count): a uniform texel buffer, RG32UI.
PNSPLAT_CONST uint kBindingItems = 2;
PNSPLAT_CONST uint kBindingDepth = 3;  // the nearest depth per pixel, as float bits
PNSPLAT_CONST uint kBindingAccum = 4;  // the fixed-point sums per pixel (kAccumStride words, or one)
PNSPLAT_CONST uint kBindingOutput = 5; // the picture, RGBA8 per pixel
// The accumulation and the normalization read the depth as R32UI texels, the normalization the
// sums as RG32UI texels (a 64-bit word each).
PNSPLAT_CONST uint kBindingDepthTexels = 6;
PNSPLAT_CONST uint kBindingAccumTexels = 7;
// The normalization's tiles: the count of those that splats reached, the x of its indirect
// dispatch (VkDispatchIndirectCommand: x, y = 1, z = 1), then a flag per tile (reached) and the
// list of those reached (their indices, in any order). After them, the big splats (kBigSplatPixels)
// of the visibility and the accumulation passes: two indirect dispatches (the count listed, 1, 1),
// then the two lists of kBigSplatCapacity entries. One buffer: with the depth, the sums and the
// picture, four storage buffers, Vulkan's least maxPerStageDescriptorStorageBuffers.
PNSPLAT_CONST uint kBindingTiles = 8;
// Graphics path: the accumulation targets, sampled by the normalization pass.
PNSPLAT_CONST uint kBindingAccumColour = 2; // w·rgb, w
PNSPLAT_CONST uint kBindingAccumNormal = 3; // w·normal

// One splat: an oriented disk. colour is sRGB, packed as R | G << 8 | B << 16 (alpha unused).
struct Splat {
    vec3 position;
    float radius;
    vec3 normal;
    uint colour;
};

struct FrameUniforms {
    mat4 view;       // world to view space (rigid: rotation and translation only)
    mat4 projection; // view to Vulkan clip space: y down, depth 0 (near) to 1 (far)
    vec4 background; // sRGB as written to the output (no conversion per pixel); a unused
    vec4 viewport;   // width, height, 1 / width, 1 / height in pixels
    // The view-space ray of pixel centre (x, y) is (ndc.x * rayScale.x, -ndc.y * rayScale.y, -1),
    // ndc = 2 (x + 0.5) / size - 1; z = near plane distance, w = unused.
    vec4 rayScale;
    // x: radius scale, y: depth offset ε as a multiple of the splat radius, z: Gaussian
    // sharpness k (w = exp(-k ρ²), ρ the distance from the centre over the radius), w: the heat
    // map's diameter in pixels (RenderSettings::heatMapPx; 0: splats keep their colour).
    vec4 splat;
    // x: 1 to normalize (0 shows the raw accumulated colour: a test switch), y: workgroups of the
    // compute path's splat passes, z: 1 to smooth the outer silhouette (kEdgeWeight), w: 1 to fill
    // pinholes (splat_common.glsl, pinholeIn).
    uvec4 flags;
    // The compute path's pipelines for splats of one colour: that colour, linear RGB (a unused).
    vec4 colour;
    // x, the compute path's normalization tiles across the picture (kTileWidth pixels each); y, the
    // background as written, RGBA8 (backgroundWord in render_passes.h: every background pixel of
    // either path is this one word); z, the tiles in all (the compute path); w unused.
    uvec4 picture;
};

#ifdef __cplusplus
} // namespace pnsplat::gpu
#endif
#undef PNSPLAT_CONST
#endif
