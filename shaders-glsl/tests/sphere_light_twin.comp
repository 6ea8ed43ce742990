#version 460
// Twin test of common/sphere_light.glsl against engine/math/src/sphere_light.rs.
// Input, stride 20 floats per case:
//   [0] cos θ, [1] sin α, [2] cos α, [3] λ, [4..7) SG axis (unit), [7..10) cap axis (unit),
//   [10..13) p, [13..16) light centre, [16] light radius, [17..20) n (unit)
// Output, stride 10 floats per case:
//   [0] cap_clamped_cosine(cos θ, sin α, cos α)   [1] cap_sg_integral(SG axis, λ, cap axis, sin α, cos α)
//   [2] cap_from_sphere(p, centre, radius) (1 = outside, 0 = inside)  [3..6) its axis  [6] sin α  [7] cos α
//   [8] sphere_light_clamped_cosine(p, n, centre, radius)   [9] sphere_light_sg_integral(p, centre, radius, SG axis, λ)
#include "../common/sphere_light.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Input { float data_in[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Output { float data_out[]; };
layout(push_constant) uniform Push { uint count; } pc;

const uint IN_STRIDE = 20u;
const uint OUT_STRIDE = 10u;

vec3 in3(uint b) {
    return vec3(data_in[b], data_in[b + 1u], data_in[b + 2u]);
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    uint b = i * IN_STRIDE;
    float cos_theta = data_in[b];
    float sin_alpha = data_in[b + 1u];
    float cos_alpha = data_in[b + 2u];
    float lambda = data_in[b + 3u];
    vec3 sg_axis = in3(b + 4u);
    vec3 cap_axis = in3(b + 7u);
    vec3 p = in3(b + 10u);
    vec3 center = in3(b + 13u);
    float radius = data_in[b + 16u];
    vec3 n = in3(b + 17u);
    uint o = i * OUT_STRIDE;
    data_out[o] = cap_clamped_cosine(cos_theta, sin_alpha, cos_alpha);
    data_out[o + 1u] = cap_sg_integral(sg_axis, lambda, cap_axis, sin_alpha, cos_alpha);
    vec3 axis;
    float sa, ca;
    bool outside = cap_from_sphere(p, center, radius, axis, sa, ca);
    data_out[o + 2u] = outside ? 1.0 : 0.0;
    data_out[o + 3u] = axis.x;
    data_out[o + 4u] = axis.y;
    data_out[o + 5u] = axis.z;
    data_out[o + 6u] = sa;
    data_out[o + 7u] = ca;
    data_out[o + 8u] = sphere_light_clamped_cosine(p, n, center, radius);
    data_out[o + 9u] = sphere_light_sg_integral(p, center, radius, sg_axis, lambda);
}
