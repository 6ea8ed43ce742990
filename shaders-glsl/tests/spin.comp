#version 460
// Test-only: a pass made to run too long (tests/tests/device_loss.rs: the fence-timeout test). Each invocation
// runs a dependent chain of `iterations` multiply-adds, capped at 60000: llvmpipe ends every loop of an
// invocation after 65535 iterations, so the total time comes from the number of invocations, not the loop.
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) writeonly buffer Output { float data_out[]; };
layout(push_constant) uniform Push { uint iterations; } pc;
void main() {
    uint id = gl_GlobalInvocationID.x;
    float x = float(id & 1023u) * 1e-3;
    uint n = min(pc.iterations, 60000u);
    for (uint i = 0u; i < n; ++i) {
        x = fract(x * 1.000173 + 0.318);
    }
    // A result the compiler cannot drop; 1024 slots, so the buffer stays small however many invocations run.
    data_out[id & 1023u] = x;
}
