#version 460
#extension GL_GOOGLE_include_directive : require
// Pass 2, graphics path: depth test against pass 1 (no depth write), additive blending of
// (w·rgb, w) and (w·normal) into two float targets.
#include "splat_fragment.glsl"

layout(location = 0) out vec4 outColourWeight;
layout(location = 1) out vec4 outNormal;

void main() {
    float rho2 = dot(inLocal, inLocal);
    if (rho2 > 1.0) discard;
    gl_FragDepth = windowDepth(-inViewPos.z);
    float w = splatWeight(rho2);
    outColourWeight = vec4(w * inColour, w);
    outNormal = vec4(w * inNormal, 0.0);
}
