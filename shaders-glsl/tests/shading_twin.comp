#version 460
// Twin test of common/shading.glsl against engine/math/src/shading.rs.
// Input, stride 9 floats per case: [0..3) n_s, [3..6) n_g, [6..9) v (all unit, any orientation).
// Output, stride 6 floats per case: [0..3) the shading normal, [3..6) the geometric normal of
// shading_normals(n_s, n_g, v).
#extension GL_GOOGLE_include_directive : require
#include "../common/shading.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Input { float data_in[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Output { float data_out[]; };
layout(push_constant) uniform Push { uint count; } pc;

const uint IN_STRIDE = 9u;
const uint OUT_STRIDE = 6u;

vec3 in3(uint b) {
    return vec3(data_in[b], data_in[b + 1u], data_in[b + 2u]);
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    uint b = i * IN_STRIDE;
    vec3 s, g;
    shading_normals(in3(b), in3(b + 3u), in3(b + 6u), s, g);
    uint o = i * OUT_STRIDE;
    data_out[o] = s.x;
    data_out[o + 1u] = s.y;
    data_out[o + 2u] = s.z;
    data_out[o + 3u] = g.x;
    data_out[o + 4u] = g.y;
    data_out[o + 5u] = g.z;
}
