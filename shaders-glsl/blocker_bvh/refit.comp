#version 460
#extension GL_GOOGLE_include_directive : require
// blocker_bvh step 5: bottom-up bounding-sphere refit with atomic counters (Karras 2012 Sec. 4): one
// thread per leaf walks towards the root; at each internal node the first arriving thread stops and the
// second merges both children (SHEXP Sec. 6.3 pair bound), so every node is written once, after its
// children. Linear: 2n - 1 steps over all threads. Parents are grown by 2^-21 (|c|inf + r) so that, despite f32 rounding of the merge, every
// child lies inside its parent when the test is evaluated in f32 or f64 (conservative culling).
#include "../common/bvh.glsl"
// One invocation per workgroup: on lavapipe (llvmpipe, 8-wide subgroups) walks of several lanes of one
// subgroup lost second-arrival merges (measured: a parent left unwritten at n = 3 with 64-wide groups;
// correct with one lane per group). The walk is cheap (2n - 1 steps in all), so this costs little, and
// sphere counts stay below the 65535-workgroup dispatch limit (MAX_SPHERES in blocker_bvh.rs).
layout(local_size_x = 1) in;
layout(std430, binding = 0) coherent buffer BvhNodes { BvhNode bvh_nodes[]; };
layout(std430, binding = 1) buffer Counters { uint counters[]; };
layout(push_constant) uniform Push { uint n; } pc;

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= pc.n) {
        return;
    }
    uint v = pc.n - 1u + k;
    for (;;) {
        uint p = bvh_nodes[v].parent;
        if (p == BVH_INVALID) {
            break;
        }
        // Make this thread's writes (v's sphere) visible before the other child's thread can see the count.
        memoryBarrierBuffer();
        if (atomicAdd(counters[p], 1u) == 0u) {
            break;
        }
        memoryBarrierBuffer();
        BvhNode node = bvh_nodes[p];
        vec4 a = bvh_sphere(bvh_nodes[node.left]);
        vec4 b = bvh_sphere(bvh_nodes[node.right]);
        vec4 m = merge_spheres(a, b);
        vec3 ac = abs(m.xyz);
        m.w += (max(ac.x, max(ac.y, ac.z)) + m.w) * (1.0 / 2097152.0);
        bvh_nodes[p].center = m.xyz;
        bvh_nodes[p].radius = m.w;
        v = p;
    }
}
