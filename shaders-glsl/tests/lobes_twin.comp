#version 460
// Twin test of common/lobes.glsl against engine/math/src/lobes.rs.
// Input, stride 12 floats per case:
//   [0..3) a1 (unit)   [3] e1   [4..7) a2 (unit)   [7] e2   [8..11) v (unit)   [11] s (scale, > 0)
// Output, stride 20 floats per case:
//   [0]  lobe_eval(a1, s, e1, v)                       lobes::lobe_eval
//   [1]  lobe_log_eval(a1, e1, v)  (-3e38 for -inf)    lobes::lobe_log_eval
//   [2]  lobe_sphere_integral(s, e1)                   s * lobes::sphere_integral(e1)
//   [3]  alpha = lobe_angle_between(a1, a2)            lobes::angle_between
//   [4]  lobe_product_axis_angle(e1, e2, alpha)        lobes::product_axis_angle
//   [5]  lobe_product_log_peak(e1, e2, alpha)          lobes::product_log_peak
//   [6..9) lobe_product_axis(a1, e1, a2, e2)           lobes::product_axis
//   [9]  lobe_exponent_coord(e1, 16)                   lobes::exponent_coord(e1, 16)
//   [10] lobe_exponent_coord(e2, 128)                  lobes::exponent_coord(e2, 128)
//   [11] lobe_hemisphere_coord_y(e1, dot(a1, a2))      lobes::hemisphere_coord_y
//   [12] lobe_alpha_coord(alpha, 49)                   lobes::alpha_coord(alpha, 49)
//   [13] lobe_cap_coord(alpha / 2, 1000)               lobes::cap_coord(alpha / 2, 1000)
//   [14] lobe_cap_exponent(s, alpha / 2)               lobes::cap_exponent_from_k(s, alpha / 2)
//   [15] lobe_sphere_cap_angle(3 a2, s, v)             lobes::sphere_cap_angle(3 a2, s, v)
//   [16..20) lobe_lafortune(C = a2, rho = s, e2, t = +x, b = +z, n = +y, v_o = v): (axis, scale)
//                                                      lobes::lafortune_lobe
#include "../common/lobes.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Input { float data_in[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Output { float data_out[]; };
layout(push_constant) uniform Push { uint count; } pc;

const uint IN_STRIDE = 12u;
const uint OUT_STRIDE = 20u;

void main() {
    uint c = gl_GlobalInvocationID.x;
    if (c >= pc.count) {
        return;
    }
    uint i = c * IN_STRIDE;
    vec3 a1 = vec3(data_in[i], data_in[i + 1u], data_in[i + 2u]);
    float e1 = data_in[i + 3u];
    vec3 a2 = vec3(data_in[i + 4u], data_in[i + 5u], data_in[i + 6u]);
    float e2 = data_in[i + 7u];
    vec3 v = vec3(data_in[i + 8u], data_in[i + 9u], data_in[i + 10u]);
    float s = data_in[i + 11u];

    uint o = c * OUT_STRIDE;
    data_out[o] = lobe_eval(a1, s, e1, v);
    data_out[o + 1u] = lobe_log_eval(a1, e1, v);
    data_out[o + 2u] = lobe_sphere_integral(s, e1);
    float alpha = lobe_angle_between(a1, a2);
    data_out[o + 3u] = alpha;
    data_out[o + 4u] = lobe_product_axis_angle(e1, e2, alpha);
    data_out[o + 5u] = lobe_product_log_peak(e1, e2, alpha);
    vec3 ar = lobe_product_axis(a1, e1, a2, e2);
    data_out[o + 6u] = ar.x;
    data_out[o + 7u] = ar.y;
    data_out[o + 8u] = ar.z;
    data_out[o + 9u] = lobe_exponent_coord(e1, 16.0);
    data_out[o + 10u] = lobe_exponent_coord(e2, 128.0);
    data_out[o + 11u] = lobe_hemisphere_coord_y(e1, dot(a1, a2));
    data_out[o + 12u] = lobe_alpha_coord(alpha, 49.0);
    data_out[o + 13u] = lobe_cap_coord(0.5 * alpha, 1000.0);
    data_out[o + 14u] = lobe_cap_exponent(s, 0.5 * alpha);
    data_out[o + 15u] = lobe_sphere_cap_angle(3.0 * a2, s, v);
    vec4 lf = lobe_lafortune(a2, s, e2, vec3(1.0, 0.0, 0.0), vec3(0.0, 0.0, 1.0), vec3(0.0, 1.0, 0.0), v);
    data_out[o + 16u] = lf.x;
    data_out[o + 17u] = lf.y;
    data_out[o + 18u] = lf.z;
    data_out[o + 19u] = lf.w;
}
