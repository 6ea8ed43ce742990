// The per-receiver cut over the blocker BVH (SHEXP Sec. 6.3 with ISG Sec. 5 cone culling), as one loop.
// Requires, before inclusion: bvh.glsl, a buffer with `BvhNode bvh_nodes[]`, and the macro
// BVH_CUT_VISIT(index, sphere) that consumes one visited node (uint index, vec4 sphere), e.g.
//     #define BVH_CUT_VISIT(index, s) accumulate_blocker(s)
// Optionally BVH_CUT_DROP(sphere): a node for which it is true is dropped with its subtree (after the
// cone test); it must then be true for every node of the subtree too (e.g. "subtends less than θ_min").
// f64 twin: engine_blockers::traverse::cut.
#ifndef BVH_CUT_GLSL
#define BVH_CUT_GLSL

// From the root: a node that misses the cone (apex, unit axis, half_angle) is dropped with its subtree; a
// leaf, a node subtending less than theta_max from every receiver point (receiver.w = 0 for a point;
// sin_theta_max = 0 visits leaves only), or a node whose children do not fit on the stack is visited
// whole; otherwise its children are visited (left first). Returns whether the stack overflowed (never
// with the default BVH_STACK_SIZE on the LBVH; see bvh.glsl).
bool bvh_cut(uint sphere_count, vec4 receiver, float sin_theta_max, vec3 apex, vec3 axis, float half_angle) {
    BvhCursor c = bvh_cursor_begin(sphere_count);
    uint v;
    while (bvh_cursor_next(c, v)) {
        BvhNode n = bvh_nodes[v];
        vec4 s = bvh_sphere(n);
        if (!bvh_cone_hits(apex, axis, half_angle, s) || bvh_beyond_reach(receiver.xyz, s)) {
            continue;
        }
#ifdef BVH_CUT_DROP
        if (BVH_CUT_DROP(s)) {
            continue;
        }
#endif
        if (bvh_is_leaf(n) || bvh_cursor_whole(c) || bvh_subtends_less_than(receiver, s, sin_theta_max)
            || !bvh_cursor_push_children(c, n.left, n.right)) {
            BVH_CUT_VISIT(v, s);
        }
    }
    return c.overflowed;
}

#endif // BVH_CUT_GLSL
