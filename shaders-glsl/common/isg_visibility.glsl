// Visibility of one spherical Gaussian lobe by integral spherical Gaussians over a patch grid
// (Iwasaki et al. 2012, Sec. 4.1 and 5). f32 twin of engine::passes::shade::isg::cpu.
//
// For a lobe with unit axis a and sharpness λ at receiver p (unit normal n):
// 1. the limiting angle Γ: exp(λ(cos Γ − 1)) = ε (Γ = π/2 when λ ≤ −ln ε);
// 2. a P × P grid of patches over (θ, φ) ∈ [π/2 − Γ, π/2 + Γ]² in the ISG frame
//    Ω(θ, φ) = (sin θ cos φ, cos θ, sin θ sin φ) with the axis at (π/2, π/2) (see isg.glsl);
// 3. the sphere BVH is traversed with a cone around a that covers the grid; a node whose angular
//    radius is below `node_threshold` patch widths is taken whole, leaves always; each blocker passes
//    the SHEXP self-shadowing rule (spheres.glsl) and marks the patches whose CENTRE direction lies
//    in its cap of directions (exact per row: one acos per row);
// 4. the receiver's own tangent plane occludes the patches below it (V = 0 there);
// 5. occluded patches are summed run by run along each row with the four-corner rule of Ŝ.
// The result is the occluded part of the lobe's integral normalized by its hemisphere integral
// (Ŝ units): visible integral = μ (F(λ) − H(λ) · occluded), F the sphere and H the hemisphere integral.
//
// The includer defines, before including this file:
//   ISG_BVH_NODE(i)   an expression giving BvhNode number i (bvh.glsl), e.g. bvh_nodes[i];
//   ISG_LUT_FETCH(i)  float number i of the ISG table (isg.glsl), for the table evaluator;
//   optionally ISG_THIN and the macros of isg_thin.glsl: thin-shell triangles join the blockers;
//   optionally ISG_PLANES and the macros of isg_planes.glsl: plane blockers join them.
#ifndef ISG_VISIBILITY_GLSL
#define ISG_VISIBILITY_GLSL

#include "isg.glsl"
#include "bvh.glsl"
#include "frame.glsl"

// Patches per side at most (one 32-bit mask word per row).
#define ISG_MAX_SIDE 32

// The occluded patches of the grid being marked, one word per row (bit j: patch j of the row). One grid
// at a time per invocation: the functions below mark and read this array instead of taking it as an
// argument, because a GLSL function takes an array argument by copy and llvmpipe copied all 32 words at
// every call (README, "Speed").
uint isg_mask[ISG_MAX_SIDE];

void isg_mask_clear() {
    for (int i = 0; i < ISG_MAX_SIDE; ++i) isg_mask[i] = 0u;
}

// Work counters of the cost model (option `counters` of technique isg compiles ISG_COUNTERS, and
// the shader then shows them instead of radiance): 0 BVH nodes of the hemisphere traversal, 1 BVH
// nodes of the lobe traversals, 2 caps marked (spheres, the horizon, half-spaces), 3 cap rows (one
// acos each), 4 patch radiance lookups of diffuse=map, 5 Ŝ corner evaluations. Kept in workgroup
// memory, 6 slots per invocation of a 64-invocation group (as private globals, llvmpipe's JIT compile
// of this shader ran past 4 minutes). No-ops in the radiance shader.
#ifdef ISG_COUNTERS
shared uint s_isg_count[6 * 64];
#define ISG_COUNT(i, n) s_isg_count[6u * gl_LocalInvocationIndex + (i)] += uint(n)
#else
#define ISG_COUNT(i, n)
#endif

const int ISG_EVAL_TABLE = 0;
const int ISG_EVAL_PAPER = 1;

struct IsgSettings {
    int side;              // patches per side P, 1..32 (P² patches)
    float log_epsilon;     // ln ε of the limiting angle (ε = 0.01 by default)
    float node_threshold;  // a BVH node is taken whole below this angular radius, in patch widths
    int evaluator;         // ISG_EVAL_TABLE or ISG_EVAL_PAPER
};

struct IsgGrid {
    vec3 x;          // local frame: z = lobe axis, y = pole of the (θ, φ) parameterization
    vec3 y;
    vec3 z;
    float lo;        // π/2 − Γ: first grid line in θ and in φ
    float delta;     // patch width 2Γ / P
    int side;
    float cone;      // half-angle of the cone around z that holds the whole grid: acos(cos² Γ)
};

float isg_limiting_angle(float lambda, float log_epsilon) {
    float c = 1.0 + log_epsilon / max(lambda, 1e-30);
    return c <= 0.0 ? ISG_HALF_PI : acos(c);
}

IsgGrid isg_grid(vec3 axis, float lambda, IsgSettings st) {
    IsgGrid g;
    g.z = axis;
    orthonormal_basis(axis, g.x, g.y);
    float gamma = isg_limiting_angle(lambda, st.log_epsilon);
    g.side = clamp(st.side, 1, ISG_MAX_SIDE);
    g.lo = ISG_HALF_PI - gamma;
    g.delta = 2.0 * gamma / float(g.side);
    float c = cos(gamma);
    g.cone = acos(clamp(c * c, 0.0, 1.0));
    return g;
}

// Bits j0..j1 (inclusive) of a row mask.
uint isg_bit_range(int j0, int j1) {
    uint upto = j1 >= 31 ? 0xffffffffu : ((2u << uint(j1)) - 1u);
    return upto & ~((1u << uint(j0)) - 1u);
}

// Bits of row i's patches whose centre lies in the cap {ω : ω·u ≥ cos ψ}, u given in the grid's
// coordinates as rho = |(u·x, u·z)|, uy = u·y and phi_c = atan(u·z, u·x) (exact per row: one acos).
uint isg_cap_row_bits(IsgGrid g, int i, float rho, float uy, float phi_c, float cos_psi) {
    uint full = isg_bit_range(0, g.side - 1);
    float last = float(g.side - 1);
    float th = g.lo + (float(i) + 0.5) * g.delta;
    float denom = sin(th) * rho;
    float rhs = cos_psi - cos(th) * uy;
    if (denom < 1e-7) return rhs <= 0.0 ? full : 0u;
    float q = rhs / denom;
    if (q <= -1.0) return full;
    if (q > 1.0) return 0u;
    float w = acos(q);
    uint bits = 0u;
    for (int k = -1; k <= 1; ++k) {
        float c = phi_c + 2.0 * ISG_PI * float(k);
        int j_lo = int(clamp(ceil((c - w - g.lo) / g.delta - 0.5), 0.0, last + 1.0));
        int j_hi = int(clamp(floor((c + w - g.lo) / g.delta - 0.5), -1.0, last));
        if (j_lo <= j_hi) bits |= isg_bit_range(j_lo, j_hi);
    }
    return bits;
}

// The grid coordinates of unit u for isg_cap_row_bits: (rho, uy, phi_c), and theta_c in w.
vec4 isg_cap_coords(IsgGrid g, vec3 u) {
    float ux = dot(u, g.x);
    float uy = dot(u, g.y);
    float uz = dot(u, g.z);
    float rho = sqrt(ux * ux + uz * uz);
    return vec4(rho, uy, rho > 0.0 ? atan(uz, ux) : 0.0, atan(rho, uy));
}

// The rows [lo, hi] whose patch centres can lie in the cap of half-angle psi < π about the direction
// with grid coordinates uc (isg_cap_coords; uc.w its θ).
ivec2 isg_cap_rows(IsgGrid g, float psi, vec4 uc) {
    float last = float(g.side - 1);
    int i_lo = int(clamp(ceil((uc.w - psi - g.lo) / g.delta - 0.5), 0.0, last + 1.0));
    int i_hi = int(clamp(floor((uc.w + psi - g.lo) / g.delta - 0.5), -1.0, last));
    return ivec2(i_lo, i_hi);
}

// Marks in isg_mask the patches whose centre lies in the cap of half-angle psi around the unit
// direction u.
void isg_mark_cap(IsgGrid g, vec3 u, float psi) {
    if (psi >= ISG_PI) {
        uint full = isg_bit_range(0, g.side - 1);
        for (int i = 0; i < g.side; ++i) isg_mask[i] = full;
        return;
    }
    vec4 uc = isg_cap_coords(g, u);
    float cos_psi = cos(psi);
    ivec2 rows = isg_cap_rows(g, psi, uc);
    ISG_COUNT(2, 1);
    ISG_COUNT(3, max(rows.y - rows.x + 1, 0));
    for (int i = rows.x; i <= rows.y; ++i) isg_mask[i] |= isg_cap_row_bits(g, i, uc.x, uc.y, uc.z, cos_psi);
}

// Ŝ at a corner given its warped coordinates (table) or its angles (the paper's fit).
float isg_corner(float theta, float phi, float st, float sp, float lambda, int evaluator, float fl) {
#ifdef ISG_LUT_FETCH
    if (evaluator == ISG_EVAL_TABLE) return isg_lut_at(st, sp, fl);
#endif
    return isg_paper(theta, phi, lambda);
}

float isg_warp_of(float x, vec2 wc, int evaluator) {
    return evaluator == ISG_EVAL_TABLE ? isg_lut_warp(x, wc) : 0.0;
}

// Sum of the normalized ISG over the patches marked in isg_mask, run by run along each row (the warps
// of a row's two θ lines are shared by its runs).
float isg_occluded_sum(IsgGrid g, float lambda, int evaluator) {
    vec2 wc = isg_lut_warp_consts(lambda);
    float fl = isg_lut_slice(lambda);
    float sum = 0.0;
    for (int i = 0; i < g.side; ++i) {
        uint m = isg_mask[i];
        if (m == 0u) continue;
        float t0 = g.lo + float(i) * g.delta;
        float t1 = t0 + g.delta;
        float s0 = isg_warp_of(t0, wc, evaluator);
        float s1 = isg_warp_of(t1, wc, evaluator);
        while (m != 0u) {
            int j0 = findLSB(m);
            uint ones = m >> uint(j0);
            int run = findLSB(~ones);
            if (run < 0) run = 32 - j0;
            int j1 = j0 + run;  // exclusive
            m &= ~isg_bit_range(j0, j1 - 1);
            float p0 = g.lo + float(j0) * g.delta;
            float p1 = g.lo + float(j1) * g.delta;
            float q0 = isg_warp_of(p0, wc, evaluator);
            float q1 = isg_warp_of(p1, wc, evaluator);
            ISG_COUNT(5, 4);
            sum += isg_corner(t1, p1, s1, q1, lambda, evaluator, fl) - isg_corner(t0, p1, s0, q1, lambda, evaluator, fl)
                 - isg_corner(t1, p0, s1, q0, lambda, evaluator, fl) + isg_corner(t0, p0, s0, q0, lambda, evaluator, fl);
        }
    }
    return max(sum, 0.0);
}

#include "isg_thin.glsl"  // thin shells under ISG_THIN, no-op stubs otherwise
#include "isg_planes.glsl"  // plane blockers under ISG_PLANES, no-op stubs otherwise

// The blockers seen from one receiver, gathered once and shared by all lobes of the point: each as
// its cap of directions (unit centre direction, half-angle), after the self-shadowing rule. One list
// per invocation, kept here rather than passed around for the same reason as isg_mask.
#ifndef ISG_MAX_BLOCKERS
#define ISG_MAX_BLOCKERS 64
#endif
vec4 isg_caps[ISG_MAX_BLOCKERS];
int isg_cap_count = 0;
// Blockers that found the list full (the caller must then not use the list).
int isg_caps_dropped = 0;

void isg_add_blocker(vec3 p, vec3 n, vec4 s) {
    s = bvh_reach_fade(p, s);
    vec4 blk;
    if (!blocker_for_receiver(p, n, s, blk) || blk.w <= 0.0) return;
    vec3 d = blk.xyz - p;
    float dist = length(d);
    if (dist <= 0.0) return;
    if (isg_cap_count >= ISG_MAX_BLOCKERS) {
        isg_caps_dropped += 1;
        return;
    }
    isg_caps[isg_cap_count] = vec4(d / dist, sphere_subtended_half_angle(p, blk));
    isg_cap_count += 1;
}

// Traverse the BVH from p within the cone (axis, half_angle) into the blocker list (isg_caps): nodes
// below `take_whole` radians of angular radius (and nodes that do not fit on the stack) are taken
// whole, leaves always.
void isg_gather(vec3 p, vec3 n, vec3 axis, float half_angle, float take_whole, uint sphere_count) {
    isg_cap_count = 0;
    isg_caps_dropped = 0;
    BvhCursor cur = bvh_cursor_begin(sphere_count);
    uint node;
    while (bvh_cursor_next(cur, node)) {
        BvhNode nd = ISG_BVH_NODE(node);
        vec4 s = bvh_sphere(nd);
        ISG_COUNT(1, 1);
        if (!bvh_cone_hits(p, axis, half_angle, s) || bvh_beyond_reach(p, s)) continue;
        if (!bvh_is_leaf(nd) && !bvh_cursor_whole(cur)) {
            // Always descend while p is inside the node (its angular radius is then π).
            float psi = sphere_subtended_half_angle(p, s);
            if (psi >= take_whole && bvh_cursor_push_children(cur, nd.left, nd.right)) continue;
        }
        isg_add_blocker(p, n, s);
    }
}

// Occluded parts of the lobe (axis, λ), in Ŝ units: x = by the receiver's own tangent plane alone
// (directions below it, where the surface itself blocks: V = 0), y = by the plane and the gathered
// blockers (isg_caps) together. The lobe's visible integral is μ (F − H y); its integral over the
// receiver's upper hemisphere is μ (F − H x). Uses (and leaves) isg_mask.
// The lobe's grid with isg_mask cleared and the patches below the receiver's tangent plane marked; their
// occluded sum (Ŝ units) in `horizon`.
IsgGrid isg_horizon_grid(vec3 n, vec3 axis, float lambda, IsgSettings st, out float horizon) {
    IsgGrid g = isg_grid(axis, lambda, st);
    isg_mask_clear();
    horizon = 0.0;
    if (spheres_angle_between(axis, -n) <= g.cone + ISG_HALF_PI) {
        isg_mark_cap(g, -n, ISG_HALF_PI);
        horizon = isg_occluded_sum(g, lambda, st.evaluator);
    }
    return g;
}

vec2 isg_occlusion_of(vec3 n, vec3 axis, float lambda, IsgSettings st) {
    float horizon;
    IsgGrid g = isg_horizon_grid(n, axis, lambda, st, horizon);
    bool marked = false;
    for (int c = 0; c < isg_cap_count; ++c) {
        vec4 cap = isg_caps[c];
        // Cone test of the cap against the cone holding the grid.
        if (spheres_angle_between(axis, cap.xyz) > g.cone + cap.w) continue;
        isg_mark_cap(g, cap.xyz, cap.w);
        marked = true;
    }
#ifdef ISG_THIN
    if (isg_thin_mark(g)) marked = true;  // thin-shell triangles (isg_thin.glsl)
#endif
    if (isg_planes_mark(g)) marked = true;  // plane blockers (isg_planes.glsl)
    return vec2(horizon, marked ? isg_occluded_sum(g, lambda, st.evaluator) : horizon);
}

// Traverse the BVH from p over the hemisphere above n and mark every blocker's cap (after the
// self-shadowing rule) straight into isg_mask: no blocker list, so no overflow. Nodes below
// `take_whole` radians of angular radius are taken whole, leaves always.
void isg_mark_traversed(IsgGrid g, vec3 p, vec3 n, float take_whole, uint sphere_count) {
    BvhCursor cur = bvh_cursor_begin(sphere_count);
    uint node;
    while (bvh_cursor_next(cur, node)) {
        BvhNode nd = ISG_BVH_NODE(node);
        vec4 s = bvh_sphere(nd);
        ISG_COUNT(0, 1);
        if (!bvh_cone_hits(p, g.z, g.cone, s) || bvh_beyond_reach(p, s)) continue;
        if (!bvh_is_leaf(nd) && !bvh_cursor_whole(cur)) {
            float psi = sphere_subtended_half_angle(p, s);
            if (psi >= take_whole && bvh_cursor_push_children(cur, nd.left, nd.right)) continue;
        }
        vec4 blk;
        if (!blocker_for_receiver(p, n, bvh_reach_fade(p, s), blk) || blk.w <= 0.0) continue;
        vec3 d = blk.xyz - p;
        float dist = length(d);
        if (dist <= 0.0) continue;
        isg_mark_cap(g, d / dist, sphere_subtended_half_angle(p, blk));
    }
}

// ∫ over patch row i of sin²θ dθ: with ∫ sin φ dφ over a run, the cosine-weighted solid angle of the
// patches of the hemisphere grid (Ω = (sin θ cos φ, cos θ, sin θ sin φ), n = z: cos = sin θ sin φ).
float isg_row_sin2(IsgGrid g, int i) {
    float t0 = g.lo + float(i) * g.delta;
    float t1 = t0 + g.delta;
    return 0.5 * ((t1 - sin(t1) * cos(t1)) - (t0 - sin(t0) * cos(t0)));
}

// The same with the lobe's own traversal (cone and node threshold from its own grid) marking the grid
// directly (isg_mark_traversed), with no blocker list: a list of ISG_MAX_BLOCKERS dropped the blockers past
// it, and a glossy lobe grazing a row of chess pieces meets more (issue 35: a black piece's highlight kept
// 85 % of its light where the proxy hides 93 % of it).
vec2 isg_occlusion(vec3 p, vec3 n, vec3 axis, float lambda, IsgSettings st, uint sphere_count) {
    float horizon;
    IsgGrid g = isg_horizon_grid(n, axis, lambda, st, horizon);
    bool marked = sphere_count > 0u;
    if (marked) isg_mark_traversed(g, p, n, st.node_threshold * g.delta, sphere_count);
#ifdef ISG_THIN
    if (isg_thin_mark(g)) marked = true;
#endif
    if (isg_planes_mark(g)) marked = true;
    return vec2(horizon, marked ? isg_occluded_sum(g, lambda, st.evaluator) : horizon);
}

#endif // ISG_VISIBILITY_GLSL
