#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_ARB_gpu_shader_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
// Pass 2, compute path: every splat not behind the visible surface adds its Gaussian-weighted
// colour, normal and weight to the pixel, in fixed point with four 64-bit atomicAdds (see
// kAccumStride in gpu_types.h), or two when every splat has one colour (kOneColour: the renderer
// makes a pipeline of each, chosen per frame with the uniforms' flags.z).
#include "splat_compute.glsl"

layout(constant_id = 0) const bool kOneColour = false;

layout(set = 0, binding = 4, std430) buffer AccumBlock { uint64_t accum[]; };

// Two values in [0, 1] (times the weight) as one 64-bit word of two 32-bit fixed-point halves.
uint64_t pack(float low, float high) {
    return uint64_t(uint(low * kFixedScale + 0.5)) | (uint64_t(uint(high * kFixedScale + 0.5)) << 32);
}

void main() {
    uint index;
    if (!invocationSplat(index)) return;
    Splat s = splats[index];
    ViewSplat v = toView(s);
    ivec2 lo, hi;
    if (!frontFacing(v) || !footprint(v, lo, hi)) return;
    vec3 colour = kOneColour ? vec3(0.0) : linearColour(s, v);
    vec3 n = v.normal * 0.5 + 0.5;
    SplatConic k = conicOf(v);
    for (int y = lo.y; y <= hi.y; ++y) {
        int x0 = lo.x, x1 = hi.x;
        ConicRow row;
        if (!conicRow(k, y, x0, x1, row)) continue;
        for (int x = x0; x <= x1; ++x) {
            float t, rho2, invRayLength;
            uint i = pixelIndex(ivec2(x, y));
            if (!conicHit(k, row, x, t, rho2, invRayLength) || t > uintBitsToFloat(depthBits[i])) continue;
            float w = splatWeight(rho2);
            if (kOneColour) {
                uint base = i * kOneColourStride;
                atomicAdd(accum[base + 0], pack(w * n.x, w * n.y));
                atomicAdd(accum[base + 1], pack(w * n.z, w));
            } else {
                uint base = i * kAccumStride;
                atomicAdd(accum[base + 0], pack(w * colour.r, w * colour.g));
                atomicAdd(accum[base + 1], pack(w * colour.b, w));
                atomicAdd(accum[base + 2], pack(w * n.x, w * n.y));
                atomicAdd(accum[base + 3], pack(w * n.z, 0.0));
            }
        }
    }
}
