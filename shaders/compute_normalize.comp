#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_ARB_gpu_shader_int64 : require
// Pass 3, compute path: decode the fixed-point sums, divide by the weight and shade; one
// invocation per pair of pixels (drawPair), a workgroup per tile of kTileWidth × kTileHeight
// pixels (large: lavapipe pays per workgroup), and only for the tiles that splats reached: a first
// dispatch of this shader (kTileScan) lists them and counts them into the second's indirect
// dispatch; the others keep the background the picture was filled with at the frame's start
// (compute_passes.cpp). lavapipe runs every branch of a shader on all its lanes, so a tile without
// splats cost as much as any before (docs/REALTIME.md, "What a frame costs on lavapipe"). It
// reads the sums and the depth as texels, which lavapipe fetches for all lanes at once (a storage
// buffer it reads one lane at a time), and the pinhole and silhouette tests' depths once per pair
// (splat_common.glsl, uncoveredNear). The sums and the depth are filled at each frame's start, a
// memset on lavapipe.
#include "splat_common.glsl"

// 32 × 32 invocations, a pair of pixels each, draw a tile (kTileWidth = 2 × 32, kTileHeight = 32);
// the scan's 32 × 1 read its 32 rows each.
layout(local_size_x = 32, local_size_y = 32, local_size_y_id = 2) in;

// Every splat has the colour frame.colour (compute_accumulate.comp).
layout(constant_id = 0) const bool kOneColour = false;
// The first dispatch: list the tiles that splats reached (scanTile), one workgroup a tile.
layout(constant_id = 1) const bool kTileScan = false;

layout(set = 0, binding = kBindingDepthTexels) uniform usamplerBuffer depthTexels; // float bits
layout(set = 0, binding = kBindingAccumTexels) uniform usamplerBuffer accumTexels;  // low, high words
layout(set = 0, binding = kBindingOutput, std430) writeonly buffer OutputBlock { uint pixels[]; }; // RGBA8
// The indirect dispatch's x (its y and z are 1), then a flag per tile (reached by a splat) and the
// list of the tiles reached: tileWords[tile] and tileWords[frame.picture.z + k].
layout(set = 0, binding = kBindingTiles, std430) buffer TileBlock {
    uint tileCount;
    uint dispatchY, dispatchZ;
    uint tileWords[];
};

// No splat reached it: the visibility pass left its depth cleared (the accumulation pass adds at
// least the nearest splat's weight wherever it did, but a weight can round to zero).
bool uncoveredAt(ivec2 p) {
    return texelFetch(depthTexels, int(uint(p.y) * uint(frame.viewport.x) + uint(p.x))).x == kDepthCleared;
}

uint64_t accumAt(uint i) {
    uvec2 t = texelFetch(accumTexels, int(i)).xy;
    return uint64_t(t.x) | (uint64_t(t.y) << 32);
}

vec2 unpack(uint64_t word) {
    return vec2(float(uint(word & 0xFFFFFFFFul)), float(uint(word >> 32))) / kFixedScale;
}

// Pixel first + (dx, 0) of a pair, from its sums: its colour, and its weight (zero: no splat's
// weight reached it, and the colour is the background); `near` as uncoveredNear(first).
struct Shaded {
    vec3 rgb;
    float w;
};

Shaded shadeAt(uint near, ivec2 first, int dx, uint i) {
    Shaded s = Shaded(frame.background.rgb, 0.0);
    if (kOneColour) {
        // One colour: one word of three fields (w, w·a', w·b'), a' and b' the normal's components
        // across the ray as (a + 1) / 2 (compute_accumulate.comp, packAcrossRay).
        // A zero weight is a background pixel: every field is at most the weight's, so the word is
        // zero but past a carry.
        uint64_t word = accumAt(i);
        if (word == 0ul) return s;
        const uint64_t mask = (1ul << kOneColourBits) - 1ul;
        float w = float(uint(word & mask));
        if (w == 0.0) return s;
        vec2 across = 2.0 * vec2(float(uint((word >> kOneColourBits) & mask)),
                                 float(uint(word >> (2 * kOneColourBits)))) / w - 1.0;
        s.rgb = linearToSrgb(frame.flags.x == 0u ? w / kOneColourScale * frame.colour.rgb
                                                 : shade(frame.colour.rgb, sqrt(max(1.0 - dot(across, across), 0.0))));
        s.w = w / kOneColourScale;
    } else {
        uint base = i * kAccumStride;
        // Every value a splat adds is at most its weight, so a zero (w·b, w) word means all four
        // words are zero: a background pixel.
        uint64_t blueWeight = accumAt(base + 1);
        if (blueWeight == 0ul) return s;
        vec2 rg = unpack(accumAt(base + 0)), bw = unpack(blueWeight);
        vec2 nxy = unpack(accumAt(base + 2)), nz = unpack(accumAt(base + 3));
        s.w = bw.y;
        // Σ w·n = 2 Σ w·n' − Σ w.
        vec3 normal = 2.0 * vec3(nxy, nz.x) - s.w;
        s.rgb = shadePixel(vec3(rg, bw.x), normal, s.w, pixelRay(vec2(first + ivec2(dx, 0)) + 0.5));
    }
    if (mayBlend(s.w)) s.rgb = smoothEdge(s.rgb, s.w, besideBackgroundIn(near, first, dx));
    return s;
}

// The first pixel of the pair this invocation draws in `tile` (row-major, frame.picture.x across).
ivec2 pairIn(uint tile) {
    uvec2 t = uvec2(tile % frame.picture.x, tile / frame.picture.x);
    return ivec2(t * uvec2(kTileWidth, kTileHeight) + uvec2(2u * gl_LocalInvocationID.x, gl_LocalInvocationID.y));
}

// The first dispatch, a workgroup of 32 invocations per tile, each reading the pairs of one column
// of it: appends the tile to the list in tileWords when a splat reached a pixel of it (the first
// invocation to flag it does). A tile no splat reached is all background: each of its pixels has zero weight
// (the accumulation adds only where the visibility pass wrote a depth), and none is a pinhole (one
// of its four neighbours lies in the tile). No barrier: lavapipe runs a workgroup with barriers as
// coroutines, and a scan of 32 × 32 invocations with two barriers cost about 1 ms at 640 × 480.
void scanTile() {
    uint tile = gl_WorkGroupID.y * frame.picture.x + gl_WorkGroupID.x;
    ivec2 first = pairIn(tile);
    ivec2 size = ivec2(frame.viewport.xy);
    bool reached = false;
    for (int row = 0; row < int(kTileHeight); ++row) {
        ivec2 p = first + ivec2(0, row);
        reached = reached || (p.x < size.x && p.y < size.y &&
                              (!uncoveredAt(p) || (p.x + 1 < size.x && !uncoveredAt(p + ivec2(1, 0)))));
    }
    if (reached && atomicOr(tileWords[tile], 1u) == 0u) tileWords[frame.picture.z + atomicAdd(tileCount, 1u)] = tile;
}

// Each invocation draws a pair of pixels, (2x, y) and (2x + 1, y), of the tile its workgroup draws
// (the scan's list). A pinhole (pinholeIn) takes the colour of the other pixel of its pair, which the
// invocation has shaded already; a pixel of zero weight is one only where the other of its pair has
// weight. A pixel whose depth is set but whose weight rounded to zero (a splat's rim with a sharp
// Gaussian) counts as covered in the test and is drawn as background: the other of its pair is not
// filled from it. Background is the one word frame.picture.y, as in the tiles not drawn.
void drawPair() {
    ivec2 first = pairIn(tileWords[frame.picture.z + gl_WorkGroupID.x]);
    if (first.x >= int(frame.viewport.x) || first.y >= int(frame.viewport.y)) return;
    ivec2 second = first + ivec2(1, 0);
    bool pair = second.x < int(frame.viewport.x);
    uint i = uint(first.y) * uint(frame.viewport.x) + uint(first.x);
    uint near = uncoveredNear(first);
    Shaded a = shadeAt(near, first, 0, i);
    Shaded b = pair ? shadeAt(near, first, 1, i + 1u) : Shaded(frame.background.rgb, 0.0);
    uint wordA = a.w > 0.0 ? packUnorm4x8(vec4(a.rgb, 1.0)) : frame.picture.y;
    uint wordB = b.w > 0.0 ? packUnorm4x8(vec4(b.rgb, 1.0)) : frame.picture.y;
    if (a.w == 0.0 && b.w > 0.0 && pinholeIn(near, first, 0, 0)) wordA = wordB;
    if (b.w == 0.0 && a.w > 0.0 && pinholeIn(near, first, 1, 0)) wordB = wordA;
    pixels[i] = wordA;
    if (pair) pixels[i + 1u] = wordB;
}

void main() {
    if (kTileScan) {
        scanTile();
    } else {
        drawPair();
    }
}
