#version 460
#extension GL_GOOGLE_include_directive : require
// blocker_bvh radix step b: exclusive prefix sum of the digit-major histogram (16 x tiles entries) in
// place, one workgroup: each thread scans a contiguous run serially, then the run totals are scanned.
layout(local_size_x = 256) in;
layout(std430, binding = 0) buffer Histogram { uint hist[]; };
#include "radix.glsl"

void main() {
    uint t = gl_LocalInvocationID.x;
    uint m = RADIX_DIGITS * radix_tiles();
    uint per = (m + RADIX_THREADS - 1u) / RADIX_THREADS;
    uint begin = min(t * per, m);
    uint end = min(begin + per, m);
    uint sum = 0u;
    for (uint i = begin; i < end; ++i) {
        sum += hist[i];
    }
    s_sums[t] = sum;
    barrier();
    radix_scan_sums(t);
    uint run = s_sums[t];
    for (uint i = begin; i < end; ++i) {
        uint v = hist[i];
        hist[i] = run;
        run += v;
    }
}
