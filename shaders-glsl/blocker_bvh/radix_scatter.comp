#version 460
#extension GL_GOOGLE_include_directive : require
// blocker_bvh radix step c: stable scatter. A key's destination is the scanned histogram entry of its
// (digit, tile), plus the keys of that digit in earlier threads of the tile, plus earlier keys of that
// digit in its own thread.
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer KeysIn { uint keys_in[]; };
layout(std430, binding = 1) readonly buffer ValuesIn { uint values_in[]; };
layout(std430, binding = 2) writeonly buffer KeysOut { uint keys_out[]; };
layout(std430, binding = 3) writeonly buffer ValuesOut { uint values_out[]; };
layout(std430, binding = 4) readonly buffer Histogram { uint hist[]; };
#include "radix.glsl"

void main() {
    uint t = gl_LocalInvocationID.x;
    uint tile = gl_WorkGroupID.x;
    for (uint d = 0u; d < RADIX_DIGITS; ++d) {
        s_counts[d * RADIX_THREADS + t] = 0u;
    }
    uint keys[RADIX_PER_THREAD];
    for (uint k = 0u; k < RADIX_PER_THREAD; ++k) {
        uint i = tile * RADIX_TILE + t * RADIX_PER_THREAD + k;
        keys[k] = i < pc.n ? keys_in[i] : 0u;
        if (i < pc.n) {
            s_counts[radix_digit(keys[k]) * RADIX_THREADS + t] += 1u;
        }
    }
    barrier();
    // Exclusive scan of s_counts within each digit row: thread t owns entries [16t, 16t + 16) in
    // digit-major order (one digit row holds 16 such runs).
    uint base = t * 16u;
    uint sum = 0u;
    for (uint j = 0u; j < 16u; ++j) {
        sum += s_counts[base + j];
    }
    s_sums[t] = sum;
    barrier();
    radix_scan_sums(t);
    uint run = s_sums[t];
    for (uint j = 0u; j < 16u; ++j) {
        uint v = s_counts[base + j];
        s_counts[base + j] = run;
        run += v;
    }
    barrier();
    // s_counts now holds tile-wide digit-major exclusive offsets; make them relative to the digit row
    // and add the global offset of (digit, tile).
    uint offset[RADIX_DIGITS];
    for (uint d = 0u; d < RADIX_DIGITS; ++d) {
        offset[d] = hist[d * radix_tiles() + tile] + s_counts[d * RADIX_THREADS + t] - s_counts[d * RADIX_THREADS];
    }
    for (uint k = 0u; k < RADIX_PER_THREAD; ++k) {
        uint i = tile * RADIX_TILE + t * RADIX_PER_THREAD + k;
        if (i < pc.n) {
            uint d = radix_digit(keys[k]);
            uint dst = offset[d];
            offset[d] = dst + 1u;
            keys_out[dst] = keys[k];
            values_out[dst] = values_in[i];
        }
    }
}
