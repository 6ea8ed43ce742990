#version 460
#extension GL_GOOGLE_include_directive : require
// Substep, step 3: pushed out of the colliders, v = (p − x)/dt with friction on the contact's tangential
// velocity and no velocity into the collider, x = p. Twin: the end of ClothSim::substep.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer ClothIn { vec4 p_in[]; };
layout(std430, binding = 1) buffer ClothX { vec4 x[]; };
layout(std430, binding = 2) writeonly buffer ClothV { vec4 v[]; };
layout(std430, binding = 3) readonly buffer Spheres { vec4 spheres[]; };
#define CLOTH_COLLIDE
#include "cloth.glsl"

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= pc.columns * pc.rows) return;
    vec3 normal;
    bool contact;
    vec3 q = cloth_collide(p_in[k].xyz, normal, contact);
    vec3 vel = (q - x[k].xyz) / pc.dt;
    if (contact) {
        float vn = dot(vel, normal);
        vel = (vel - normal * vn) * (1.0 - pc.friction) + normal * max(vn, 0.0);
    }
    x[k] = vec4(q, 0.0);
    v[k] = vec4(vel, 0.0);
}
