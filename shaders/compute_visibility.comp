#version 460
#extension GL_GOOGLE_include_directive : require
// Pass 1, compute path: the nearest depth per pixel, pushed back by ε (atomicMin on the bits of a
// positive float orders like the float). No plain read first to skip the atomic where the pixel
// already holds a nearer depth: on lavapipe, which reads a storage buffer one lane at a time, the
// read cost more than the atomics it saved (docs/REALTIME.md, "What a frame costs on lavapipe").
#include "splat_compute.glsl"

layout(set = 0, binding = kBindingDepth, std430) buffer DepthBlock { uint depthBits[]; }; // float bits

void main() {
    uint index;
    Splat s;
    ViewSplat v;
    ivec2 lo, hi;
    Walk walk;
    if (!drawnSplat(0u, index, s, v, lo, hi, walk)) return;
    SplatConic k = conicOf(v);
    for (int j = walk.first; j < walk.count; j += walk.step) {
        int y, x0, x1;
        walkPiece(walk, lo, hi, j, y, x0, x1);
        ConicRow row;
        if (!conicRow(k, y, x0, x1, row)) continue;
        for (int x = x0; x <= x1; ++x) {
            float t, rho2, rx, invRayLength;
            if (!conicHit(k, row, x, t, rho2, rx, invRayLength)) continue;
            uint i = pixelIndex(ivec2(x, y));
            uint depth = floatBitsToUint(pushedDepthOver(t, invRayLength, v.radius));
            atomicMin(depthBits[i], depth);
        }
    }
}
