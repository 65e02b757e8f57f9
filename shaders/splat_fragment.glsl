// Inputs of the graphics path's splat fragment shaders (see splat.vert).
#include "splat_common.glsl"

layout(location = 0) in vec3 inViewPos;
layout(location = 1) in vec2 inLocal;
layout(location = 2) flat in vec3 inColour;
layout(location = 3) flat in vec3 inNormal;
layout(location = 4) flat in float inRadius;

// Window depth (0 near, 1 far) of linear depth t under the frame's projection.
float windowDepth(float t) {
    return (frame.projection[2][2] * -t + frame.projection[3][2]) / t;
}
