#version 460
#extension GL_GOOGLE_include_directive : require
// Graphics path, passes 1 and 2: each splat is drawn as the square that bounds its disk, in the
// disk's plane (two triangles, six vertices per splat, no vertex buffer). Perspective-correct
// interpolation then gives every fragment the exact point of the disk plane under its pixel
// centre, so the fragment shaders need no ray–plane intersection, and the rasterizer clips
// squares at the near plane. There is no size limit in pixels, unlike point sprites.
#include "splat_common.glsl"

layout(location = 0) out vec3 outViewPos;        // the point of the disk plane, view space
layout(location = 1) out vec2 outLocal;          // the same in disk coordinates / radius
layout(location = 2) flat out vec3 outColour;    // linear RGB
layout(location = 3) flat out vec3 outNormal;    // view space
layout(location = 4) flat out float outRadius;

const vec2 kCorners[6] = vec2[](vec2(-1.0, -1.0), vec2(1.0, -1.0), vec2(1.0, 1.0),
                                vec2(-1.0, -1.0), vec2(1.0, 1.0), vec2(-1.0, 1.0));

void main() {
    Splat s = splatAt(uint(gl_VertexIndex) / 6u);
    ViewSplat v = toView(s);
    vec2 corner = kCorners[gl_VertexIndex % 6];
    outLocal = corner;
    outColour = linearColour(s, v);
    outNormal = v.normal;
    outRadius = v.radius;
    if (!frontFacing(v)) {
        // Outside the clip volume and of zero area: the rasterizer drops it.
        outViewPos = vec3(0.0);
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
        return;
    }
    vec3 u = tangentOf(v.normal) * v.radius;
    vec3 w = cross(v.normal, u);
    outViewPos = v.centre + corner.x * u + corner.y * w;
    gl_Position = frame.projection * vec4(outViewPos, 1.0);
}
