#version 460
// Twin test of common/sh.glsl against engine/math/src/sh.rs.
// Input, stride 16 floats per case:
//   [0..3) d (any length; zero allowed)   [3] order n (1..8, as float)
//   [4..12) fstar[0..8) (scaled zonal coefficients f*_l; entries ≥ n ignored)   [12..15) axis   [15] unused
// Output, stride 130 floats per case:
//   [0..64)    sh_eval(d, n)                      (sh::eval_basis; entries ≥ n² are 0)
//   [64..128)  sh_zh_rotate(fstar, axis, n)       (sh::zh_rotate_star_into with fstar[..n])
//   [128]      sh_dot(y, f, n)                    (sh::dot of the two above)
//   [129]      sh4_dot(sh4_eval(d), sh4_zh_rotate(fstar[0..4), axis))   (order-4 helpers)
#include "../common/sh.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Input { float data_in[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Output { float data_out[]; };
layout(push_constant) uniform Push { uint count; } pc;

const uint IN_STRIDE = 16u;
const uint OUT_STRIDE = 130u;

void main() {
    uint c = gl_GlobalInvocationID.x;
    if (c >= pc.count) {
        return;
    }
    uint b = c * IN_STRIDE;
    vec3 d = vec3(data_in[b], data_in[b + 1u], data_in[b + 2u]);
    int n = clamp(int(data_in[b + 3u] + 0.5), 1, SH_MAX_ORDER);
    float fstar[SH_MAX_ORDER];
    for (int l = 0; l < SH_MAX_ORDER; ++l) {
        fstar[l] = data_in[b + 4u + uint(l)];
    }
    vec3 axis = vec3(data_in[b + 12u], data_in[b + 13u], data_in[b + 14u]);
    float y[SH_MAX_COEFFS];
    float f[SH_MAX_COEFFS];
    sh_eval(d, n, y);
    sh_zh_rotate(fstar, axis, n, f);
    uint o = c * OUT_STRIDE;
    for (int i = 0; i < SH_MAX_COEFFS; ++i) {
        data_out[o + uint(i)] = y[i];
        data_out[o + 64u + uint(i)] = f[i];
    }
    data_out[o + 128u] = sh_dot(y, f, n);
    float y4[16];
    float f4[16];
    sh4_eval(d, y4);
    sh4_zh_rotate(vec4(fstar[0], fstar[1], fstar[2], fstar[3]), axis, f4);
    data_out[o + 129u] = sh4_dot(y4, f4);
}
