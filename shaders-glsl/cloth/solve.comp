#version 460
#extension GL_GOOGLE_include_directive : require
// Substep, step 2 (one Jacobi sweep, ping-pong): every vertex gathers the XPBD corrections of its
// distance constraints to its 12 neighbours (λ = 0: Macklin et al. 2016 Eq. 18 for unit masses) and moves
// by ω times their average (Macklin et al. 2014 §4.2). No atomics: deterministic. Twin: ClothSim::jacobi.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer ClothRest { vec4 rest[]; };
layout(std430, binding = 1) readonly buffer ClothIn { vec4 p_in[]; };
layout(std430, binding = 2) writeonly buffer ClothOut { vec4 p_out[]; };
#include "cloth.glsl"

// (di, dj, kind): structural, shear, bending. Twin: engine::scene::cloth::NEIGHBOURS (same order).
const ivec3 NEIGHBOURS[12] = ivec3[12](
    ivec3(1, 0, 0), ivec3(-1, 0, 0), ivec3(0, 1, 0), ivec3(0, -1, 0),
    ivec3(1, 1, 1), ivec3(-1, -1, 1), ivec3(1, -1, 1), ivec3(-1, 1, 1),
    ivec3(2, 0, 2), ivec3(-2, 0, 2), ivec3(0, 2, 2), ivec3(0, -2, 2));

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= pc.columns * pc.rows) return;
    ivec2 ij = ivec2(int(k % pc.columns), int(k / pc.columns));
    ivec2 size = ivec2(pc.columns, pc.rows);
    vec3 p = p_in[k].xyz;
    vec3 delta = vec3(0.0);
    uint count = 0u;
    for (int t = 0; t < 12; ++t) {
        ivec2 q = ij + NEIGHBOURS[t].xy;
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
        uint m = uint(q.y) * pc.columns + uint(q.x);
        vec3 d = p - p_in[m].xyz;
        float len = length(d);
        count += 1u;
        if (len > 1e-9) {
            float c = len - length(rest[k].xyz - rest[m].xyz);
            delta -= d * (c / ((2.0 + pc.alpha[NEIGHBOURS[t].z]) * len));
        }
    }
    p_out[k] = vec4(p + delta * (pc.relaxation / float(max(count, 1u))), 0.0);
}
