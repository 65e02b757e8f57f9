#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_ARB_gpu_shader_int64 : require
// Pass 3, compute path: decode the fixed-point sums, divide by the weight and shade; one
// invocation per pair of pixels (main), in large workgroups (lavapipe pays per workgroup). It also
// clears the sums it read for the next frame, so that no frame pays a fill of them: a pixel no
// splat reached costs one 64-bit read and one 32-bit write, and a few reads of the depth where the
// other of its pair has weight (a pinhole's test). (The depth is filled at each frame's start, a
// memset on lavapipe, which costs less than a write per invocation: 1.4 ms less a frame at
// 1280x720.)
#include "splat_common.glsl"

layout(local_size_x = 32, local_size_y = 32) in;

// Every splat has the colour frame.colour (compute_accumulate.comp).
layout(constant_id = 0) const bool kOneColour = false;

layout(set = 0, binding = kBindingDepth, std430) readonly buffer DepthBlock { uint depthBits[]; }; // float bits
layout(set = 0, binding = kBindingAccum, std430) buffer AccumBlock { uint64_t accum[]; };
layout(set = 0, binding = kBindingOutput, std430) writeonly buffer OutputBlock { uint pixels[]; }; // RGBA8

// No splat reached it: the visibility pass left its depth cleared (the accumulation pass adds at
// least the nearest splat's weight wherever it did). The sums cannot tell: the neighbours'
// invocations clear them as they read them.
bool uncoveredAt(ivec2 p) {
    return depthBits[uint(p.y) * uint(frame.viewport.x) + uint(p.x)] == kDepthCleared;
}

vec2 unpack(uint64_t word) {
    return vec2(float(uint(word & 0xFFFFFFFFul)), float(uint(word >> 32))) / kFixedScale;
}

// One pixel's sums, read and cleared: its colour, and its weight (zero: no splat's weight reached
// it, and the colour is the background).
struct Shaded {
    vec3 rgb;
    float w;
};

Shaded shadeAt(ivec2 pixel, uint i) {
    Shaded s = Shaded(frame.background.rgb, 0.0);
    if (kOneColour) {
        // One colour: one word of three fields (w, w·a', w·b'), a' and b' the normal's components
        // across the ray as (a + 1) / 2 (compute_accumulate.comp, packAcrossRay).
        // A zero weight is a background pixel: every field is at most the weight's, so the word is
        // zero but past a carry, and it is cleared whenever it is not.
        uint64_t word = accum[i];
        if (word == 0ul) return s;
        accum[i] = 0ul;
        const uint64_t mask = (1ul << kOneColourBits) - 1ul;
        float w = float(uint(word & mask));
        if (w == 0.0) return s;
        vec2 across = 2.0 * vec2(float(uint((word >> kOneColourBits) & mask)),
                                 float(uint(word >> (2 * kOneColourBits)))) / w - 1.0;
        s.rgb = frame.flags.x == 0u ? linearToSrgb(w / kOneColourScale * frame.colour.rgb)
                                    : shade(frame.colour.rgb, sqrt(max(1.0 - dot(across, across), 0.0)));
        s.w = w / kOneColourScale;
    } else {
        uint base = i * kAccumStride;
        // Every value a splat adds is at most its weight, so a zero (w·b, w) word means all four
        // words are zero: a background pixel, already cleared.
        uint64_t blueWeight = accum[base + 1];
        if (blueWeight == 0ul) return s;
        vec2 rg = unpack(accum[base + 0]), bw = unpack(blueWeight);
        vec2 nxy = unpack(accum[base + 2]), nz = unpack(accum[base + 3]);
        for (uint k = 0; k < kAccumStride; ++k) accum[base + k] = 0ul;
        s.w = bw.y;
        // Σ w·n = 2 Σ w·n' − Σ w.
        vec3 normal = 2.0 * vec3(nxy, nz.x) - s.w;
        s.rgb = shadePixel(vec3(rg, bw.x), normal, s.w, pixelRay(vec2(pixel) + 0.5));
    }
    if (mayBlend(s.w)) s.rgb = smoothEdge(s.rgb, s.w, besideBackground(pixel));
    return s;
}

// Each invocation draws a pair of pixels, (2x, y) and (2x + 1, y). A pinhole (pinholeAt) takes the
// colour of the other pixel of its pair, so that no invocation reads what another writes; a pixel
// of zero weight tests it only where the other of its pair has weight (the smooth silhouette's rim
// pixels test their four neighbours too: besideBackground). A pixel whose depth is set but whose
// weight rounded to zero (a splat's rim with a sharp Gaussian) counts as covered in the test and is
// drawn as background: the other of its pair is not filled from it.
void main() {
    ivec2 first = ivec2(2 * gl_GlobalInvocationID.x, gl_GlobalInvocationID.y);
    if (first.x >= int(frame.viewport.x) || first.y >= int(frame.viewport.y)) return;
    ivec2 second = first + ivec2(1, 0);
    bool pair = second.x < int(frame.viewport.x);
    uint i = uint(first.y) * uint(frame.viewport.x) + uint(first.x);
    Shaded a = shadeAt(first, i);
    Shaded b = pair ? shadeAt(second, i + 1u) : Shaded(frame.background.rgb, 0.0);
    if (a.w == 0.0 && b.w > 0.0 && pinholeAt(first)) a.rgb = b.rgb;
    if (b.w == 0.0 && a.w > 0.0 && pinholeAt(second)) b.rgb = a.rgb;
    pixels[i] = packUnorm4x8(vec4(a.rgb, 1.0));
    if (pair) pixels[i + 1u] = packUnorm4x8(vec4(b.rgb, 1.0));
}
