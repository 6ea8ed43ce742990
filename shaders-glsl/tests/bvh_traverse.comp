#version 460
#extension GL_GOOGLE_include_directive : require
// Twin test of common/bvh.glsl + bvh_cut.glsl against engine_blockers::traverse (f64), run over node
// arrays built by the blocker_bvh pass. One query per invocation; output per query, (cap + 2) uints:
// [count, overflowed, entries...]. Modes (push constant):
//   0: sphere indices of the leaves containing the point a.xyz (cursor loop);
//   1: sphere indices of the leaves meeting the cone (apex a.xyz, axis b.xyz, half-angle b.w) via bvh_cut
//      with sin_theta_max = 0;
//   2: node indices of the cut for receiver c (xyz, radius w) with sin_theta_max = a.w and the cone.
#include "../common/bvh.glsl"
layout(local_size_x = 64) in;
struct Query {
    vec4 a;
    vec4 b;
    vec4 c;
};
layout(std430, binding = 0) readonly buffer Queries { Query queries[]; };
layout(std430, binding = 1) readonly buffer BvhNodes { BvhNode bvh_nodes[]; };
layout(std430, binding = 2) writeonly buffer Hits { uint hits[]; };
layout(push_constant) uniform Push {
    uint query_count;
    uint sphere_count;
    uint mode;
    uint cap;
} pc;

uint g_base;
uint g_count;

void emit(uint x) {
    if (g_count < pc.cap) {
        hits[g_base + 2u + g_count] = x;
    }
    g_count += 1u;
}

#define BVH_CUT_VISIT(index, s) emit(pc.mode == 1u ? bvh_nodes[index].sphere : index)
#include "../common/bvh_cut.glsl"

void main() {
    uint q = gl_GlobalInvocationID.x;
    if (q >= pc.query_count) {
        return;
    }
    Query query = queries[q];
    g_base = q * (pc.cap + 2u);
    g_count = 0u;
    bool overflowed = false;
    if (pc.mode == 0u) {
        BvhCursor c = bvh_cursor_begin(pc.sphere_count);
        uint v;
        while (bvh_cursor_next(c, v)) {
            BvhNode n = bvh_nodes[v];
            if (distance(query.a.xyz, n.center) > n.radius) {
                continue;
            }
            if (bvh_is_leaf(n)) {
                emit(n.sphere);
            } else {
                bvh_cursor_push_children(c, n.left, n.right);
            }
        }
        overflowed = c.overflowed;
    } else {
        float sin_theta = pc.mode == 1u ? 0.0 : query.a.w;
        overflowed = bvh_cut(pc.sphere_count, query.c, sin_theta, query.a.xyz, query.b.xyz, query.b.w);
    }
    hits[g_base] = g_count;
    hits[g_base + 1u] = overflowed ? 1u : 0u;
}
