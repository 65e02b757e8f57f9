#version 460
#extension GL_GOOGLE_include_directive : require
// Pass 3, graphics path: divide by the accumulated weight and shade (the same shading as the
// compute path's normalization).
#include "splat_common.glsl"

layout(set = 0, binding = kBindingAccumColour) uniform sampler2D accumColour; // w·rgb, w
layout(set = 0, binding = kBindingAccumNormal) uniform sampler2D accumNormal; // w·normal

layout(location = 0) out vec4 outColour;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 cw = texelFetch(accumColour, pixel, 0);
    vec3 n = texelFetch(accumNormal, pixel, 0).xyz;
    outColour = vec4(shadePixel(cw.rgb, n, cw.a, pixelRay(gl_FragCoord.xy)), 1.0);
}
