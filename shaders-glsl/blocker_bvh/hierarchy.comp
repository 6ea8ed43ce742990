#version 460
#extension GL_GOOGLE_include_directive : require
// blocker_bvh step 4: Karras 2012 hierarchy generation over the sorted Morton codes (Fig. 4: direction,
// range end by exponential + binary search, split by binary search), one thread per internal node, and
// the leaves, one thread per sphere. Equal codes are ordered by their sorted position, as the augmented
// keys of the paper and the CPU build (engine_blockers::bvh) do. Internal spheres are left for refit.
//
// A sphere with a non-finite centre or a negative / non-finite radius is stored as a zero-radius leaf at
// the lower corner of the scene bounds (it blocks nothing and cannot poison its ancestors).
#include "../common/bvh.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Spheres { vec4 spheres[]; };
layout(std430, binding = 1) readonly buffer Bounds { vec4 bounds[2]; };
layout(std430, binding = 2) readonly buffer Keys { uint keys[]; };
layout(std430, binding = 3) readonly buffer Values { uint values[]; };
layout(std430, binding = 4) buffer BvhNodes { BvhNode bvh_nodes[]; };
layout(push_constant) uniform Push { uint n; } pc;

// Length of the common prefix of the augmented keys (code, position); -1 outside [0, n).
int delta(int i, int j) {
    if (j < 0 || j >= int(pc.n)) {
        return -1;
    }
    uint a = keys[i];
    uint b = keys[j];
    if (a == b) {
        return 32 + (31 - findMSB(uint(i) ^ uint(j)));
    }
    return 31 - findMSB(a ^ b);
}

void main() {
    uint g = gl_GlobalInvocationID.x;
    uint n = pc.n;
    if (g >= 2u * n - 1u) {
        return;
    }
    if (g >= n - 1u) {
        // Leaf n - 1 + k holds the k-th sphere in Morton order.
        uint k = g - (n - 1u);
        uint s = values[k];
        vec4 sp = spheres[s];
        bool ok = !any(isnan(sp)) && !any(isinf(sp)) && sp.w >= 0.0;
        vec3 lo = bounds[0].xyz;
        vec3 fallback = (any(isnan(lo)) || any(isinf(lo))) ? vec3(0.0) : lo;
        bvh_nodes[g].center = ok ? sp.xyz : fallback;
        bvh_nodes[g].radius = ok ? sp.w : 0.0;
        bvh_nodes[g].left = BVH_INVALID;
        bvh_nodes[g].right = BVH_INVALID;
        bvh_nodes[g].sphere = s;
        if (n == 1u) {
            bvh_nodes[g].parent = BVH_INVALID;
        }
        return;
    }
    int i = int(g);
    int d = delta(i, i + 1) - delta(i, i - 1) >= 0 ? 1 : -1;
    int delta_min = delta(i, i - d);
    int l_max = 2;
    while (delta(i, i + l_max * d) > delta_min) {
        l_max *= 2;
    }
    int l = 0;
    for (int t = l_max / 2; t >= 1; t /= 2) {
        if (delta(i, i + (l + t) * d) > delta_min) {
            l += t;
        }
    }
    int j = i + l * d;
    int delta_node = delta(i, j);
    int s = 0;
    int div = 2;
    for (;;) {
        int t = (l + div - 1) / div;
        if (delta(i, i + (s + t) * d) > delta_node) {
            s += t;
        }
        if (t <= 1) {
            break;
        }
        div *= 2;
    }
    int gamma = i + s * d + min(d, 0);
    int internal = int(n) - 1;
    uint left = uint(min(i, j) == gamma ? internal + gamma : gamma);
    uint right = uint(max(i, j) == gamma + 1 ? internal + gamma + 1 : gamma + 1);
    bvh_nodes[i].left = left;
    bvh_nodes[i].right = right;
    bvh_nodes[i].sphere = BVH_INVALID;
    bvh_nodes[left].parent = uint(i);
    bvh_nodes[right].parent = uint(i);
    if (i == 0) {
        bvh_nodes[0].parent = BVH_INVALID;
    }
}
