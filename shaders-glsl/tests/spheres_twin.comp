#version 460
// Twin test of common/spheres.glsl against engine_blockers::geom (f64).
// Input, 16 floats per case:
//   0-2 apex (also the point p of the subtended angle), 3-5 cone axis (unit), 6 cone half-angle,
//   7 theta_max, 8-11 sphere A (cx, cy, cz, r), 12-15 sphere B (cx, cy, cz, r; also the receiver).
// Output, 8 floats per case:
//   0 cone_intersects_sphere(apex, axis, half_angle, A) as 0/1
//   1 sphere_subtended_half_angle(apex, A)
//   2-5 merge_spheres(A, B)
//   6 sphere_subtends_less_than(B, A, theta_max) as 0/1
//   7 spheres_angle_between(axis, A.xyz - apex)
#include "../common/spheres.glsl"

layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Input { float data_in[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Output { float data_out[]; };
layout(push_constant) uniform Push { uint count; } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    uint b = i * 16u;
    vec3 apex = vec3(data_in[b + 0u], data_in[b + 1u], data_in[b + 2u]);
    vec3 axis = vec3(data_in[b + 3u], data_in[b + 4u], data_in[b + 5u]);
    float half_angle = data_in[b + 6u];
    float theta_max = data_in[b + 7u];
    vec4 sa = vec4(data_in[b + 8u], data_in[b + 9u], data_in[b + 10u], data_in[b + 11u]);
    vec4 sb = vec4(data_in[b + 12u], data_in[b + 13u], data_in[b + 14u], data_in[b + 15u]);

    uint o = i * 8u;
    data_out[o + 0u] = cone_intersects_sphere(apex, axis, half_angle, sa) ? 1.0 : 0.0;
    data_out[o + 1u] = sphere_subtended_half_angle(apex, sa);
    vec4 m = merge_spheres(sa, sb);
    data_out[o + 2u] = m.x;
    data_out[o + 3u] = m.y;
    data_out[o + 4u] = m.z;
    data_out[o + 5u] = m.w;
    data_out[o + 6u] = sphere_subtends_less_than(sb, sa, theta_max) ? 1.0 : 0.0;
    data_out[o + 7u] = spheres_angle_between(axis, sa.xyz - apex);
}
