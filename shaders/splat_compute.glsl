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

// The pixels whose centres may see the disk: the screen box of the projected corners of the disk's
// axis-aligned bounding box in view space (half-extents r·sqrt(1 - n_i²); x/(-z) and y/(-z) are
// monotone in each coordinate, so their extremes lie at the box's corners). Tighter than the box of
// any bounding square (up to 2 times less area for a disk seen obliquely), so fewer pixels are
// tested; the same pixels pass. False when the box is empty or reaches the near plane (such splats are
// skipped; the graphics path clips them instead).
bool footprint(ViewSplat v, out ivec2 lo, out ivec2 hi) {
    vec3 e = v.radius * sqrt(max(1.0 - v.normal * v.normal, 0.0));
    float nearest = -(v.centre.z + e.z), farthest = -(v.centre.z - e.z);
    if (nearest < frame.rayScale.z) return false;
    // Screen x grows with x / depth and y shrinks with y / depth; each extreme is at the nearest or
    // the farthest depth of the box.
    vec2 scale = 0.5 * frame.viewport.xy / frame.rayScale.xy;
    vec2 a = v.centre.xy - e.xy, b = v.centre.xy + e.xy;
    vec2 low = min(a / nearest, a / farthest), high = max(b / nearest, b / farthest);
    vec2 centre = 0.5 * frame.viewport.xy;
    vec2 pixelLow = vec2(centre.x + low.x * scale.x, centre.y - high.y * scale.y);
    vec2 pixelHigh = vec2(centre.x + high.x * scale.x, centre.y - low.y * scale.y);
    lo = ivec2(max(ceil(pixelLow - 0.5), vec2(0.0)));
    hi = ivec2(min(floor(pixelHigh - 0.5), frame.viewport.xy - 1.0));
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
