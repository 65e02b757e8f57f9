// The C++ side of shaders/gpu_types.h must lay out exactly as GLSL's std430 (Splat) and std140
// (FrameUniforms) do; these checks fail the build otherwise.
#include <cstddef>

#include "gpu_types.h"

namespace pnsplat::gpu {

static_assert(sizeof(Splat) == 32);
static_assert(offsetof(Splat, position) == 0 && offsetof(Splat, radius) == 12);
static_assert(offsetof(Splat, normal) == 16 && offsetof(Splat, colour) == 28);

static_assert(sizeof(FrameUniforms) == 2 * 64 + 7 * 16);
static_assert(offsetof(FrameUniforms, view) == 0 && offsetof(FrameUniforms, projection) == 64);
static_assert(offsetof(FrameUniforms, background) == 128 && offsetof(FrameUniforms, viewport) == 144);
static_assert(offsetof(FrameUniforms, rayScale) == 160 && offsetof(FrameUniforms, splat) == 176);
static_assert(offsetof(FrameUniforms, flags) == 192 && offsetof(FrameUniforms, colour) == 208);
static_assert(offsetof(FrameUniforms, picture) == 224);

} // namespace pnsplat::gpu
