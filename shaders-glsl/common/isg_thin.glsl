// Thin shells in the ISG patch grid (Iwasaki et al. 2012, Sec. 5: "our method projects triangle meshes
// instead of spheres, calculating the occluded patches by rasterizing the projected triangle meshes").
// f64 twin: engine::passes::shade::isg::thin (mark_triangle, mark_thin).
//
// For the receiver p (set once per shading point by isg_thin_begin) and one lobe's grid (isg_grid):
// 1. clusters of thin triangles are culled by the same exact cone test as the sphere BVH (bvh_cone_hits
//    with the cone holding the grid) and by the receiver's tangent plane (a cluster wholly below it only
//    covers patches the horizon already occludes);
// 2. each triangle passes the self-shadowing rule of thin.glsl (plane not within ε of p, nonzero area)
//    and is skipped when wholly below the tangent plane;
// 3. it is projected onto the unit sphere around p and rasterized tile by tile: the tile is the rows
//    of the cluster's bounding cap (padded by ISG_THIN_PAD), which bound the rows of each of its
//    triangles; the candidate patches are the tile's not yet occluded ones (a cluster with none is
//    skipped whole), and a candidate is occluded when its centre direction lies inside the spherical
//    triangle: the three sign tests dot(e_k, ω) ≥ 0 with e_k the edge-plane normals a × b, b × c,
//    c × a oriented by det(a, b, c) (ω = αa + βb + γc with α, β, γ ≥ 0: the ray along ω hits the
//    triangle in front of p; −ω would give the opposite signs). Each triangle visits the rows of its
//    own bounding cap, and per row each sign test is solved for the row's columns in closed form
//    (an arc of the row's circle), so no loop runs over patches (see isg_thin_mark).
// The marks are OR-ed into the same row masks as the spheres' caps and the horizon, so spheres and thin
// triangles combine.
//
// Without ISG_THIN, no-op stubs of isg_thin_begin, isg_thin_present and isg_thin_mark. With it, the
// includer defines, before including isg_visibility.glsl:
//   ISG_THIN_TRIANGLE(i)     ThinTriangle number i (thin.glsl);
//   ISG_THIN_CLUSTER(i)      ThinCluster number i;
//   ISG_THIN_CLUSTER_COUNT   the number of clusters (cluster 0 with no triangles: no thin meshes).
// isg_visibility.glsl includes this file after IsgGrid and isg_bit_range.
#ifndef ISG_THIN_GLSL
#define ISG_THIN_GLSL

#ifndef ISG_THIN
// No thin shells: the hooks compile to nothing.
void isg_thin_begin(vec3 p, vec3 n) {}
bool isg_thin_present() {
    return false;
}
bool isg_thin_mark(IsgGrid g) {
    return false;
}
#else

#include "thin.glsl"

// Angular padding (radians) of a cluster's bounding cap: covers the f32 and lavapipe errors of acos
// and atan (≤ 4e-4), so the tile holds every patch the sign tests can accept.
const float ISG_THIN_PAD = 2e-3;

// The shading point the thin triangles are seen from (isg_thin_begin, once per point).
vec3 g_isg_thin_p = vec3(0.0);
vec3 g_isg_thin_n = vec3(0.0, 1.0, 0.0);

void isg_thin_begin(vec3 p, vec3 n) {
    g_isg_thin_p = p;
    g_isg_thin_n = n;
}

bool isg_thin_present() {
    return ISG_THIN_CLUSTER(0).count > 0u;
}

// Sines and cosines of the patch rows' centre angles θ_i = lo + (i + ½) δ, filled once per grid on first
// use.
float g_isg_thin_sin[ISG_MAX_SIDE];
float g_isg_thin_cos[ISG_MAX_SIDE];

void isg_thin_tables(IsgGrid g) {
    for (int i = 0; i < g.side; ++i) {
        float a = g.lo + (float(i) + 0.5) * g.delta;
        g_isg_thin_sin[i] = sin(a);
        g_isg_thin_cos[i] = cos(a);
    }
}

// One edge plane of a triangle in the grid's frame, prepared for rasterizing rows: e (its oriented
// normal), r = |e.xz| and φ_e = atan2(e.z, e.x), so that for the centre ω = (sin θ cos φ, cos θ,
// sin θ sin φ): e·ω = r sin θ cos(φ − φ_e) + e.y cos θ.
struct IsgThinEdge {
    vec3 e;
    float r;
    float phi;
};

IsgThinEdge isg_thin_edge(vec3 e) {
    IsgThinEdge h;
    h.e = e;
    h.r = length(e.xz);
    h.phi = h.r > 0.0 ? atan(e.z, e.x) : 0.0;
    return h;
}

// The columns of row (sin θ, cos θ) whose centre ω has e·ω ≥ 0: the arc |φ − φ_e| ≤ acos(−e.y cos θ /
// (r sin θ)) of the row's circle, as bit ranges (the same closed form as a cap's row in isg_mark_cap).
// Equivalent to testing every centre's sign (the f64 twin does that); they differ only for centres
// within f32 rounding of the edge.
uint isg_thin_edge_bits(IsgGrid g, IsgThinEdge h, float st, float ct, uint full) {
    float rs = h.r * st;
    float rhs = -h.e.y * ct;
    if (!(rs > 1e-7 * length(h.e))) return rhs <= 0.0 ? full : 0u;
    float q = rhs / rs;
    if (q <= -1.0) return full;
    if (q > 1.0) return 0u;
    float w = acos(q);
    float last = float(g.side - 1);
    uint bits = 0u;
    for (int k = -1; k <= 1; ++k) {
        float c = h.phi + 2.0 * ISG_PI * float(k);
        int j_lo = int(clamp(ceil((c - w - g.lo) / g.delta - 0.5), 0.0, last + 1.0));
        int j_hi = int(clamp(floor((c + w - g.lo) / g.delta - 0.5), -1.0, last));
        if (j_lo <= j_hi) bits |= isg_bit_range(j_lo, j_hi);
    }
    return bits;
}

// Marks the patches of grid g occluded by the thin triangles, seen from g_isg_thin_p. Returns whether
// any cluster had candidate patches.
//
// Written for lavapipe's loop limiter (llvmpipe ends every loop once 65535 loop iterations in total
// have run in one shader invocation, LP_MAX_TGSI_LOOP_ITERATIONS; later loops then run once and the
// result is silently wrong): a triangle visits only the rows of its own bounding cap and fills each
// row with three closed-form column spans (isg_thin_edge_bits), no loop over patches. On `sheet`
// (1152 triangles) at 100 × 75 this runs at most ≈ 5.7k loop iterations per pixel in `diffuse=map` and
// ≈ 34k with `diffuse=sg|ratio` (K = 10, P = 32, a grid per lobe); `K=16` reaches the limit at a few
// percent of the pixels.
bool isg_thin_mark(IsgGrid g) {
    if (!isg_thin_present()) return false;
    vec3 p = g_isg_thin_p;
    vec3 n = g_isg_thin_n;
    uint clusters = ISG_THIN_CLUSTER_COUNT;
    bool have_tables = false;
    bool marked = false;
    uint full = isg_bit_range(0, g.side - 1);
    float last = float(g.side - 1);
    for (uint k = 0u; k < clusters; ++k) {
        ThinCluster cl = ISG_THIN_CLUSTER(k);
        if (cl.count == 0u) continue;
        if (dot(cl.bound.xyz - p, n) < -cl.bound.w) continue;
        if (!bvh_cone_hits(p, g.z, g.cone, cl.bound)) continue;
        // The cluster's tile: the rows of its bounding cap (padded). Its columns are left to each
        // triangle's own spans (a cap's columns cost an acos per row, about as much as the spans).
        vec3 d = cl.bound.xyz - p;
        float dist = length(d);
        float psi = sphere_subtended_half_angle(p, cl.bound) + ISG_THIN_PAD;
        int i_lo = 0;
        int i_hi = g.side - 1;
        if (psi < ISG_PI && dist > 0.0) {
            vec3 u = d / dist;
            float theta_c = atan(length(vec2(dot(u, g.x), dot(u, g.z))), dot(u, g.y));
            i_lo = int(clamp(ceil((theta_c - psi - g.lo) / g.delta - 0.5), 0.0, last + 1.0));
            i_hi = int(clamp(floor((theta_c + psi - g.lo) / g.delta - 0.5), -1.0, last));
        }
        // Skipped whole when every patch of its rows is occluded already (usually the first row
        // decides: one iteration).
        bool open_row = false;
        for (int i = i_lo; i <= i_hi; ++i) {
            if (isg_mask[i] != full) {
                open_row = true;
                break;
            }
        }
        if (!open_row) continue;
        marked = true;
        if (!have_tables) {
            isg_thin_tables(g);
            have_tables = true;
        }
        for (uint t = cl.first; t < cl.first + cl.count; ++t) {
            ThinTriangle tri = ISG_THIN_TRIANGLE(t);
            vec3 a = tri.v0.xyz - p;
            vec3 b = tri.v1.xyz - p;
            vec3 c = tri.v2.xyz - p;
            // Wholly below the tangent plane: only patches the horizon occludes.
            if (dot(a, n) <= 0.0 && dot(b, n) <= 0.0 && dot(c, n) <= 0.0) continue;
            float orient;
            if (!thin_blocks_receiver(a, b, c, orient)) continue;
            // The triangle's rows: those of its bounding cap (centre the normalized sum of its unit
            // vertex directions, radius the farthest vertex, padded), within the cluster's.
            vec3 ua = normalize(a);
            vec3 ub = normalize(b);
            vec3 uc = normalize(c);
            vec3 s = ua + ub + uc;
            float sl = length(s);
            int t_lo = i_lo;
            int t_hi = i_hi;
            if (sl > 1e-6) {
                vec3 u = s / sl;
                float tpsi = acos(clamp(min(dot(u, ua), min(dot(u, ub), dot(u, uc))), -1.0, 1.0)) + ISG_THIN_PAD;
                if (tpsi < ISG_HALF_PI) {
                    float uy = dot(u, g.y);
                    float rho = length(vec2(dot(u, g.x), dot(u, g.z)));
                    float theta_c = atan(rho, uy);
                    t_lo = max(t_lo, int(clamp(ceil((theta_c - tpsi - g.lo) / g.delta - 0.5), 0.0, last + 1.0)));
                    t_hi = min(t_hi, int(clamp(floor((theta_c + tpsi - g.lo) / g.delta - 0.5), -1.0, last)));
                }
            }
            if (t_lo > t_hi) continue;
            // Edge-plane normals (a × b written a × (b − a): better conditioned), oriented, in the
            // grid's frame: ω is inside the spherical triangle iff e_k·ω ≥ 0 for all three.
            vec3 n0 = orient * cross(a, b - a);
            vec3 n1 = orient * cross(b, c - b);
            vec3 n2 = orient * cross(c, a - c);
            IsgThinEdge h0 = isg_thin_edge(vec3(dot(n0, g.x), dot(n0, g.y), dot(n0, g.z)));
            IsgThinEdge h1 = isg_thin_edge(vec3(dot(n1, g.x), dot(n1, g.y), dot(n1, g.z)));
            IsgThinEdge h2 = isg_thin_edge(vec3(dot(n2, g.x), dot(n2, g.y), dot(n2, g.z)));
            for (int i = t_lo; i <= t_hi; ++i) {
                uint m = full & ~isg_mask[i];
                if (m == 0u) continue;
                float st = g_isg_thin_sin[i];
                float ct = g_isg_thin_cos[i];
                m &= isg_thin_edge_bits(g, h0, st, ct, full);
                m &= isg_thin_edge_bits(g, h1, st, ct, full);
                m &= isg_thin_edge_bits(g, h2, st, ct, full);
                isg_mask[i] |= m;
            }
        }
    }
    return marked;
}

#endif // ISG_THIN
#endif // ISG_THIN_GLSL
