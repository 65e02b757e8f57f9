#version 460
#extension GL_GOOGLE_include_directive : require
// Pass 1, compute path: the nearest depth per pixel, pushed back by ε (atomicMin on the bits of a
// positive float orders like the float).
#include "splat_compute.glsl"

void main() {
    ViewSplat v;
    ivec2 lo, hi;
    if (!invocationSplat(v) || !footprint(v, lo, hi)) return;
    for (int y = lo.y; y <= hi.y; ++y)
        for (int x = lo.x; x <= hi.x; ++x) {
            float t, rho2;
            vec3 ray;
            if (intersect(v, ivec2(x, y), t, rho2, ray))
                atomicMin(depthBits[pixelIndex(ivec2(x, y))], floatBitsToUint(pushedDepth(t, ray, v.radius)));
        }
}
