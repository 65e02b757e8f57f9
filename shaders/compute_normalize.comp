#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_ARB_gpu_shader_int64 : require
// Pass 3, compute path: decode the fixed-point sums, divide by the weight and shade; one
// invocation per pixel, in large workgroups (lavapipe pays per workgroup).
#include "splat_common.glsl"

layout(local_size_x = 32, local_size_y = 32) in;

layout(set = 0, binding = 4, std430) readonly buffer AccumBlock { uint64_t accum[]; };
layout(set = 0, binding = 5, std430) writeonly buffer OutputBlock { uint pixels[]; }; // RGBA8

vec2 unpack(uint64_t word) {
    return vec2(float(uint(word & 0xFFFFFFFFul)), float(uint(word >> 32))) / kFixedScale;
}

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (pixel.x >= int(frame.viewport.x) || pixel.y >= int(frame.viewport.y)) return;
    uint i = uint(pixel.y) * uint(frame.viewport.x) + uint(pixel.x);
    uint base = i * kAccumStride;
    vec2 rg = unpack(accum[base + 0]), bw = unpack(accum[base + 1]);
    vec2 nxy = unpack(accum[base + 2]), nz = unpack(accum[base + 3]);
    float w = bw.y;
    // Σ w·n = 2 Σ w·n' − Σ w.
    vec3 normal = 2.0 * vec3(nxy, nz.x) - w;
    vec3 rgb = shadePixel(vec3(rg, bw.x), normal, w, pixelRay(vec2(pixel) + 0.5));
    pixels[i] = packUnorm4x8(vec4(rgb, 1.0));
}
