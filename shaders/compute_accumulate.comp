#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_ARB_gpu_shader_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
// Pass 2, compute path: every splat not behind the visible surface adds its Gaussian-weighted
// colour, normal and weight to the pixel, in fixed point with four 64-bit atomicAdds (see
// kAccumStride in gpu_types.h), or one when every splat has one colour (kOneColour: the renderer
// makes a pipeline of each, and of the normalization, chosen per frame). It reads the visibility
// pass's depth as texels, which lavapipe fetches for all lanes at once (a storage buffer it reads
// one lane at a time: docs/REALTIME.md, "What a frame costs on lavapipe").
#include "splat_compute.glsl"

layout(constant_id = 0) const bool kOneColour = false;

layout(set = 0, binding = kBindingAccum, std430) buffer AccumBlock { uint64_t accum[]; };
layout(set = 0, binding = kBindingDepthTexels) uniform usamplerBuffer depthTexels; // float bits

// Two values in [0, 1] (times the weight) as one 64-bit word of two 32-bit fixed-point halves.
uint64_t pack(float low, float high) {
    return uint64_t(uint(low * kFixedScale + 0.5)) | (uint64_t(uint(high * kFixedScale + 0.5)) << 32);
}

// With one colour, the weight and the normal across the pixel's ray as one word (kOneColourBits a
// field; see gpu_types.h): the normal n in an orthonormal frame (e1, e2, -ray/|ray|) of the ray
// (rx, ry, -1), e1 = (1, 0, rx) / sqrt(1 + rx²) and e2 = ray × e1 / |ray × e1|, its two components
// across the ray stored as (a + 1) / 2 and (b + 1) / 2, times w. The shading needs only the
// interpolated normal's cosine to the eye (splat_common.glsl, shade), sqrt(1 - a² - b²) of the
// averaged a and b.
uint64_t packAcrossRay(float w, vec3 n, float rx, float ry, float invRayLength) {
    float s1 = inversesqrt(1.0 + rx * rx);
    float a = (n.x + rx * n.z) * s1;
    float b = (n.x * rx * ry - n.y * (1.0 + rx * rx) - n.z * ry) * s1 * invRayLength;
    uint fw = uint(w * kOneColourScale + 0.5);
    // Clamped: a normal a rounding longer than 1 must not make a field exceed its weight's.
    uint fa = uint(w * clamp(0.5 * a + 0.5, 0.0, 1.0) * kOneColourScale + 0.5);
    uint fb = uint(w * clamp(0.5 * b + 0.5, 0.0, 1.0) * kOneColourScale + 0.5);
    return uint64_t(fw) | (uint64_t(fa) << kOneColourBits) | (uint64_t(fb) << (2 * kOneColourBits));
}

void main() {
    uint index;
    Splat s;
    ViewSplat v;
    ivec2 lo, hi;
    Walk walk;
    if (!drawnSplat(1u, index, s, v, lo, hi, walk)) return;
    vec3 colour = kOneColour ? vec3(0.0) : linearColour(s, v);
    vec3 n = kOneColour ? v.normal : v.normal * 0.5 + 0.5;
    SplatConic k = conicOf(v);
    for (int j = walk.first; j < walk.count; j += walk.step) {
        int y, x0, x1;
        walkPiece(walk, lo, hi, j, y, x0, x1);
        ConicRow row;
        if (!conicRow(k, y, x0, x1, row)) continue;
        for (int x = x0; x <= x1; ++x) {
            float t, rho2, rx, invRayLength;
            uint i = pixelIndex(ivec2(x, y));
            // Not where the visibility pass left the depth cleared (its pushed depth overflowed): the
            // normalization draws no tile without a depth (compute_normalize.comp, scanTile).
            uint depth = texelFetch(depthTexels, int(i)).x;
            if (!conicHit(k, row, x, t, rho2, rx, invRayLength) || depth == kDepthCleared || t > uintBitsToFloat(depth))
                continue;
            float w = splatWeight(rho2);
            if (kOneColour) {
                atomicAdd(accum[i], packAcrossRay(w, n, rx, row.ry, invRayLength));
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
