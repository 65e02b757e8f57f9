#version 460
#extension GL_GOOGLE_include_directive : require
// Pass 1, compute path: the nearest depth per pixel, pushed back by ε (atomicMin on the bits of a
// positive float orders like the float). A plain read first skips the atomic (a compare-and-swap
// loop on CPUs) wherever the pixel already holds a nearer depth.
#include "splat_compute.glsl"

void main() {
    uint index;
    if (!invocationSplat(index)) return;
    ViewSplat v = toView(splats[index]);
    ivec2 lo, hi;
    if (!frontFacing(v) || !footprint(v, lo, hi)) return;
    for (int y = lo.y; y <= hi.y; ++y)
        for (int x = lo.x; x <= hi.x; ++x) {
            float t, rho2;
            vec3 ray;
            if (!intersect(v, ivec2(x, y), t, rho2, ray)) continue;
            uint i = pixelIndex(ivec2(x, y));
            uint depth = floatBitsToUint(pushedDepth(t, ray, v.radius));
            if (depth < depthBits[i]) atomicMin(depthBits[i], depth);
        }
}
