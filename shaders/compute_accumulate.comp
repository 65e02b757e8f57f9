#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_atomic_float : require
// Pass 2, compute path: every splat not behind the visible surface adds its Gaussian-weighted
// colour, normal and weight to the pixel (float atomicAdd).
#include "splat_compute.glsl"

layout(set = 0, binding = 4, std430) buffer AccumBlock { float accum[]; };

void main() {
    ViewSplat v;
    ivec2 lo, hi;
    if (!invocationSplat(v) || !footprint(v, lo, hi)) return;
    for (int y = lo.y; y <= hi.y; ++y)
        for (int x = lo.x; x <= hi.x; ++x) {
            float t, rho2;
            vec3 ray;
            uint i = pixelIndex(ivec2(x, y));
            if (!intersect(v, ivec2(x, y), t, rho2, ray) || t > uintBitsToFloat(depthBits[i])) continue;
            float w = splatWeight(rho2);
            uint base = i * kAccumStride;
            atomicAdd(accum[base + 0], w * v.colour.r);
            atomicAdd(accum[base + 1], w * v.colour.g);
            atomicAdd(accum[base + 2], w * v.colour.b);
            atomicAdd(accum[base + 3], w * v.normal.x);
            atomicAdd(accum[base + 4], w * v.normal.y);
            atomicAdd(accum[base + 5], w * v.normal.z);
            atomicAdd(accum[base + 6], w);
        }
}
