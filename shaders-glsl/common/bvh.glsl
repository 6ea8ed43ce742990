// Binary sphere BVH in device memory: the node layout (twin of engine_blockers::bvh::GpuBvhNode, std430,
// 32 bytes) and bounded-stack traversal helpers shared by every technique. f64 twin:
// engine_blockers::traverse (same stack discipline, same overflow rule).
//
// Node numbering (Karras 2012): for n leaves, internal nodes are 0 .. n-2 (root 0) and leaves n-1 .. 2n-2;
// with one sphere the root is that leaf. A node's sphere bounds its children's.
//
// This file declares no buffer: a shader includes it, declares its node array with this struct, e.g.
//     layout(std430, binding = N) readonly buffer BvhNodes { BvhNode bvh_nodes[]; };
// and then either writes its own loop with the cursor helpers or includes bvh_cut.glsl.
#ifndef BVH_GLSL
#define BVH_GLSL

#include "spheres.glsl"

const uint BVH_INVALID = 0xffffffffu;

struct BvhNode {
    vec3 center;
    float radius;
    uint left;   // BVH_INVALID for a leaf
    uint right;  // BVH_INVALID for a leaf
    uint parent; // BVH_INVALID for the root
    uint sphere; // leaf: index into the sphere buffer; internal: BVH_INVALID
};

// Maximum pending nodes. An LBVH over 30-bit Morton codes with index tie-breaks has depth <= 63 (the
// split prefix length strictly grows along every root-to-leaf path and is at most 62), and a traversal
// that pops one node and pushes two holds at most depth + 1 = 64 entries: BVH_STACK_SIZE 64 never
// overflows on the LBVH built by the blocker_bvh pass. A shader may define a smaller stack before
// including this file (fewer registers); then see bvh_cursor_push_children for what overflow does.
#ifndef BVH_STACK_SIZE
#define BVH_STACK_SIZE 64
#endif

struct BvhCursor {
    uint stack[BVH_STACK_SIZE];
    uint size;
    // Set when a push did not fit (the node was then handed back to the caller to take whole).
    bool overflowed;
    // Start nodes still to visit, [next, end) of the shader's start list (BVH_TILE_NODE): each is visited,
    // with its subtree, when the stack runs empty. Empty when the traversal starts at the root.
    uint next;
    uint end;
    // The node last popped came from the list marked "take whole" (the tile's level of detail, cull.comp).
    bool whole;
};

// Tile start lists (shaders-glsl/blocker_tiles/cull.comp): a shader that defines BVH_TILE_NODE(i) (the i-th
// entry of its start-list buffer) and declares `uvec2 bvh_tile_range()` (this invocation's [first, end) in
// it) starts every traversal from its tile's list instead of the root. The list is a cut of the BVH in
// depth-first, left-first order holding every node that any receiver of the tile could reach, so the
// traversal visits the same nodes in the same order as from the root, minus the upper levels and the
// subtrees no receiver of the tile sees (see cull.comp for why that is exact).
#ifdef BVH_TILE_NODE
uvec2 bvh_tile_range();
#endif

// BVH_COUNT_VISITS: bvh_visits counts the nodes this invocation popped, over all its traversals (the
// "blockers tested per pixel" counter; the pixel target writes it out).
#ifdef BVH_COUNT_VISITS
uint bvh_visits = 0u;
#define BVH_VISITED() (bvh_visits += 1u)
#else
#define BVH_VISITED() 0u
#endif

// A cursor at the root, or an empty one when there are no spheres.
BvhCursor bvh_cursor_begin_root(uint sphere_count) {
    BvhCursor c;
    c.size = sphere_count > 0u ? 1u : 0u;
    c.stack[0] = 0u;
    c.overflowed = false;
    c.next = 0u;
    c.end = 0u;
    c.whole = false;
    return c;
}

// A cursor at the invocation's tile list (BVH_TILE_NODE) or else at the root; empty when there are no spheres.
BvhCursor bvh_cursor_begin(uint sphere_count) {
    BvhCursor c = bvh_cursor_begin_root(sphere_count);
#ifdef BVH_TILE_NODE
    if (sphere_count > 0u) {
        uvec2 r = bvh_tile_range();
        c.size = 0u;
        c.next = r.x;
        c.end = r.y;
    }
#endif
    return c;
}

// The two cursor steps below are macros over the caller's own cursor variable, not functions: a GLSL
// function takes an `inout` argument by copy (in and out), and llvmpipe copied the whole stack at every
// step (the `isg` shade pass on the bunny lost about 10-15 % to it; README, "Speed").

// bool bvh_cursor_next(BvhCursor c, out uint node): pops the next node to visit into `node` (the stack's top,
// else the next start node); false (and `node` untouched) when the traversal is finished.
// A list entry's bit 31 marks a node the tile takes whole (BVH_TILE_WHOLE): bvh_cursor_whole(c) then holds until
// the next pop, and the traversal must visit the node as if it were a leaf.
#ifdef BVH_TILE_NODE
const uint BVH_TILE_WHOLE = 0x80000000u;
#define bvh_cursor_next(c, node) \
    ((c).size == 0u \
         ? ((c).next >= (c).end ? false \
                                : ((node) = BVH_TILE_NODE((c).next) & ~BVH_TILE_WHOLE, \
                                   (c).whole = (BVH_TILE_NODE((c).next) & BVH_TILE_WHOLE) != 0u, (c).next += 1u, \
                                   BVH_VISITED(), true)) \
         : ((c).size -= 1u, (node) = (c).stack[(c).size], (c).whole = false, BVH_VISITED(), true))
#else
#define bvh_cursor_next(c, node) \
    ((c).size == 0u ? false : ((c).size -= 1u, (node) = (c).stack[(c).size], BVH_VISITED(), true))
#endif

// bool bvh_cursor_push_children(BvhCursor c, uint left, uint right): pushes both children (the left
// one is visited first). Returns false, pushes nothing and sets c.overflowed when there is no room for
// both: the caller must then take the node whole (use its bounding sphere as if it were a leaf). That
// is conservative for blocking, since the node's sphere contains every sphere below it: overflow can
// only add occlusion, never lose it.
#define bvh_cursor_push_children(c, left, right) \
    ((c).size + 2u > uint(BVH_STACK_SIZE) \
         ? ((c).overflowed = true, false) \
         : ((c).stack[(c).size] = (right), (c).stack[(c).size + 1u] = (left), (c).size += 2u, true))

// Whether the node last popped must be visited whole (a list entry of the tile's level of detail).
#define bvh_cursor_whole(c) ((c).whole)

bool bvh_is_leaf(BvhNode n) {
    return n.left == BVH_INVALID;
}

vec4 bvh_sphere(BvhNode n) {
    return vec4(n.center, n.radius);
}

// Bounded reach (option `reach` of isg, lobes and shexp; an approximation, 0: off; the technique sets bvh_reach
// from its parameters before its traversals): a blocker sphere whose centre lies d from the receiver blocks with
// its radius scaled by clamp((reach − d) / (BVH_REACH_FADE reach), 0, 1), so that it fades out continuously (no
// pop as a character walks past the reach) and is gone from d = reach on; a node with d − R ≥ reach holds only
// spheres with d ≥ reach and is dropped with its subtree. Unreal's capsule shadows bound their reach the same way
// (r.CapsuleMaxDirectOcclusionDistance).
float bvh_reach = 0.0;
const float BVH_REACH_FADE = 0.25;

bool bvh_beyond_reach(vec3 p, vec4 s) {
    return bvh_reach > 0.0 && distance(p, s.xyz) - s.w >= bvh_reach;
}

vec4 bvh_reach_fade(vec3 p, vec4 s) {
    if (!(bvh_reach > 0.0)) return s;
    return vec4(s.xyz, s.w * clamp((bvh_reach - distance(p, s.xyz)) / (BVH_REACH_FADE * bvh_reach), 0.0, 1.0));
}

// "Subtends less than theta_max" cut test (SHEXP Eq. 36) with sin(theta_max) precomputed, from every
// point of the receiver sphere (radius 0 for a point). A node passing it may be taken whole.
// Twin: engine_blockers::geom::subtends_less_than.
bool bvh_subtends_less_than(vec4 receiver, vec4 s, float sin_theta_max) {
    return s.w < sin_theta_max * (distance(receiver.xyz, s.xyz) - receiver.w);
}

// Cone-sphere culling (ISG Sec. 5, Fig. 5): whether sphere s can block any direction of the cone.
// Exact (see spheres.glsl); a node that fails culls its whole subtree.
bool bvh_cone_hits(vec3 apex, vec3 axis, float half_angle, vec4 s) {
    return cone_intersects_sphere(apex, axis, half_angle, s);
}

#endif // BVH_GLSL
