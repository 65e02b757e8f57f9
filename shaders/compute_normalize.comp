#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_ARB_gpu_shader_int64 : require
// Pass 3, compute path: decode the fixed-point sums, divide by the weight and shade; one
// invocation per pixel, in large workgroups (lavapipe pays per workgroup). It also clears the
// depth and the sums for the next frame, so no frame pays a full-screen fill: a pixel no splat
// reached costs one 64-bit read and two 32-bit writes.
#include "splat_common.glsl"

layout(local_size_x = 32, local_size_y = 32) in;

layout(set = 0, binding = 3, std430) writeonly buffer DepthBlock { uint depthBits[]; };
layout(set = 0, binding = 4, std430) buffer AccumBlock { uint64_t accum[]; };
layout(set = 0, binding = 5, std430) writeonly buffer OutputBlock { uint pixels[]; }; // RGBA8

vec2 unpack(uint64_t word) {
    return vec2(float(uint(word & 0xFFFFFFFFul)), float(uint(word >> 32))) / kFixedScale;
}

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (pixel.x >= int(frame.viewport.x) || pixel.y >= int(frame.viewport.y)) return;
    uint i = uint(pixel.y) * uint(frame.viewport.x) + uint(pixel.x);
    bool oneColour = frame.flags.z != 0u;
    uint stride = oneColour ? kOneColourStride : kAccumStride;
    uint base = i * stride;
    // The visibility pass may have set the depth of a pixel whose rounded weight is still zero.
    depthBits[i] = kDepthCleared;
    // Every value a splat adds is at most its weight, so a zero second word ((w·b, w), or (w·n'z, w)
    // with one colour) means all the pixel's words are zero: a background pixel, already cleared.
    uint64_t weightWord = accum[base + 1];
    if (weightWord == 0ul) {
        pixels[i] = packUnorm4x8(vec4(frame.background.rgb, 1.0));
        return;
    }
    float w;
    vec3 sumColour, sumNormal; // Σ w·rgb; Σ w·n' (n' = (n + 1) / 2)
    if (oneColour) {
        vec2 nxy = unpack(accum[base + 0]), nzw = unpack(weightWord);
        w = nzw.y;
        sumColour = w * srgbToLinear(unpackUnorm4x8(frame.flags.w).rgb);
        sumNormal = vec3(nxy, nzw.x);
    } else {
        vec2 rg = unpack(accum[base + 0]), bw = unpack(weightWord);
        vec2 nxy = unpack(accum[base + 2]), nz = unpack(accum[base + 3]);
        w = bw.y;
        sumColour = vec3(rg, bw.x);
        sumNormal = vec3(nxy, nz.x);
    }
    for (uint k = 0; k < stride; ++k) accum[base + k] = 0ul;
    // Σ w·n = 2 Σ w·n' − Σ w.
    vec3 rgb = shadePixel(sumColour, 2.0 * sumNormal - w, w, pixelRay(vec2(pixel) + 0.5));
    pixels[i] = packUnorm4x8(vec4(rgb, 1.0));
}
