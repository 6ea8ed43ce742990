#version 460
#extension GL_GOOGLE_include_directive : require
// Substep, step 1: damped velocity plus gravity, predicted position pushed out of the colliders.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer ClothX { vec4 x[]; };
layout(std430, binding = 1) readonly buffer ClothV { vec4 v[]; };
layout(std430, binding = 2) writeonly buffer ClothOut { vec4 p_out[]; };
layout(std430, binding = 3) readonly buffer Spheres { vec4 spheres[]; };
#define CLOTH_COLLIDE
#include "cloth.glsl"

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= pc.columns * pc.rows) return;
    vec3 vel = v[k].xyz * pc.keep + pc.gravity * pc.dt;
    vec3 normal;
    bool contact;
    p_out[k] = vec4(cloth_collide(x[k].xyz + vel * pc.dt, normal, contact), 0.0);
}
