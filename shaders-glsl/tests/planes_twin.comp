#version 460
#extension GL_GOOGLE_include_directive : require
// Twin test of common/planes.glsl against engine/blockers/src/plane.rs (tests/tests/math_gpu_planes.rs).
// Input, stride 29 floats per case:
//   [0..16) the BlockerPlane record (plane, center, half_u, half_v), [16..19) receiver p,
//   [19..22) ray origin o, [22..25) unit direction d, [25] t_max, [26..29) unit receiver normal n
// Output, stride 15 floats per case:
//   [0] plane_blocks_receiver(p) (1/0)   [1] plane_hit(p, o, d, t_max) (−1: miss)
//   [2..14) plane_edge_normals(p) (rectangles blocking p only; zero otherwise)
//   [14] plane_projected_solid_angle(p, n)
#include "../common/planes.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Input { float data_in[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Output { float data_out[]; };
layout(push_constant) uniform Push { uint count; } pc;

const uint IN_STRIDE = 29u;
const uint OUT_STRIDE = 15u;

vec4 in4(uint b) {
    return vec4(data_in[b], data_in[b + 1u], data_in[b + 2u], data_in[b + 3u]);
}

vec3 in3(uint b) {
    return vec3(data_in[b], data_in[b + 1u], data_in[b + 2u]);
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    uint b = i * IN_STRIDE;
    BlockerPlane pl;
    pl.plane = in4(b);
    pl.center = in4(b + 4u);
    pl.half_u = in4(b + 8u);
    pl.half_v = in4(b + 12u);
    vec3 p = in3(b + 16u);
    vec3 o = in3(b + 19u);
    vec3 d = in3(b + 22u);
    float t_max = data_in[b + 25u];
    uint w = i * OUT_STRIDE;
    bool blocks = plane_blocks_receiver(pl, p);
    data_out[w] = blocks ? 1.0 : 0.0;
    data_out[w + 1u] = plane_hit(pl, p, o, d, t_max);
    vec3 e[4];
    for (int k = 0; k < 4; ++k) e[k] = vec3(0.0);
    if (blocks && plane_is_rectangle(pl)) plane_edge_normals(pl, p, e);
    for (uint k = 0u; k < 4u; ++k) {
        data_out[w + 2u + 3u * k] = e[k].x;
        data_out[w + 3u + 3u * k] = e[k].y;
        data_out[w + 4u + 3u * k] = e[k].z;
    }
    data_out[w + 14u] = plane_projected_solid_angle(pl, p, in3(b + 26u));
}
