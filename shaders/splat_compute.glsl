// The compute path (ALGORITHM.md §11.5, with atomics instead of the raster pipeline): one invocation per
// splat walks the pixels of its screen footprint. Workgroup (x, y) covers splats
// [x·kLocalSize, (x+1)·kLocalSize) of the y-th visible node.
#include "splat_common.glsl"

layout(local_size_x = kLocalSize) in;

layout(set = 0, binding = 2, std430) readonly buffer ItemBlock { uvec2 items[]; }; // first, count
layout(set = 0, binding = 3, std430) buffer DepthBlock { uint depthBits[]; };         // float bits

// The index of this invocation's splat, or false when the node has no splat for it.
bool invocationSplat(out uint index) {
    uint item = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    if (item >= frame.flags.y) return false;
    uvec2 range = items[item];
    index = range.x + gl_LocalInvocationID.x;
    return gl_LocalInvocationID.x < range.y;
}

// The pixels whose centres may see the disk: the screen box of the projected corners of its
// bounding square (a planar square in front of the eye projects to a convex quadrilateral that
// contains the projected disk). False when the box is empty or a corner is not beyond the near
// plane (such splats are skipped; the graphics path clips them instead).
bool footprint(ViewSplat v, out ivec2 lo, out ivec2 hi) {
    vec3 u = tangentOf(v.normal) * v.radius;
    vec3 w = cross(v.normal, u);
    vec2 low = vec2(3.0e38), high = vec2(-3.0e38);
    for (int k = 0; k < 4; ++k) {
        vec3 p = v.centre + ((k & 1) != 0 ? u : -u) + ((k & 2) != 0 ? w : -w);
        if (-p.z < frame.rayScale.z) return false;
        vec2 ndc = vec2(p.x / (-p.z * frame.rayScale.x), -p.y / (-p.z * frame.rayScale.y));
        vec2 pixel = (ndc * 0.5 + 0.5) * frame.viewport.xy;
        low = min(low, pixel);
        high = max(high, pixel);
    }
    lo = ivec2(max(ceil(low - 0.5), vec2(0.0)));
    hi = ivec2(min(floor(high - 0.5), frame.viewport.xy - 1.0));
    return lo.x <= hi.x && lo.y <= hi.y;
}

// Ray–disk intersection at a pixel: linear depth t, squared normalized distance rho2 from the
// centre, and the pixel's ray. False when the ray misses the disk.
bool intersect(ViewSplat v, ivec2 pixel, out float t, out float rho2, out vec3 ray) {
    ray = pixelRay(vec2(pixel) + 0.5);
    float dn = dot(v.normal, ray);
    if (dn >= 0.0) return false;
    t = dot(v.normal, v.centre) / dn;
    vec3 q = t * ray - v.centre;
    rho2 = dot(q, q) / (v.radius * v.radius);
    return rho2 <= 1.0;
}

uint pixelIndex(ivec2 pixel) {
    return uint(pixel.y) * uint(frame.viewport.x) + uint(pixel.x);
}
