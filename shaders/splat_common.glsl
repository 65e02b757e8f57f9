// Splat geometry and shading shared by the compute path and the graphics path, so that the two
// paths differ only in how footprints reach pixels (ALGORITHM.md §11).
#include "gpu_types.h"

layout(set = 0, binding = kBindingFrame, std140) uniform FrameBlock { FrameUniforms frame; };
// The cache's splats: gpu::Splat's 32 bytes as two RGBA32UI texels. A texel buffer, not a storage
// buffer: lavapipe fetches texels in SIMD lanes, but reads a storage buffer at a different address
// in each lane one lane and one word at a time (docs/REALTIME.md, "What a frame costs on lavapipe").
layout(set = 0, binding = kBindingSplats) uniform usamplerBuffer splatTexels;

Splat splatAt(uint index) {
    uvec4 a = texelFetch(splatTexels, int(2u * index));
    uvec4 b = texelFetch(splatTexels, int(2u * index + 1u));
    Splat s;
    s.position = uintBitsToFloat(a.xyz);
    s.radius = uintBitsToFloat(a.w);
    s.normal = uintBitsToFloat(b.xyz);
    s.colour = b.w;
    return s;
}

// A splat in view space: centre, unit normal, radius (after the radius scale).
struct ViewSplat {
    vec3 centre;
    vec3 normal;
    float radius;
};

vec3 srgbToLinear(vec3 c) {
    return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), greaterThan(c, vec3(0.04045)));
}

vec3 linearToSrgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, greaterThan(c, vec3(0.0031308)));
}

ViewSplat toView(Splat s) {
    ViewSplat v;
    v.centre = (frame.view * vec4(s.position, 1.0)).xyz;
    v.normal = mat3(frame.view) * s.normal;
    v.radius = s.radius * frame.splat.x;
    return v;
}

// The heat map of splat size (RenderSettings::heatMapPx): the colour, in sRGB, of a splat whose
// projected diameter is `ratio` times the heat map's diameter. Below it, blue (a quarter or less)
// through cyan to green; above it, yellow through orange to red (four times or more): the jump from
// green to yellow marks the threshold.
vec3 heatColour(float ratio) {
    float x = clamp(0.25 * log2(ratio) + 0.5, 0.0, 1.0);
    return x < 0.5 ? mix(vec3(0.1, 0.25, 0.95), vec3(0.1, 0.8, 0.35), 2.0 * x)
                   : mix(vec3(1.0, 0.85, 0.1), vec3(0.9, 0.1, 0.1), 2.0 * x - 1.0);
}

// A splat's colour in linear RGB (only the accumulation pass needs it): its own, or with the heat
// map its projected diameter's (2 r f / depth, f = height / (2 tan(fovY / 2)) pixels, as the
// engine measures splats, engine.h FrameReport::maxSplatPx).
vec3 linearColour(Splat s, ViewSplat v) {
    if (frame.splat.w > 0.0) {
        float focal = frame.viewport.y / (2.0 * frame.rayScale.y);
        float diameter = 2.0 * v.radius * focal / max(-v.centre.z, frame.rayScale.z);
        return srgbToLinear(heatColour(diameter / frame.splat.w));
    }
    return srgbToLinear(unpackUnorm4x8(s.colour).rgb);
}

// Splats seen edge-on or from behind are skipped (one-sided splats: normals face outwards).
bool frontFacing(ViewSplat v) {
    return dot(v.normal, v.centre) < 0.0;
}

// Any unit vector orthogonal to n, chosen continuously enough that the disk's bounding square is
// well defined; the second axis is cross(n, u).
vec3 tangentOf(vec3 n) {
    vec3 a = abs(n.x) < 0.6 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0);
    return normalize(cross(n, a));
}

// The view-space ray through the centre of pixel p (not normalized; its z is -1, so the ray
// parameter of a point is its linear depth).
vec3 pixelRay(vec2 pixelCentre) {
    vec2 ndc = pixelCentre * frame.viewport.zw * 2.0 - 1.0;
    return vec3(ndc.x * frame.rayScale.x, -ndc.y * frame.rayScale.y, -1.0);
}

// Linear depth pushed back along the view ray by ε·radius (the visibility pass's offset): a point
// at depth t on ray d moves to t + ε r / |d|.
float pushedDepth(float t, vec3 ray, float radius) {
    return t + frame.splat.y * radius / length(ray);
}

// The same push where 1 / |d| is known (the compute path's conicHit gives it).
float pushedDepthOver(float t, float invRayLength, float radius) {
    return t + frame.splat.y * radius * invRayLength;
}

// Gaussian weight at squared normalized distance rho2 from the centre (rho2 <= 1 inside the disk).
float splatWeight(float rho2) {
    return exp(-frame.splat.z * rho2);
}

// Headlight Blinn–Phong: the light sits at the eye, so the half vector is the view vector and the
// shading needs only the cosine ndl of the interpolated normal to the eye. Returns the linear
// colour; the callers encode it to sRGB once, whether shaded or not (lavapipe would run an encoding
// in each branch, as the note at uncoveredNear below says).
vec3 shade(vec3 albedo, float ndl) {
    float ndl2 = ndl * ndl, ndl4 = ndl2 * ndl2, ndl16 = ndl4 * ndl4 * ndl4 * ndl4;
    float specular = 0.25 * ndl16 * ndl16 * ndl16; // 0.25 ndl^48
    return albedo * (0.12 + 0.88 * ndl) + vec3(specular);
}

// A pixel of the outer silhouette blends toward the background by its accumulated weight: a pixel
// that only the rims of splats reach is covered in part (kEdgeWeight in gpu_types.h; a splat's own
// weight is 1 at its centre and exp(-k) at its rim). Only beside the background: inside the picture
// a low weight is the edge of a nearer surface over a farther one, which the passes do not keep.
vec3 smoothEdge(vec3 rgb, float sumWeight, bool besideBackground) {
    return besideBackground ? mix(frame.background.rgb, rgb, sumWeight / kEdgeWeight) : rgb;
}

// Whether a pixel's colour may blend toward the background (smoothEdge): the option is on and its
// weight above zero (a pixel of zero weight shows the background already) and below kEdgeWeight.
bool mayBlend(float sumWeight) {
    return frame.flags.z != 0u && sumWeight > 0.0 && sumWeight < kEdgeWeight;
}

// Whether no splat reached pixel p, inside the picture: each path's normalization says how it knows.
bool uncoveredAt(ivec2 p);

// The pinhole and silhouette tests below read the pixels within two steps (left, right, up, down)
// of either pixel of a pair (2x, y) and (2x + 1, y): 18 pixels, read once per pair into the bits of
// a window of kNearWidth by 5 pixels from (2x - 2, y - 2), a bit set where the pixel lies in the
// picture and no splat reached it. Read once, not where each test needs them: lavapipe runs every
// branch of a shader on all of its lanes (a branch only masks lanes off), so the tests written per
// pixel read the depth about 60 times a pair wherever no lane needed them, and the compute path's
// normalization took 8 ms of a frame at 640x480 where nothing was drawn, against 2 ms without
// the tests (docs/REALTIME.md, "What a frame costs on lavapipe").
const int kNearWidth = 6;

uint uncoveredNear(ivec2 first) {
    uint bits = 0u;
    for (int dy = -2; dy <= 2; ++dy) {
        for (int dx = -2; dx <= 3; ++dx) {
            if (abs(dy) + max(max(-dx, dx - 1), 0) > 2) continue; // more than two steps from the pair
            ivec2 p = first + ivec2(dx, dy);
            if (all(greaterThanEqual(p, ivec2(0))) && all(lessThan(p, ivec2(frame.viewport.xy))) && uncoveredAt(p))
                bits |= 1u << uint((dy + 2) * kNearWidth + dx + 2);
        }
    }
    return bits;
}

// Pixel first + (dx, dy) of a pair's window (uncoveredNear): no splat reached it, inside the picture.
bool uncoveredIn(uint near, int dx, int dy) {
    return ((near >> uint((dy + 2) * kNearWidth + dx + 2)) & 1u) != 0u;
}

// A pinhole at first + (dx, dy), one step from the pair at most: a pixel no splat reached whose
// four neighbours splats did reach, inside the picture (RenderSettings::fillPinholes). It is drawn
// as the other pixel of its pair, not as background. Choice, after the surfels of Pfister et al.
// (2000), which fill the holes of their splatted image: two samplings of one surface leave
// different single uncovered pixels where a strand is one or two pixels wide or where two nodes'
// splats only just meet (docs/REALTIME.md, "Pinholes"); a hole of two pixels or more, or a gap
// open on one side, stays.
bool pinholeIn(uint near, ivec2 first, int dx, int dy) {
    ivec2 p = first + ivec2(dx, dy);
    if (frame.flags.w == 0u || any(lessThan(p, ivec2(1))) || any(greaterThanEqual(p, ivec2(frame.viewport.xy) - 1)))
        return false;
    return uncoveredIn(near, dx, dy) && !uncoveredIn(near, dx + 1, dy) && !uncoveredIn(near, dx - 1, dy) &&
           !uncoveredIn(near, dx, dy + 1) && !uncoveredIn(near, dx, dy - 1);
}

// Whether pixel first + (dx, dy), one step from the pair at most, shows the background: inside the
// picture, no splat reached it and it is no pinhole.
bool backgroundIn(uint near, ivec2 first, int dx, int dy) {
    return uncoveredIn(near, dx, dy) && !pinholeIn(near, first, dx, dy);
}

// Whether one of the four neighbours of pixel first + (dx, 0) of the pair shows the background.
bool besideBackgroundIn(uint near, ivec2 first, int dx) {
    return backgroundIn(near, first, dx + 1, 0) || backgroundIn(near, first, dx - 1, 0) ||
           backgroundIn(near, first, dx, 1) || backgroundIn(near, first, dx, -1);
}

// Deferred shading of one pixel from its accumulated sums (w·rgb, w·normal, w); ray as pixelRay.
vec3 shadePixel(vec3 sumColour, vec3 sumNormal, float sumWeight, vec3 ray) {
    if (!(sumWeight > 0.0)) return frame.background.rgb;
    float len = length(sumNormal);
    vec3 n = len > 0.0 ? sumNormal / len : vec3(0.0, 0.0, 1.0);
    return linearToSrgb(frame.flags.x == 0u ? sumColour
                                            : shade(sumColour / sumWeight, max(dot(n, -normalize(ray)), 0.0)));
}
