#version 460
#extension GL_GOOGLE_include_directive : require
// Pass 1, graphics path: depth only, fragments outside the disk discarded, depth pushed back by ε.
#include "splat_fragment.glsl"

void main() {
    if (dot(inLocal, inLocal) > 1.0) discard;
    float t = -inViewPos.z;
    gl_FragDepth = windowDepth(pushedDepth(t, inViewPos / t, inRadius));
}
