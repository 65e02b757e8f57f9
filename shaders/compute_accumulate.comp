#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_ARB_gpu_shader_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
// Pass 2, compute path: every splat not behind the visible surface adds its Gaussian-weighted
// colour, normal and weight to the pixel, in fixed point with four 64-bit atomicAdds (see
// kAccumStride in gpu_types.h).
#include "splat_compute.glsl"

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
    vec3 colour = linearColour(s, v);
    vec3 n = v.normal * 0.5 + 0.5;
    for (int y = lo.y; y <= hi.y; ++y)
        for (int x = lo.x; x <= hi.x; ++x) {
            float t, rho2;
            vec3 ray;
            uint i = pixelIndex(ivec2(x, y));
            if (!intersect(v, ivec2(x, y), t, rho2, ray) || t > uintBitsToFloat(depthBits[i])) continue;
            float w = splatWeight(rho2);
            uint base = i * kAccumStride;
            atomicAdd(accum[base + 0], pack(w * colour.r, w * colour.g));
            atomicAdd(accum[base + 1], pack(w * colour.b, w));
            atomicAdd(accum[base + 2], pack(w * n.x, w * n.y));
            atomicAdd(accum[base + 3], pack(w * n.z, 0.0));
        }
}
