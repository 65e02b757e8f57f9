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
    // The pair (2x, y), (2x + 1, y) that the compute path draws in one invocation.
    ivec2 first = ivec2(pixel.x & ~1, pixel.y);
    int dx = pixel.x & 1;
    uint near = uncoveredNear(first);
    // A pinhole is drawn as the other pixel of its pair, as on the compute path.
    if (pinholeIn(near, first, dx, 0)) {
        dx ^= 1;
        pixel.x ^= 1;
        centre.x = float(pixel.x) + 0.5;
    }
    vec4 cw = texelFetch(accumColour, pixel, 0);
    vec3 n = texelFetch(accumNormal, pixel, 0).xyz;
    vec3 rgb = shadePixel(cw.rgb, n, cw.a, pixelRay(centre));
    if (mayBlend(cw.a)) rgb = smoothEdge(rgb, cw.a, besideBackgroundIn(near, first, dx));
    // Background is the compute path's word (backgroundWord): k / 255 converts back to k under
    // any rounding, where the background itself may round either way on a half.
    outColour = cw.a > 0.0 ? vec4(rgb, 1.0) : unpackUnorm4x8(frame.picture.y);
}
