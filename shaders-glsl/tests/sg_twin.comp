#version 460
// Twin test of common/sg.glsl against engine/math/src/sg.rs.
// Input, stride 16 floats per case:
//   [0..3)  a1, [3] λ1, [4] μ1, [5..8) a2, [8] λ2, [9] μ2, [10..13) v (unit), [13..16) n (unit)
// Output, stride 13 floats per case:
//   [0] sg_eval(a1, λ1, μ1, v)   [1] sg_integral(λ1, μ1)
//   [2..5) product axis   [5] product λ   [6] product ln μ   [7] product μ   [8] inner product
//   [9..12) warp_half_vector_lobe(n, v, λ_h = λ1) axis   [12] its λ
#include "../common/sg.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Input { float data_in[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Output { float data_out[]; };
layout(push_constant) uniform Push { uint count; } pc;

const uint IN_STRIDE = 16u;
const uint OUT_STRIDE = 13u;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    uint b = i * IN_STRIDE;
    vec3 a1 = vec3(data_in[b], data_in[b + 1u], data_in[b + 2u]);
    float l1 = data_in[b + 3u];
    float mu1 = data_in[b + 4u];
    vec3 a2 = vec3(data_in[b + 5u], data_in[b + 6u], data_in[b + 7u]);
    float l2 = data_in[b + 8u];
    float mu2 = data_in[b + 9u];
    vec3 v = vec3(data_in[b + 10u], data_in[b + 11u], data_in[b + 12u]);
    vec3 n = vec3(data_in[b + 13u], data_in[b + 14u], data_in[b + 15u]);
    uint o = i * OUT_STRIDE;
    data_out[o] = sg_eval(a1, l1, mu1, v);
    data_out[o + 1u] = sg_integral(l1, mu1);
    vec3 axis;
    float lambda;
    float log_mu = sg_product_log(a1, l1, mu1, a2, l2, mu2, axis, lambda);
    data_out[o + 2u] = axis.x;
    data_out[o + 3u] = axis.y;
    data_out[o + 4u] = axis.z;
    data_out[o + 5u] = lambda;
    data_out[o + 6u] = log_mu;
    float mu;
    sg_product(a1, l1, mu1, a2, l2, mu2, mu);
    data_out[o + 7u] = mu;
    data_out[o + 8u] = sg_inner_product(a1, l1, mu1, a2, l2, mu2);
    vec4 w = sg_warp_half_vector_lobe(n, v, l1);
    data_out[o + 9u] = w.x;
    data_out[o + 10u] = w.y;
    data_out[o + 11u] = w.z;
    data_out[o + 12u] = w.w;
}
