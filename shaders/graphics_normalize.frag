#version 460
#extension GL_GOOGLE_include_directive : require
// Pass 3, graphics path: divide by the accumulated weight and shade (the same shading as the
// compute path's normalization).
#include "splat_common.glsl"

layout(set = 0, binding = kBindingAccumColour) uniform sampler2D accumColour; // w·rgb, w
layout(set = 0, binding = kBindingAccumNormal) uniform sampler2D accumNormal; // w·normal

layout(location = 0) out vec4 outColour;

// No splat reached it: its weight is zero.
bool uncoveredAt(ivec2 p) {
    return !(texelFetch(accumColour, p, 0).a > 0.0);
}

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec2 centre = gl_FragCoord.xy;
    vec4 cw = texelFetch(accumColour, pixel, 0);
    vec3 n = texelFetch(accumNormal, pixel, 0).xyz;
    // A pinhole is drawn as the other pixel of its pair, (2x, y) and (2x + 1, y), as on the compute
    // path; a pixel of zero weight beside one of none is background, with one read.
    ivec2 other = ivec2(pixel.x ^ 1, pixel.y);
    if (frame.flags.w != 0u && !(cw.a > 0.0) && other.x < int(frame.viewport.x) && !uncoveredAt(other) &&
        pinholeAt(pixel)) {
        pixel = other;
        centre.x = float(other.x) + 0.5;
        cw = texelFetch(accumColour, pixel, 0);
        n = texelFetch(accumNormal, pixel, 0).xyz;
    }
    vec3 rgb = shadePixel(cw.rgb, n, cw.a, pixelRay(centre));
    if (cw.a > 0.0 && mayBlend(cw.a)) rgb = smoothEdge(rgb, cw.a, besideBackground(pixel));
    outColour = vec4(rgb, 1.0);
}
