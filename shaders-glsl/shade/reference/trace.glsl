// Ray visibility for the reference: stack traversal of the triangle BVH built on the CPU
// (twin of engine::scene::triangle_bvh, whose tests check the CPU traversal against brute force).
#ifndef REFERENCE_TRACE_GLSL
#define REFERENCE_TRACE_GLSL

// Internal nodes: count == 0, children at first and first + 1. Leaves: tris[first .. first + count].
struct TriNode {
    vec3 lo;
    uint first;
    vec3 hi;
    uint count;
};

struct Tri {
    vec4 v0;
    vec4 v1;
    vec4 v2;
};

layout(std430, binding = 10) readonly buffer TriNodes { TriNode tri_nodes[]; };
layout(std430, binding = 11) readonly buffer Tris { Tri tris[]; };

// The host checks that the BVH depth fits (ReferenceTables::build).
const int TRACE_STACK = 64;

// 1/d with zero components replaced by ±1e-20 first (twin of triangle_bvh::safe_recip).
vec3 safe_recip(vec3 d) {
    vec3 s = mix(vec3(-1e-20), vec3(1e-20), greaterThanEqual(d, vec3(0.0)));
    return 1.0 / mix(d, s, lessThan(abs(d), vec3(1e-20)));
}

// Entry distance of the ray into node n, or -1 if it misses within [0, t_max].
float node_entry(vec3 o, vec3 inv_d, uint n, float t_max) {
    vec3 t0 = (tri_nodes[n].lo - o) * inv_d;
    vec3 t1 = (tri_nodes[n].hi - o) * inv_d;
    vec3 a = min(t0, t1);
    vec3 b = max(t0, t1);
    float near = max(max(a.x, a.y), max(a.z, 0.0));
    float far = min(min(b.x, b.y), min(b.z, t_max));
    return near <= far ? near : -1.0;
}

// Möller–Trumbore; t in (0, t_max) or -1.
float intersect_triangle(vec3 o, vec3 d, vec3 p0, vec3 p1, vec3 p2, float t_max) {
    vec3 e1 = p1 - p0;
    vec3 e2 = p2 - p0;
    vec3 p = cross(d, e2);
    float det = dot(e1, p);
    if (det == 0.0) return -1.0;
    float inv = 1.0 / det;
    vec3 s = o - p0;
    float u = dot(s, p) * inv;
    if (u < 0.0 || u > 1.0) return -1.0;
    vec3 q = cross(s, e1);
    float v = dot(d, q) * inv;
    if (v < 0.0 || u + v > 1.0) return -1.0;
    float t = dot(e2, q) * inv;
    return (t > 0.0 && t < t_max) ? t : -1.0;
}

float intersect_tri(vec3 o, vec3 d, uint k, float t_max) {
    return intersect_triangle(o, d, tris[k].v0.xyz, tris[k].v1.xyz, tris[k].v2.xyz, t_max);
}

// Nearest hit distance in (0, t_max), or t_max if none; with `any`, the first hit found.
float trace_triangles(vec3 o, vec3 d, float t_max, bool any_hit) {
    if (tri_nodes.length() == 0 || tris.length() == 0) return t_max;
    vec3 inv_d = safe_recip(d);
    float best = t_max;
    uint stack[TRACE_STACK];
    int sp = 0;
    if (node_entry(o, inv_d, 0u, best) < 0.0) return t_max;
    stack[sp++] = 0u;
    while (sp > 0) {
        uint n = stack[--sp];
        uint count = tri_nodes[n].count;
        uint first = tri_nodes[n].first;
        if (count == 0u) {
            // Re-test against the current best, push the far child first so the near one pops first.
            float ta = node_entry(o, inv_d, first, best);
            float tb = node_entry(o, inv_d, first + 1u, best);
            if (ta >= 0.0 && tb >= 0.0) {
                bool a_near = ta <= tb;
                stack[sp++] = a_near ? first + 1u : first;
                stack[sp++] = a_near ? first : first + 1u;
            } else if (ta >= 0.0) {
                stack[sp++] = first;
            } else if (tb >= 0.0) {
                stack[sp++] = first + 1u;
            }
            continue;
        }
        for (uint k = first; k < first + count; ++k) {
            float t = intersect_tri(o, d, k, best);
            if (t > 0.0) {
                best = t;
                if (any_hit) return best;
            }
        }
    }
    return best;
}

// ---- sphere proxies: the blocker spheres and their BVH (written every frame by the blocker passes) ----
#include "../../common/bvh.glsl"
layout(std430, binding = 14) readonly buffer BlockerSpheres { vec4 blocker_spheres[]; };
layout(std430, binding = 15) readonly buffer BvhNodes { BvhNode bvh_nodes[]; };

// Entry and exit distances of the ray into sphere s (entry > exit when it misses).
vec2 ray_sphere(vec3 o, vec3 d, vec4 s) {
    vec3 oc = s.xyz - o;
    float b = dot(d, oc);
    // |oc|² − b² is the squared distance of the centre from the ray (non-negative by construction).
    vec3 perp = oc - b * d;
    float disc = s.w * s.w - dot(perp, perp);
    if (disc < 0.0) return vec2(1.0, -1.0);
    float q = sqrt(disc);
    return vec2(b - q, b + q);
}

// The receiver the current sample belongs to (set by the integrator before tracing): the sphere proxy
// seen from it is the blocker set after the SHEXP §6.2 self-shadowing rules (blocker_for_receiver in
// spheres.glsl), the same proxy the techniques see.
vec3 g_receiver_p = vec3(0.0);
vec3 g_receiver_n = vec3(0.0, 1.0, 0.0);

// Nearest entry distance in (0, t_max) into a blocker sphere, or t_max. Each leaf sphere is first
// replaced by its blocker for the receiver (eliminated behind the tangent plane, shrunk to tangency
// when the receiver is inside, the tangent sphere in front when it straddles); the replacement lies
// inside the original, so the BVH's bounds stay conservative. A blocker counts when the ray from the
// receiver itself, not from the offset origin o, enters it in front of the receiver: a blocker tangent
// to T_p next to p holds o (o is p moved along the normal), and traced from o it was never entered,
// so a ground point under a bunny sphere's centre, hidden by the proxy (and by isg), came out lit
// (issue 35). Overflow of the node stack takes the node's bounding sphere whole (conservative, as in
// bvh.glsl); with the LBVH's depth bound it never happens.
float trace_spheres(vec3 o, vec3 d, float t_max, uint sphere_count, bool any_hit) {
    float best = t_max;
    BvhCursor c = bvh_cursor_begin(sphere_count);
    uint node;
    while (bvh_cursor_next(c, node)) {
        BvhNode n = bvh_nodes[node];
        bool leaf = bvh_is_leaf(n);
        vec4 s = leaf ? blocker_spheres[n.sphere] : bvh_sphere(n);
        vec2 t = ray_sphere(o, d, s);
        if (t.x > t.y || t.y <= 0.0 || t.x >= best) continue;
        if (!leaf && bvh_cursor_push_children(c, n.left, n.right)) continue;
        if (leaf) {
            vec4 blk;
            if (!blocker_for_receiver(g_receiver_p, g_receiver_n, s, blk) || blk.w <= 0.0) continue;
            t = ray_sphere(g_receiver_p, d, blk);
            if (t.x > t.y || t.y <= 0.0 || t.x >= best) continue;
        }
        if (t.x > 0.0) {
            best = t.x;
            if (any_hit) return best;
        }
    }
    return best;
}

// ---- thin shells: the world-space triangles of meshes marked thin (written every frame by the
// thin_shells pass, so a simulated cloth is where the G-buffer draws it). For the sphere proxy they are
// their own proxy, seen through the same rule as in ISG (thin.glsl: a triangle whose plane passes within
// ε of the receiver, or of zero area, does not block it); for the triangle truth they are hit exactly,
// like the triangles of the BVH (the triangle BVH leaves them out) ----
#include "../../common/thin.glsl"
layout(std430, binding = 16) readonly buffer ThinTriangles { ThinTriangle thin_triangles[]; };
layout(std430, binding = 17) readonly buffer ThinClusters { ThinCluster thin_clusters[]; };

// Nearest hit distance in (0, t_max) on a thin triangle (one that blocks the receiver, with
// `receiver_rule`), or t_max. Clusters are culled by their bounding spheres.
float trace_thin(vec3 o, vec3 d, float t_max, bool any_hit, bool receiver_rule) {
    float best = t_max;
    if (thin_clusters[0].count == 0u) return best;
    uint clusters = uint(thin_clusters.length());
    for (uint k = 0u; k < clusters; ++k) {
        ThinCluster cl = thin_clusters[k];
        if (cl.count == 0u) continue;
        vec2 t = ray_sphere(o, d, cl.bound);
        if (t.x > t.y || t.y <= 0.0 || t.x >= best) continue;
        for (uint i = cl.first; i < cl.first + cl.count; ++i) {
            ThinTriangle tri = thin_triangles[i];
            float orient;
            vec3 p = g_receiver_p;
            if (receiver_rule && !thin_blocks_receiver(tri.v0.xyz - p, tri.v1.xyz - p, tri.v2.xyz - p, orient))
                continue;
            float h = intersect_triangle(o, d, tri.v0.xyz, tri.v1.xyz, tri.v2.xyz, best);
            if (h > 0.0) {
                best = h;
                if (any_hit) return best;
            }
        }
    }
    return best;
}

// ---- plane blockers (half-spaces and rectangles, world space, common/planes.glsl): part of the sphere
// proxy, seen through the same self-shadowing rule as in ISG (a receiver on the plane is not shadowed
// by it) ----
#include "../../common/planes.glsl"
layout(std430, binding = 21) readonly buffer BlockerPlanes {
    uint plane_count;
    BlockerPlane blocker_planes[];  // at least one record (zero when plane_count = 0)
};

// Nearest hit distance in (0, t_max) on a plane blocker of the receiver, or t_max.
float trace_planes(vec3 o, vec3 d, float t_max, bool any_hit) {
    float best = t_max;
    for (uint k = 0u; k < plane_count; ++k) {
        float t = plane_hit(blocker_planes[k], g_receiver_p, o, d, best);
        if (t > 0.0) {
            best = t;
            if (any_hit) return best;
        }
    }
    return best;
}

#endif
