#version 460
#extension GL_GOOGLE_include_directive : require
// Back to the rest state (time went backwards): x = rest, v = 0.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer ClothRest { vec4 rest[]; };
layout(std430, binding = 1) writeonly buffer ClothX { vec4 x[]; };
layout(std430, binding = 2) writeonly buffer ClothV { vec4 v[]; };
#include "cloth.glsl"

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= pc.columns * pc.rows) return;
    x[k] = rest[k];
    v[k] = vec4(0.0);
}
