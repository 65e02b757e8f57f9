#version 460
#extension GL_GOOGLE_include_directive : require
// Pass 3, graphics path: divide by the accumulated weight and shade (the same shading as the
// compute path's normalization).
#include "splat_common.glsl"

layout(set = 0, binding = kBindingAccumColour) uniform sampler2D accumColour; // w·rgb, w
layout(set = 0, binding = kBindingAccumNormal) uniform sampler2D accumNormal; // w·normal

layout(location = 0) out vec4 outColour;

// Whether a 4-neighbour of the pixel is background: no splat reached it (weight 0).
bool besideBackground(ivec2 pixel) {
    const ivec2 size = ivec2(frame.viewport.xy);
    const ivec2 steps[4] = ivec2[4](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));
    for (int k = 0; k < 4; ++k) {
        ivec2 p = pixel + steps[k];
        if (all(greaterThanEqual(p, ivec2(0))) && all(lessThan(p, size)) && !(texelFetch(accumColour, p, 0).a > 0.0))
            return true;
    }
    return false;
}

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 cw = texelFetch(accumColour, pixel, 0);
    vec3 n = texelFetch(accumNormal, pixel, 0).xyz;
    vec3 rgb = shadePixel(cw.rgb, n, cw.a, pixelRay(gl_FragCoord.xy));
    if (cw.a > 0.0 && mayBlend(cw.a)) rgb = smoothEdge(rgb, cw.a, besideBackground(pixel));
    outColour = vec4(rgb, 1.0);
}
