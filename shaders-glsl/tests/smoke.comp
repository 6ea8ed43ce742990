#version 460
// Harness self-test: data_out[i] = 2 * data_in[i] + i.
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Input { float data_in[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Output { float data_out[]; };
layout(push_constant) uniform Push { uint count; } pc;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    data_out[i] = 2.0 * data_in[i] + float(i);
}
