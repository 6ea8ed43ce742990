// Shared parts of the radix sort steps: 4-bit digits, tiles of 1024 keys (256 threads x 4 consecutive
// keys), per-thread digit counts in shared memory, digit-major order (digit, tile, thread) so that the
// counting sort is stable: equal keys keep their order, hence the sort by (code, index) of the CPU build.
#ifndef RADIX_GLSL
#define RADIX_GLSL

const uint RADIX_THREADS = 256u;
const uint RADIX_PER_THREAD = 4u;
const uint RADIX_TILE = RADIX_THREADS * RADIX_PER_THREAD;
const uint RADIX_DIGITS = 16u;

layout(push_constant) uniform Push {
    uint n;      // keys
    uint shift;  // bit offset of this pass's digit
    uint tiles;  // ceil(n / RADIX_TILE)
} pc;

// counts[d * RADIX_THREADS + t]: keys of digit d in thread t's four keys.
shared uint s_counts[RADIX_DIGITS * RADIX_THREADS];
shared uint s_sums[RADIX_THREADS];

uint radix_tiles() {
    return (pc.n + RADIX_TILE - 1u) / RADIX_TILE;
}

uint radix_digit(uint key) {
    return (key >> pc.shift) & (RADIX_DIGITS - 1u);
}

// Exclusive scan of s_sums in place (Hillis-Steele over 256 entries); returns the total. The caller
// has written s_sums and passed a barrier.
uint radix_scan_sums(uint t) {
    uint own = s_sums[t];
    for (uint off = 1u; off < RADIX_THREADS; off <<= 1u) {
        // Index clamped so no out-of-range shared read is ever formed (a select would still load it).
        uint add = t >= off ? s_sums[t - min(off, t)] : 0u;
        barrier();
        s_sums[t] += add;
        barrier();
    }
    uint total = s_sums[RADIX_THREADS - 1u];
    uint inclusive = s_sums[t];
    barrier();
    s_sums[t] = inclusive - own;
    barrier();
    return total;
}

#endif
