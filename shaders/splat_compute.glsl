// The compute path (ALGORITHM.md §11.5, with atomics instead of the raster pipeline): one invocation per
// splat walks the pixels of its screen footprint. A workgroup draws up to kGroupRanges ranges of the
// splats drawn (runs of a chunk's facing classes), kLocalSize splats in all, its invocations the
// ranges' splats in order; a splat too large for one invocation is listed and drawn by workgroups
// of its own in a second dispatch (drawnSplat).
#include "splat_common.glsl"

layout(local_size_x = kLocalSize, local_size_x_id = 4) in; // kBigSplatGroup with kBigSplats

// The dispatch that draws the big splats a pass listed (gpu_types.h, kBigSplatPixels); constant
// ids 0 to 2 are the passes' own.
layout(constant_id = 3) const bool kBigSplats = false;

// The tiles' buffer (gpu_types.h, kBindingTiles) as words: after the normalization's tiles, at
// bigSplatsAt(), the passes' two indirect dispatches and their two lists.
layout(set = 0, binding = kBindingTiles, std430) buffer BigSplatBlock { uint tileWords[]; };
uint bigSplatsAt() {
    return 3u + 2u * frame.picture.z;
}

// Per workgroup (its first range, its ranges), then the ranges (first splat, count): texels, which
// lavapipe fetches for all lanes at once (splat_common.glsl, splatAt).
layout(set = 0, binding = kBindingItems) uniform usamplerBuffer itemTexels;
uvec2 item(uint k) {
    return texelFetch(itemTexels, int(k)).xy;
}

// The index of this invocation's splat, or false when its workgroup has no splat for it. The loop
// reads the same ranges in every invocation.
bool invocationSplat(out uint index) {
    uint workgroup = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    if (workgroup >= frame.flags.y) return false;
    uvec2 group = item(workgroup);
    uint local = gl_LocalInvocationID.x, offset = 0u;
    bool found = false;
    for (uint k = 0u; k < group.y; ++k) {
        uvec2 range = item(group.x + k);
        if (!found && local < offset + range.y) {
            index = range.x + local - offset;
            found = true;
        }
        offset += range.y;
    }
    return found;
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

// The pixels an invocation walks: pieces first, first + step, ... below count, a piece a row of
// the footprint, or in the big splats' dispatch a row's run of at most kBigSplatRun pixels (piece j:
// row lo.y + j / runs, columns from lo.x + (j % runs) · kBigSplatRun).
struct Walk {
    int first, step, count, runs;
};

// Piece j of `walk`: its row and columns [x0, x1] within the footprint [lo, hi].
void walkPiece(Walk walk, ivec2 lo, ivec2 hi, int j, out int y, out int x0, out int x1) {
    if (kBigSplats) {
        y = lo.y + j / walk.runs;
        x0 = lo.x + (j % walk.runs) * int(kBigSplatRun);
        x1 = min(x0 + int(kBigSplatRun) - 1, hi.x);
    } else {
        y = lo.y + j;
        x0 = lo.x;
        x1 = hi.x;
    }
}

// The splat this invocation draws (its index, as stored and in view space), the pixels of its
// footprint (footprint below) and the pieces of them it walks. In a pass's first dispatch, a splat
// an invocation and all of it; a splat whose footprint's box holds more than kBigSplatPixels pixels
// is listed instead, in the list of `pass` (0 visibility, 1 accumulation), while it has room. With
// kBigSplats, the dispatch of that list: a splat a column of workgroups (x the splat, y a part),
// its runs shared out among their invocations. Either way each splat is drawn once in each pass.
bool drawnSplat(uint pass, out uint index, out Splat s, out ViewSplat v, out ivec2 lo, out ivec2 hi,
                out Walk walk) {
    uint at = bigSplatsAt(), count = at + 4u * pass, list = at + 8u + kBigSplatCapacity * pass;
    if (kBigSplats) {
        index = tileWords[list + gl_WorkGroupID.x];
    } else if (!invocationSplat(index)) {
        return false;
    }
    s = splatAt(index);
    v = toView(s);
    if (!frontFacing(v) || !footprint(v, lo, hi)) return false;
    ivec2 size = hi - lo + 1;
    if (kBigSplats) {
        walk.runs = (size.x + int(kBigSplatRun) - 1) / int(kBigSplatRun);
        walk.first = int(gl_WorkGroupID.y * gl_WorkGroupSize.x + gl_LocalInvocationID.x);
        walk.step = int(gl_NumWorkGroups.y * gl_WorkGroupSize.x);
        walk.count = size.y * walk.runs;
        return walk.first < walk.count;
    }
    walk = Walk(0, 1, size.y, 1);
    if (size.x * size.y <= int(kBigSplatPixels)) return true;
    uint k = atomicAdd(tileWords[count], 1u);
    if (k < kBigSplatCapacity) {
        tileWords[list + k] = index;
        return false;
    }
    atomicAdd(tileWords[count], 0xFFFFFFFFu); // the list is full: drawn here, the count kept at it
    return true;
}

// The disk seen through the pixels (ALGORITHM.md §11.2), set up once per splat so that each pixel
// costs a few multiply-adds, one division and one inverse square root. With c' = c / -c.z (the
// centre scaled onto the plane z = -1), K' = n·c' and pixel offsets (u, v) from the projected centre,
// the ray through a pixel is c' + (hx·u, -hy·v, 0), and n·ray = dn(u, v) = K' + n.x·hx·u - n.y·hy·v
// is linear. The hit point's offset from the centre, times dn, is P = K'·ray - dn·c', also linear
// in (u, v) and zero at the centre: P = u·Pu + v·Pv, so
//     rho² · r'² · dn² = |P|²      (r' = r / -c.z),
// and the hit's depth is t = -c.z · K' / dn. Each row's pixels inside the disk (|P|² <= r'² dn²)
// are the roots of a quadratic in u: only those are visited, not the whole box. |P|² is taken as
// the square of the vector, not as the quadratic form a·u² + 2b·u·v + c·v², whose terms cancel to
// within 2 % of its value for a disk seen nearly edge-on. Everything is scale-free (a model in
// kilometres or microns gives the same numbers).
struct SplatConic {
    vec2 centre;   // the projected centre, pixels
    vec3 pu, pv;   // Pu, Pv
    vec3 plane;    // K', n.x·hx, -n.y·hy: dn = plane.x + plane.y·u + plane.z·v
    float r2;      // r'²
    float depth;   // -c.z
    vec2 ray;      // c'.xy
    vec2 step;     // hx, hy: the ray's change per pixel
};

SplatConic conicOf(ViewSplat v) {
    SplatConic k;
    k.depth = -v.centre.z;
    vec3 c = v.centre / k.depth;
    k.ray = c.xy;
    k.step = 2.0 * frame.rayScale.xy * frame.viewport.zw;
    k.centre = vec2((c.x / frame.rayScale.x + 1.0) * 0.5 * frame.viewport.x,
                    (1.0 - c.y / frame.rayScale.y) * 0.5 * frame.viewport.y);
    float kk = dot(v.normal, c);
    k.pu = k.step.x * (vec3(kk, 0.0, 0.0) - v.normal.x * c);
    k.pv = -k.step.y * (vec3(0.0, kk, 0.0) - v.normal.y * c);
    k.plane = vec3(kk, v.normal.x * k.step.x, -v.normal.y * k.step.y);
    float r = v.radius / k.depth;
    k.r2 = r * r;
    return k;
}

// One row y of the box [x0, x1]: narrows [x0, x1] to the pixels whose centres may lie in the disk
// (false when none do). The quadratic A u² + 2 B u + C <= 0 (|P|² - r'² dn² <= 0) has
//     B² - A·C = r'² |dn0·Pu - du·v·Pv|² - v² |Pu × Pv|²
// (dn0 = dn at u = 0, du = n.x·hx; Lagrange's identity), a difference of two squared norms, each
// exact to a few roundings; near the ellipse's tips the two cancel, so the span is widened by what
// their rounding may hide (a millionth of their sum) and by a hundredth of a pixel, and a row is
// dropped only when the difference is clearly negative. Each pixel of the span is still tested by
// conicHit, which decides at the rim.
struct ConicRow {
    float dn0; // dn at u = 0
    vec3 pv;   // v·Pv
    float ry;  // the ray's y (its z is -1)
    float ry2; // the ray's y² + z²
};

bool conicRow(SplatConic k, int y, inout int x0, inout int x1, out ConicRow row) {
    float v = float(y) + 0.5 - k.centre.y; // the row's offset from the centre
    row.dn0 = k.plane.x + k.plane.z * v;
    row.pv = v * k.pv;
    row.ry = k.ray.y - k.step.y * v;
    row.ry2 = row.ry * row.ry + 1.0;
    float du = k.plane.y;
    float a = dot(k.pu, k.pu) - k.r2 * du * du;
    if (!(a > 0.0)) return true; // not an ellipse in u (rounding, or nearly edge-on): test the box row
    float b = dot(k.pu, row.pv) - k.r2 * du * row.dn0;
    vec3 across = row.dn0 * k.pu - du * row.pv;
    vec3 normal = cross(k.pu, row.pv);
    float inside = k.r2 * dot(across, across), outside = dot(normal, normal);
    float tolerance = 1e-6 * (inside + outside);
    float disc = inside - outside;
    if (disc < -tolerance) return false;
    float s = sqrt(max(disc, 0.0) + tolerance) / a + 0.01;
    float mid = -b / a;
    // Clamped as floats: a nearly degenerate quadratic has roots far beyond the box, which would
    // not convert to int.
    x0 = int(max(float(x0), ceil(k.centre.x + mid - s - 0.5)));
    x1 = int(min(float(x1), floor(k.centre.x + mid + s - 0.5)));
    return x0 <= x1;
}

// The pixel x of a row: the hit's linear depth t, its squared normalized distance rho2 from the
// centre, the ray's x (the ray is (rx, row.ry, -1)) and 1 / |ray|; false when the ray misses the
// disk.
bool conicHit(SplatConic k, ConicRow row, int x, out float t, out float rho2, out float rx,
              out float invRayLength) {
    float u = float(x) + 0.5 - k.centre.x;
    float dn = row.dn0 + k.plane.y * u;
    if (dn >= 0.0) return false;
    float inv = 1.0 / dn;
    vec3 p = row.pv + u * k.pu;
    rho2 = dot(p, p) * (inv * inv / k.r2);
    rx = k.ray.x + k.step.x * u;
    invRayLength = inversesqrt(rx * rx + row.ry2);
    t = k.depth * k.plane.x * inv;
    return rho2 <= 1.0;
}

uint pixelIndex(ivec2 pixel) {
    return uint(pixel.y) * uint(frame.viewport.x) + uint(pixel.x);
}
