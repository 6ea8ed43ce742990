#version 460
// Twin test of common/isg.glsl against engine/math/src/isg.rs.
// data_in: the first ISG_LUT_SIZE = 55808 floats are IsgLut::generate_default().values (f32, in
// order, read 4 at a time as the table's vec4 entries); then cases at stride 5 floats: [0] θ0, [1] θ1, [2] φ0, [3] φ1, [4] λ.
// data_out, stride 6 floats per case:
//   [0] isg_paper(θ1, φ1, λ)          [1] isg_lut(θ1, φ1, λ)
//   [2] isg_paper_patch(θ0, θ1, φ0, φ1, λ)   [3] isg_lut_patch(θ0, θ1, φ0, φ1, λ)
//   [4] isg_normalization(λ)           [5] isg_lut_warp(θ1, isg_lut_warp_consts(λ))
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Input { float data_in[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Output { float data_out[]; };
layout(push_constant) uniform Push { uint count; } pc;

#define ISG_LUT_FETCH(index) vec4(data_in[4 * (index)], data_in[4 * (index) + 1], data_in[4 * (index) + 2], data_in[4 * (index) + 3])
#include "../common/isg.glsl"

const uint ISG_LUT_SIZE = 55808u;
const uint IN_STRIDE = 5u;
const uint OUT_STRIDE = 6u;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    uint b = ISG_LUT_SIZE + i * IN_STRIDE;
    float t0 = data_in[b];
    float t1 = data_in[b + 1u];
    float p0 = data_in[b + 2u];
    float p1 = data_in[b + 3u];
    float lambda = data_in[b + 4u];
    uint o = i * OUT_STRIDE;
    data_out[o] = isg_paper(t1, p1, lambda);
    data_out[o + 1u] = isg_lut(t1, p1, lambda);
    data_out[o + 2u] = isg_paper_patch(t0, t1, p0, p1, lambda);
    data_out[o + 3u] = isg_lut_patch(t0, t1, p0, p1, lambda);
    data_out[o + 4u] = isg_normalization(lambda);
    data_out[o + 5u] = isg_lut_warp(t1, isg_lut_warp_consts(lambda));
}
