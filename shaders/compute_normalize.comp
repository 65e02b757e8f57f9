#version 460
#extension GL_GOOGLE_include_directive : require
// Pass 3, compute path: divide by the accumulated weight and shade; one invocation per pixel.
#include "splat_common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 4, std430) readonly buffer AccumBlock { float accum[]; };
layout(set = 0, binding = 5, std430) writeonly buffer OutputBlock { uint pixels[]; }; // RGBA8

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (pixel.x >= int(frame.viewport.x) || pixel.y >= int(frame.viewport.y)) return;
    uint i = uint(pixel.y) * uint(frame.viewport.x) + uint(pixel.x);
    uint base = i * kAccumStride;
    vec3 colour = vec3(accum[base + 0], accum[base + 1], accum[base + 2]);
    vec3 normal = vec3(accum[base + 3], accum[base + 4], accum[base + 5]);
    vec3 rgb = shadePixel(colour, normal, accum[base + 6], pixelRay(vec2(pixel) + 0.5));
    pixels[i] = packUnorm4x8(vec4(rgb, 1.0));
}
