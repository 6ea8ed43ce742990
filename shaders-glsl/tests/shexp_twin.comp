#version 460
// Twin test of common/shexp.glsl (order 4) against engine/math/src/shexp.rs.
// Input, stride 34 floats per case:
//   [0..16) f (an order-4 SH vector, e.g. a summed log visibility)   [16..32) b (second vector)
//   [32] HYB target norm   [33] PS* series degree p (as float, 0..12)
// Output, stride 80 floats per case:
//   [0..16)  sh4_product(f, b)          (ShTensor::product at n = 4)
//   [16..32) sh4_square(f)              (ShTensor::square)
//   [32..48) sh4_exp_ol(f)              (shexp::exp_ol with ShExp::new(4).ol.resampled(64))
//   [48..64) sh4_exp_hyb(f, target)     (shexp::exp_hyb with the same resampled table)
//   [64..80) sh4_exp_ps_star(f, p)      (shexp::exp_ps_star)
#include "../common/shexp.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Input { float data_in[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Output { float data_out[]; };
layout(push_constant) uniform Push { uint count; } pc;

const uint IN_STRIDE = 34u;
const uint OUT_STRIDE = 80u;

void write16(uint o, float v[16]) {
    for (int i = 0; i < 16; ++i) {
        data_out[o + uint(i)] = v[i];
    }
}

void main() {
    uint c = gl_GlobalInvocationID.x;
    if (c >= pc.count) {
        return;
    }
    uint b = c * IN_STRIDE;
    float f[16];
    float g[16];
    for (int i = 0; i < 16; ++i) {
        f[i] = data_in[b + uint(i)];
        g[i] = data_in[b + 16u + uint(i)];
    }
    float target = data_in[b + 32u];
    int p = clamp(int(data_in[b + 33u] + 0.5), 0, 12);
    uint o = c * OUT_STRIDE;
    float r[16];
    sh4_product(f, g, r);
    write16(o, r);
    sh4_square(f, r);
    write16(o + 16u, r);
    sh4_exp_ol(f, r);
    write16(o + 32u, r);
    sh4_exp_hyb(f, target, r);
    write16(o + 48u, r);
    sh4_exp_ps_star(f, p, r);
    write16(o + 64u, r);
}
