#version 460
// Twin test of blocker_for_receiver (common/spheres.glsl) against engine_blockers::geom (f64).
// Input, 10 floats per case: 0-2 receiver p, 3-5 unit normal n, 6-9 sphere (cx, cy, cz, r).
// Output, 5 floats per case: 0 kept (0/1), 1-4 the blocker (cx, cy, cz, r) when kept.
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
    uint b = i * 10u;
    vec3 p = vec3(data_in[b + 0u], data_in[b + 1u], data_in[b + 2u]);
    vec3 n = vec3(data_in[b + 3u], data_in[b + 4u], data_in[b + 5u]);
    vec4 s = vec4(data_in[b + 6u], data_in[b + 7u], data_in[b + 8u], data_in[b + 9u]);
    vec4 blk;
    bool kept = blocker_for_receiver(p, n, s, blk);
    uint o = i * 5u;
    data_out[o + 0u] = kept ? 1.0 : 0.0;
    data_out[o + 1u] = kept ? blk.x : 0.0;
    data_out[o + 2u] = kept ? blk.y : 0.0;
    data_out[o + 3u] = kept ? blk.z : 0.0;
    data_out[o + 4u] = kept ? blk.w : 0.0;
}
