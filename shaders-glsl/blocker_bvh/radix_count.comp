#version 460
#extension GL_GOOGLE_include_directive : require
// blocker_bvh radix step a: per-tile digit histogram, written digit-major: hist[digit * tiles + tile].
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer KeysIn { uint keys_in[]; };
layout(std430, binding = 1) writeonly buffer Histogram { uint hist[]; };
#include "radix.glsl"

void main() {
    uint t = gl_LocalInvocationID.x;
    uint tile = gl_WorkGroupID.x;
    for (uint d = 0u; d < RADIX_DIGITS; ++d) {
        s_counts[d * RADIX_THREADS + t] = 0u;
    }
    for (uint k = 0u; k < RADIX_PER_THREAD; ++k) {
        uint i = tile * RADIX_TILE + t * RADIX_PER_THREAD + k;
        if (i < pc.n) {
            s_counts[radix_digit(keys_in[i]) * RADIX_THREADS + t] += 1u;
        }
    }
    barrier();
    // 16 digits x 256 counts: each of the 256 threads sums 16 entries of one digit, then 16 threads add up.
    uint d = t / 16u;
    uint part = 0u;
    for (uint j = 0u; j < 16u; ++j) {
        part += s_counts[d * RADIX_THREADS + (t % 16u) * 16u + j];
    }
    s_sums[t] = part;
    barrier();
    if (t < RADIX_DIGITS) {
        uint total = 0u;
        for (uint j = 0u; j < 16u; ++j) {
            total += s_sums[t * 16u + j];
        }
        hist[t * radix_tiles() + tile] = total;
    }
}
