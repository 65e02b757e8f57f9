#version 460
#extension GL_GOOGLE_include_directive : require
// The benchmark's baseline: every splat centre as a plain 1-pixel point, no splatting.
#include "splat_common.glsl"

layout(location = 0) flat out vec3 outColour;

void main() {
    Splat s = splatAt(uint(gl_VertexIndex));
    outColour = unpackUnorm4x8(s.colour).rgb;
    gl_Position = frame.projection * (frame.view * vec4(s.position, 1.0));
    gl_PointSize = 1.0;
}
