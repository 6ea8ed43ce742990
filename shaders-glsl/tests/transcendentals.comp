#version 460
// Accuracy probe of the GLSL built-ins that the common/*.glsl twins use; the twin tests' tolerances
// assume the bounds that tests/tests/math_gpu_sg.rs checks with this shader.
// Input: one float x in [-1, 1] per case. Output, stride 9 floats per case:
//   [0] exp(40x)   [1] log(1 + x/2)   [2] log(1000(x + 1.001))   [3] atan(4x)   [4] atan(x, 0.7)
//   [5] sin(3x)   [6] cos(3x)   [7] asin(x)   [8] acos(x)
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Input { float data_in[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Output { float data_out[]; };
layout(push_constant) uniform Push { uint count; } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    float x = data_in[i];
    uint o = i * 9u;
    data_out[o] = exp(40.0 * x);
    data_out[o + 1u] = log(1.0 + 0.5 * x);
    data_out[o + 2u] = log(1000.0 * (x + 1.001));
    data_out[o + 3u] = atan(4.0 * x);
    data_out[o + 4u] = atan(x, 0.7);
    data_out[o + 5u] = sin(3.0 * x);
    data_out[o + 6u] = cos(3.0 * x);
    data_out[o + 7u] = asin(x);
    data_out[o + 8u] = acos(x);
}
