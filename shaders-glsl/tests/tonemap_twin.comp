#version 460
// Twin test of common/tonemap.glsl against engine/math/src/tonemap.rs.
// Input, stride 4 floats per case: radiance r, g, b and the exposure. Output, stride 3: tonemap(radiance, exposure).
#extension GL_GOOGLE_include_directive : require
#include "../common/tonemap.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Input { float data_in[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Output { float data_out[]; };
layout(push_constant) uniform Push { uint count; } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    uint b = i * 4u;
    vec3 c = tonemap(vec3(data_in[b], data_in[b + 1u], data_in[b + 2u]), data_in[b + 3u]);
    data_out[i * 3u] = c.x;
    data_out[i * 3u + 1u] = c.y;
    data_out[i * 3u + 2u] = c.z;
}
