// Technique `lobes` (engine passes::shade::lobes): cosine lobes for direct lighting (Meunier et al.
// 2009), per pixel and per vertex. f64 twin: engine::passes::shade::lobes::cpu (same tables, same
// quad-tree, same order of operations).
//
// Per receiver p (normal n, view v):
// - reflectance f̃_r = f_r · cos as lobes (§5.1): Lambert (n, ρ/π, e = 1); a Blinn-Phong specular
//   k_s (s+8)/(8π) (n·h)^s as the Phong lobe (r, e = s/4) times the cosine lobe (n, 1) through the
//   product table. Other specular kinds: the exact SG light term times the light's lobe visibility.
// - each spherical light j as one cap lobe (§5.2: axis to the centre, e_cap from the cap table),
//   scaled by L (light_scale=paper) or so that its integral is the cap's solid angle (=energy);
//   `sharpen` multiplies its exponent (1: the paper's L2 fit, which keeps ~38 % of its integral
//   outside the cap and so widens penumbrae).
// - R × L first (§5.4), each product from the product table; U = Σ ∫_{Ω+} (R_k L) from the
//   hemisphere table (§4.2).
// - visibility of light j (§5.3): blockers in the light's mask cone (a cut of the blocker BVH: leaves,
//   and nodes narrower than `take_whole` cells of the finest level taken whole as their bounding
//   sphere; at most LOBES_MAX_BLOCKERS, else the cut is retried coarser up to `coarsen` times; plane
//   blockers) classified against the cells
//   of a quad-tree over a square perpendicular to the light axis (gnomonic coordinates, half-angle
//   min(extent · α, 1.4)); a wholly covered mask hides the light (S = U); covered cells split down
//   to `split` (so that leaf lobes are narrower than the light's), then are shadow leaves; partial
//   cells split down to `depth`,
//   then are dropped (aggressive) or kept (conservative). Each shadow leaf is the cap lobe of its
//   bounding cone, weighted by w_i = weight · Ω_cell / ∫c_i (its integral equals the cell's solid
//   angle; the paper's hand-set w_i(dist, depth) replaced by this rule). S = Σ_i Σ_k w_i ∫_{Ω+} (R_k L) c_i.
//   Leaves are streamed (no leaf list); products whose integral is below threshold · U are pruned.
// - light j adds max(U − S, 0) (light=lobes) or the exact unshadowed term times
//   clamp(1 − S/U, 0, 1) (light=ratio, luminance-weighted).
// - environment: diffuse ρ/π max(E(n) − S_env, 0), E the shared irradiance, S_env from the same
//   mask machinery about n against the cosine lobe, each shadow leaf's product weighted by the
//   prefiltered environment at its axis (as isg's diffuse=map weighs its patches); plane blockers
//   multiply by their visibility: 1 − o/π (o their exact cosine-weighted solid angle) weighted by the
//   environment light they hide and leave free (lobes_env_planes). Glossy: the shared prefiltered
//   term times the diffuse visibility (luminance ratio).
// Overflow (more blockers in a mask's cone than LOBES_MAX_BLOCKERS after the coarsest cut) drops the narrowest
// caps and is counted in LobesStats,
// with a bound on the shadow the dropped blockers cast (g_dropped): its sum, the largest over receivers, and the
// receivers where it passes 1 %.
#include "../common.glsl"
#include "../prefiltered.glsl"
#include "../lights.glsl"
#include "../../common/lobes.glsl"
#include "../../common/frame.glsl"
#define BVH_STACK_SIZE 32
#include "../tiles.glsl"
#include "../../common/bvh.glsl"
// The cost split of option `phase` (the paper's Table 1; a timing variant, not an image): every receiver
// stops after phase 1 lobes (reflectance and light lobes, R × L, U and the unshadowed terms), 2 gather (+ the
// blocker cuts of every mask), 3 mask (+ the quad-trees' classification, leaves counted), 4 leaves (+ the
// shadow leaves' cap lobes and weights) or 5 all (+ the visibility products and their hemisphere integrals:
// the image). The work a stopped phase did stays live through a term of 1e-30 in the result, so that the
// compiler keeps it.
#ifndef LOBES_PHASE
#define LOBES_PHASE 5
#endif
#include "../../common/planes.glsl"

layout(binding = 8) uniform sampler2D irradiance_map;
layout(binding = 9) uniform sampler2D prefiltered_env;
layout(std430, binding = 10) readonly buffer LobeProduct { vec2 lobe_product_table[]; };
layout(std430, binding = 11) readonly buffer LobeHemisphere { vec2 lobe_hemisphere_table[]; };
layout(std430, binding = 12) readonly buffer LobeCap { float lobe_cap_table[]; };
layout(std430, binding = 13) readonly buffer BvhNodes { BvhNode bvh_nodes[]; };
// Twin: engine::passes::shade::lobes::GpuLobesParams.
struct LobesParams {
    uint sphere_count;
    uint depth;           // maximal quad-tree depth
    uint conservative;    // 1: partial leaves at the maximal depth shadow
    float threshold;      // t_i, relative to the light's unshadowed lobe integral U
    float weight;         // global factor of the leaf weights
    float extent;         // mask half-angle / light half-angle
    uint light_mode;      // 0 lobes, 1 ratio
    uint energy_scale;    // 1: light lobes scaled to the cap's solid angle
    uint split;           // covered cells split down to this depth
    float sharpen;        // the light lobes' exponent is e_cap times this
    float take_whole;     // BVH nodes below this many cells of the finest mask level are taken whole (0: leaves only)
    uint coarsen;         // on overflow, retries of the cut with take_whole doubled
    float light_weights[8];  // per-depth factors of the light masks' leaf weights (0..6 used)
    uint env_lobe_count;     // env=lobes: lobes in EnvLobes (0 with env=map)
    uint budget;             // work one mask may spend before it stops refining (option budget)
    uint env_black;          // 1: the environment is black everywhere (its term and mask are skipped)
    uint light_alpha;        // 1: the lights' masks take the receiver rules with α too (option light_rule)
    float reach;             // bounded reach (common/bvh.glsl), scene units; 0: off
};
layout(std430, binding = 14) readonly buffer LobesParamsBuf { LobesParams lp; };
// [0] receivers shaded, [1] receivers whose blocker list overflowed, [2] lobe products computed,
// [3] products pruned by the threshold, [4] shadow leaves, [5] receivers whose environment mask
// overflowed, [6] receivers where some light's mask overflowed. Cumulative (the host resets it).
// Counters (twin: engine::passes::shade::lobes::STATS_LEN).
#define LOBES_STATS 14
layout(std430, binding = 15) buffer LobesStats { uint lobes_stats[LOBES_STATS]; };
layout(std430, binding = 21) readonly buffer BlockerPlanes {
    uint plane_count;
    BlockerPlane blocker_planes[];  // at least one record (zero when plane_count = 0)
};

#define LOBES_PRODUCT_NE 97
#define LOBES_PRODUCT_NA 49
#define LOBES_HEMI_NE 769
#define LOBES_HEMI_NY 129
#define LOBES_CAP_N 1000
#define LOBES_MAX_BLOCKERS 64
#define LOBES_MAX_DEPTH 6
#define LOBES_STACK (3 * LOBES_MAX_DEPTH + 1)
#define LOBES_MAX_R (1 + BRDF_LAFORTUNE_LOBES)
const float LOBES_MASK_MAX_HALF_ANGLE = 1.4;
// llvmpipe ends every loop of an invocation once 65535 loop iterations have run in it (all loops together,
// and for the 8 lanes that run together): a deep mask over many blockers (depth 5–6 near a bunny's shadow edge)
// ran past it and lost its light. So each mask stops refining once it has spent this much work (a visited cell
// costs 4, each blocker or plane tested 1): later cells are leaves at their depth, as at the maximal depth.
// The receivers where that happened are counted (lobes_stats[7]) and reported. The budget is lp.budget
// (option `budget`, default engine::passes::shade::lobes::MASK_WORK_BUDGET).

struct Lobe {
    vec3 axis;
    float e;
    vec3 s;  // RGB scale
};

// env=lobes (LOBES_ENV_K = the option K > 0): the environment as fitted cosine lobes
// scale · max(axis·v, 0)^e (twin: engine::passes::shade::lobes::GpuEnvLobe), and the receiver's products
// R_r × L_k (k outer, r inner), which every leaf of the normal's mask multiplies.
#ifndef LOBES_ENV_K
#define LOBES_ENV_K 0
#endif
struct EnvLobe {
    vec4 axis_e;
    vec4 scale;
};
layout(std430, binding = 16) readonly buffer EnvLobes { EnvLobe env_lobes[]; };
#if LOBES_ENV_K > 0
Lobe g_env_rl[LOBES_MAX_R * LOBES_ENV_K];
int g_env_rl_count;
#endif

float lobes_lum(vec3 c) {
    return dot(c, vec3(0.2126, 0.7152, 0.0722));
}

// Linear interpolation weights on a table axis of n samples (twin of lobes::axis_lerp).
void lobes_axis(float coord, int n, out int i0, out int i1, out float f) {
    float c = clamp(coord, 0.0, float(n - 1));
    i0 = min(int(floor(c)), n - 1);
    i1 = min(i0 + 1, n - 1);
    f = c - float(i0);
}

// (ln p_r/peak, e_r) by trilinear lookup (twin of ProductTable::lookup_raw). Past the table
// (an exponent above 1e5) the SG product rule: e_r = |e1 a1 + e2 a2|, p_r = the peak.
vec2 lobes_product_raw(float e1, float e2, float alpha) {
    if (e1 > LOBES_MAX_EXPONENT || e2 > LOBES_MAX_EXPONENT) {
        return vec2(0.0, sqrt(max(e1 * e1 + e2 * e2 + 2.0 * e1 * e2 * cos(alpha), 0.0)));
    }
    int a0, a1, b0, b1, j0, j1;
    float fa, fb, fj;
    lobes_axis(lobe_exponent_coord(e1, 16.0), LOBES_PRODUCT_NE, a0, a1, fa);
    lobes_axis(lobe_exponent_coord(e2, 16.0), LOBES_PRODUCT_NE, b0, b1, fb);
    lobes_axis(lobe_alpha_coord(alpha, float(LOBES_PRODUCT_NA)), LOBES_PRODUCT_NA, j0, j1, fj);
    vec2 r = vec2(0.0);
    for (int ia = 0; ia < 2; ++ia) {
        for (int ib = 0; ib < 2; ++ib) {
            for (int ij = 0; ij < 2; ++ij) {
                float w = (ia == 0 ? 1.0 - fa : fa) * (ib == 0 ? 1.0 - fb : fb) * (ij == 0 ? 1.0 - fj : fj);
                if (w == 0.0) continue;
                int i = ((ia == 0 ? a0 : a1) * LOBES_PRODUCT_NE + (ib == 0 ? b0 : b1)) * LOBES_PRODUCT_NA + (ij == 0 ? j0 : j1);
                r += w * lobe_product_table[i];
            }
        }
    }
    return r;
}

// c1 · c2 as one lobe (paper Eq. 15-16; twin of ProductTable::product).
Lobe lobes_mul(Lobe c1, Lobe c2) {
    float alpha = lobe_angle_between(c1.axis, c2.axis);
    vec2 r = lobes_product_raw(c1.e, c2.e, alpha);
    Lobe o;
    // The axis angle once for the axis and the peak (lobe_product_axis and _scale would each recompute it).
    float t = lobe_product_axis_angle(c1.e, c2.e, alpha);
    o.axis = lobe_product_axis_at(c1.axis, c2.axis, t);
    o.e = max(r.y, 0.0);
    o.s = c1.s * c2.s * lobe_product_scale_at(c1.e, c2.e, alpha, t, r.x);
    return o;
}

// The specular term as cosine lobes (§5.1): Blinn-Phong as the Phong lobe about the mirror direction
// (e = s/4, scale k_s (s+8)/(8π)); Lafortune (Phong among them) exactly, lobe i about d_i = M_i v/|M_i v|
// with scale w_i k_s (e_i+2)/(2π) |M_i v|^e_i (Eq. 28-30). Returns their count: 0 for the other models
// and k_s = 0. Twin: lobes::cpu::specular_lobes.
int lobes_specular_lobes(Material m, vec3 n, vec3 view, out Lobe spec[LOBES_MAX_R - 1]) {
    for (int i = 0; i < LOBES_MAX_R - 1; ++i) {
        spec[i].axis = n;
        spec[i].e = 1.0;
        spec[i].s = vec3(0.0);
    }
    if (!brdf_has_specular(m)) return 0;
    int kind = brdf_kind(m);
    if (kind == BRDF_BLINN_PHONG) {
        float s = m.shininess;
        spec[0].axis = reflect(-view, n);
        spec[0].e = 0.25 * s;
        spec[0].s = m.specular.rgb * (s + 8.0) / (8.0 * PI);
        return 1;
    }
    if (kind != BRDF_LAFORTUNE) return 0;
    vec3 t = brdf_tangent(m, n);
    int count = 0;
    for (int i = 0; i < BRDF_LAFORTUNE_LOBES; ++i) {
        vec3 d;
        float e, scale;
        if (!brdf_lafortune_term(m, i, n, t, view, d, e, scale)) continue;
        spec[count].axis = d;
        spec[count].e = e;
        spec[count].s = m.specular.rgb * scale;
        count += 1;
    }
    return count;
}

// ∫_{n·v > 0} c dω from the hemisphere table (twin of HemisphereTable::hemisphere_integral).
vec3 lobes_hemisphere_integral(Lobe c, vec3 n) {
    float cb = clamp(dot(c.axis, n), -1.0, 1.0);
    int e0, e1, y0, y1;
    float fe, fy;
    lobes_axis(lobe_exponent_coord(c.e, 128.0), LOBES_HEMI_NE, e0, e1, fe);
    lobes_axis((lobe_hemisphere_coord_y(c.e, cb) + 1.0) * 0.5 * float(LOBES_HEMI_NY - 1), LOBES_HEMI_NY, y0, y1, fy);
    float a = lobe_hemisphere_table[e0 * LOBES_HEMI_NY + y0].x * (1.0 - fy) + lobe_hemisphere_table[e0 * LOBES_HEMI_NY + y1].x * fy;
    float b = lobe_hemisphere_table[e1 * LOBES_HEMI_NY + y0].x * (1.0 - fy) + lobe_hemisphere_table[e1 * LOBES_HEMI_NY + y1].x * fy;
    return c.s * ((a * (1.0 - fe) + b * fe) * 2.0 * LOBES_PI / (c.e + 1.0));
}

// e_cap of a cap of half-angle alpha (twin of CapTable::exponent).
float lobes_cap_exponent(float alpha) {
    int i0, i1;
    float f;
    lobes_axis(lobe_cap_coord(max(alpha, LOBES_CAP_MIN_ALPHA), float(LOBES_CAP_N)), LOBES_CAP_N, i0, i1, f);
    return lobe_cap_exponent(lobe_cap_table[i0] * (1.0 - f) + lobe_cap_table[i1] * f, alpha);
}

// Solid angle of a cap of half-angle alpha, 2π(1 − cos α) = 4π sin²(α/2).
float lobes_cap_solid_angle(float alpha) {
    float h = sin(0.5 * min(alpha, LOBES_PI));
    return 4.0 * LOBES_PI * h * h;
}

// The cap lobe of half-angle alpha about axis, scaled so that its integral is the cap's solid
// angle times `scale` (energy) or by `scale` alone.
Lobe lobes_cap_lobe(vec3 axis, float alpha, vec3 scale, bool energy, float sharpen) {
    Lobe c;
    c.axis = axis;
    c.e = lobes_cap_exponent(alpha) * sharpen;
    c.s = energy ? scale * (lobes_cap_solid_angle(alpha) * (c.e + 1.0) / (2.0 * LOBES_PI)) : scale;
    return c;
}

// Solid angle of the triangle (a, b, c) seen from the origin (Van Oosterom-Strackee).
float lobes_triangle_solid_angle(vec3 a, vec3 b, vec3 c) {
    float la = length(a), lb = length(b), lc = length(c);
    float num = abs(dot(a, cross(b, c)));
    float den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
    return 2.0 * atan(num, den);
}

// ---------------------------------------------------------------------------------------------
// Light visibility: the quad-tree mask.

vec3 g_p;
vec3 g_n;
// (unit direction, sin(β/2)) seen from g_p, β the half-angle: the cell tests compare chords |a − b| = 2 sin(∠/2),
// which keep their digits for small angles and need no trigonometry per test (lobes_cell_state).
vec4 g_blockers[LOBES_MAX_BLOCKERS];
uint g_blocker_count;
bool g_overflow;
// Σ sin²(β/2) over the caps this mask's gather dropped: their solid angles over 4π. A bound on the share of the
// light they could hide (twin: cpu::dropped_share): 4 Σ sin²(β/2) of the cosine-weighted sky (a cap's solid angle
// over π bounds its cosine-weighted share), Σ sin²(β/2) / sin²(α/2) of a light of angular radius α.
float g_dropped;
// The narrowest-first drop (lobes_gather): caps at least g_min_width wide (sin(β/2)) are kept, those of the next
// width bin down ([g_boundary_low, g_min_width)) while g_boundary_room lasts, in traversal order, the rest dropped;
// the count of the visited caps per width bin (lobes_width_bin) of the last cut.
#define LOBES_WIDTH_BINS 8
float g_min_width;
float g_boundary_low;
uint g_boundary_room;
bool g_count_widths;  // only the pass that chooses g_min_width counts
uvec4 g_width_bins_lo;  // bins 0..3
uvec4 g_width_bins_hi;  // bins 4..7
// This receiver's largest dropped share over its environment mask and over its lights' masks.
float g_dropped_env;
float g_dropped_light;
vec3 g_axis;
float g_cos_mask;
// env=map: the environment light the normal's mask leaves free, Σ over its free cells and the uncovered
// share of its partial leaves of the same lobe product as a leaf's (lobes_shadow adds it; shade_point reads it).
vec3 g_env_free;
bool g_budget_hit;  // some mask of this receiver stopped refining at its work budget (lp.budget)

// The blocker a sphere becomes for the receiver: SHEXP §6.2's rules, in the environment's mask with its radius
// scale α (blocker_for_receiver_alpha, shexp's default: a sphere straddling the tangent plane with the receiver
// outside it shrinks continuously, near it, to the inside rule's blocker). The plain rule turns every straddling
// sphere into the sphere of radius (h + r)/2 sitting on the tangent plane; the cloth's stand-in spheres (one per
// 4 × 4 quads, centred on the sheet) straddle the tangent plane of every receiver on the cloth, which so saw a
// ring of blockers about its horizon from its own sheet: 22 % of its cosine-weighted sky on average, in a pattern
// of the 12 × 12 patches (the grid of issue 37; tests/tests/lobes.rs the_flat_cloth_does_not_shadow_itself).
// The lights' masks take the plain rule unless lp.light_alpha (option light_rule; `auto`: α in a scene with
// thin shells, whose stand-ins straddle the sheet's receivers as above): with α, lamp_key's light shadows moved
// from 0.68 to 0.89 % (vs the sphere reference, which takes the plain rule) and 4.28 to 4.37 % (vs the triangles),
// while the cloth's environment lights (the courtyard's windows, low over the sheet) drew the grid again with the
// plain rule: cloth at rest 21.8 -> 16.9 % vs the triangles with α. Twin: cpu::Twin::collect.
bool g_alpha_rule;
// The bin of a cap's width sin(β/2) (lobes_gather's narrowest-first drop): k for sin(β/2) in [2^-(k+1), 2^-k),
// 7 below 2^-7 (β under 0.9°).
uint lobes_width_bin(float sb) {
    return uint(clamp(floor(-log2(max(sb, 1e-30))), 0.0, float(LOBES_WIDTH_BINS - 1)));
}

void lobes_light_visit(vec4 s) {
    s = bvh_reach_fade(g_p, s);
    vec4 b;
    if (!(g_alpha_rule ? blocker_for_receiver_alpha(g_p, g_n, s, b) : blocker_for_receiver(g_p, g_n, s, b))) return;
    if (!(b.w > 0.0)) return;
    vec3 d = b.xyz - g_p;
    float l = length(d);
    vec3 dir = l > 0.0 ? d / l : g_n;
    float beta = sphere_subtended_half_angle(g_p, b);
    float sb = sin(0.5 * beta);
    if (g_count_widths) {
        // Vector compares, not an indexed private array (which slowed every mask on llvmpipe).
        uvec4 bin = uvec4(lobes_width_bin(sb));
        g_width_bins_lo += uvec4(equal(bin, uvec4(0u, 1u, 2u, 3u)));
        g_width_bins_hi += uvec4(equal(bin, uvec4(4u, 5u, 6u, 7u)));
    }
    if (sb < g_min_width) {
        if (sb < g_boundary_low || g_boundary_room == 0u) {
            g_dropped += sb * sb;
            return;
        }
        g_boundary_room -= 1u;
    } else if (g_blocker_count >= uint(LOBES_MAX_BLOCKERS)) {
        g_overflow = true;
        g_dropped += sb * sb;
        return;
    }
    g_blockers[g_blocker_count] = vec4(dir, sb);
    g_blocker_count += 1u;
}


// Whether BVH node s, seen from p, may be taken whole (its bounding sphere as one blocker) in a mask
// about `axis`: its angular diameter 2β is below `cells` (= take_whole × the gnomonic side w of a cell at
// the maximal depth) times cos(θ + β) (θ the angle of its centre from the axis, θ + β capped at the
// mask's corner `corner`). A finest cell at polar angle θ spans w cos²θ radially and w cos θ across, so
// its longest chord is at least w cos θ; a cap narrower than that holds no cell's four corners. With
// take_whole ≤ 1 the node therefore covers no cell at any depth, and neither does any sphere under it
// (a cell is covered only by one blocker holding its four corners): taking it whole changes no covered
// cell and can only turn partial the finest cells its cap touches that its leaves' caps miss. Near the
// horizon of the environment mask those cells are narrow radially but weigh little (cos³θ solid angle
// times cos θ). Twin: cpu::node_is_small.
bool lobes_node_is_small(vec3 p, vec3 axis, vec4 s, float cells, float corner) {
    vec3 d = s.xyz - p;
    float l = length(d);
    if (!(s.w < l)) return false;
    float beta = asin(s.w / l);
    float far = min(lobe_angle_between(d / l, axis) + beta, corner);
    return 2.0 * beta < cells * cos(far);
}

// Whether lobes_collect traverses from the root rather than from the tile list (a coarsened retry).
bool g_from_root = false;

// The cut of the blocker BVH for the mask cone (apex p, axis, half-angle `corner`): nodes missing the
// cone are dropped, leaves and nodes that lobes_node_is_small(cells) are visited (as one blocker
// each), other nodes opened. cells = 0: leaves only. Sets g_overflow when a blocker was dropped.
void lobes_collect(vec3 p, vec3 n, vec3 axis, float corner, float cells) {
    g_p = p;
    g_n = n;
    g_blocker_count = 0u;
    g_overflow = false;
    g_dropped = 0.0;
    // A coarsened retry takes nodes whole that the tile list (tiles.glsl) may have opened: from the root.
    BvhCursor c = g_from_root ? bvh_cursor_begin_root(lp.sphere_count) : bvh_cursor_begin(lp.sphere_count);
    uint v;
    while (bvh_cursor_next(c, v)) {
        BvhNode node = bvh_nodes[v];
        vec4 s = bvh_sphere(node);
        if (!bvh_cone_hits(p, axis, corner, s) || bvh_beyond_reach(p, s)) continue;
        if (bvh_is_leaf(node) || bvh_cursor_whole(c) || (cells > 0.0 && lobes_node_is_small(p, axis, s, cells, corner))) {
            lobes_light_visit(s);
        } else if (!bvh_cursor_push_children(c, node.left, node.right)) {
            // Never on the LBVH (bvh.glsl) with this stack: taken whole (conservative) and counted.
            g_overflow = true;
            lobes_light_visit(s);
        }
    }
}

// The blockers of the mask about `axis` (square half-side tan_half, maximal depth `depth`): the cut
// with take_whole cells; while it overflows LOBES_MAX_BLOCKERS, again with take_whole doubled, at most
// `coarsen` times; if the coarsest still overflows, the first cut again keeping its widest caps (below) and
// g_overflow set. Twin: cpu::Twin::gather.
void lobes_gather(vec3 p, vec3 n, vec3 axis, float tan_half, uint depth) {
    float corner = atan(tan_half * sqrt(2.0));
    float cells = lp.take_whole * 2.0 * tan_half / float(1u << min(depth, uint(LOBES_MAX_DEPTH)));
    g_min_width = 0.0;
    g_count_widths = false;
    float first = cells;
    for (uint i = 0u;; ++i) {
        g_from_root = i > 0u;
        lobes_collect(p, n, axis, corner, cells);
        if (!g_overflow || !(cells > 0.0) || i >= lp.coarsen) break;
        cells *= 2.0;
    }
    g_from_root = false;
    if (!g_overflow) return;
    // Still too many: the first cut again, keeping its widest caps (the nearest blockers, whose shadow matters
    // most): the widest width bins that fit together, then the next bin's caps in traversal order while there is
    // room (so that one more blocker drops one, not a whole bin), the rest dropped (their shadow bounded in
    // g_dropped). One walk counts the caps per bin, a second keeps them.
    cells = first;
    g_width_bins_lo = uvec4(0u);
    g_width_bins_hi = uvec4(0u);
    g_count_widths = true;
    lobes_collect(p, n, axis, corner, cells);
    g_count_widths = false;
    uint kept = 0u;
    uint full = 0u;
    for (uint k = 0u; k < uint(LOBES_WIDTH_BINS); ++k) {
        uint count = k < 4u ? g_width_bins_lo[k] : g_width_bins_hi[k - 4u];
        if (kept + count > uint(LOBES_MAX_BLOCKERS)) break;
        kept += count;
        full = k + 1u;
    }
    g_min_width = exp2(-float(full));
    g_boundary_low = full + 1u < uint(LOBES_WIDTH_BINS) ? exp2(-float(full + 1u)) : 0.0;
    g_boundary_room = uint(LOBES_MAX_BLOCKERS) - kept;
    lobes_collect(p, n, axis, corner, cells);
    g_min_width = 0.0;
    g_overflow = true;
}

// The bit mask of blockers 0 .. count − 1 (count ≤ 64).
uvec2 lobes_all_blockers(uint count) {
    uint lo = count >= 32u ? 0xffffffffu : (1u << count) - 1u;
    uint hi = count <= 32u ? 0u : (count >= 64u ? 0xffffffffu : (1u << (count - 32u)) - 1u);
    return uvec2(lo, hi);
}

// 0: no blocker meets the cell; 1: partial; 2: covered. corners: unit directions; centre: unit; (sg, cg) =
// (sin, cos) of half the cell's bounding-cone half-angle γ. Only the blockers in `subset` are tested (in index
// order: those that met the parent cell); on return it holds those that meet this cell (unchanged when one
// covers it). The tests of the twin (cpu::Twin::mask), in chords: a blocker of half-angle β misses the cell when
// ∠(b, centre) ≥ β + γ, i.e. |b − centre| ≥ 2 sin((β + γ)/2) while (β + γ)/2 < π/2; it covers the cell when
// every corner is within β of b, |q − b|² ≤ 4 sin²(β/2). (The angle form took an atan2 and a cos per test.)
int lobes_cell_state(vec3 q[4], vec3 centre, float sg, float cg, bool planes, inout uvec2 subset, inout uint work) {
    bool partial = false;
    uvec2 met = uvec2(0u);
    for (uint half_ = 0u; half_ < 2u; ++half_) {
        uint bits = half_ == 0u ? subset.x : subset.y;
        while (bits != 0u) {
            uint j = uint(findLSB(bits));
            bits &= bits - 1u;
            work += 1u;
            vec4 b = g_blockers[j + 32u * half_];
            float sb = b.w;
            float cb = sqrt(max(1.0 - sb * sb, 0.0));
            float sin_sum = sb * cg + cb * sg;
            vec3 dc = b.xyz - centre;
            if (cb * cg - sb * sg > 0.0 && dot(dc, dc) >= 4.0 * sin_sum * sin_sum) continue;
            float r2 = 4.0 * sb * sb;
            vec3 d0 = q[0] - b.xyz, d1 = q[1] - b.xyz, d2 = q[2] - b.xyz, d3 = q[3] - b.xyz;
            if (dot(d0, d0) <= r2 && dot(d1, d1) <= r2 && dot(d2, d2) <= r2 && dot(d3, d3) <= r2) return 2;
            partial = true;
            if (half_ == 0u) met.x |= 1u << j;
            else met.y |= 1u << j;
        }
    }
    subset = met;
    for (uint i = 0u; i < (planes ? plane_count : 0u); ++i) {
        work += 1u;
        BlockerPlane pl = blocker_planes[i];
        if (!plane_blocks_receiver(pl, g_p)) continue;
        if (!plane_is_rectangle(pl)) {
            // Blocked: m·ω < 0 (a great circle: a line in the mask's gnomonic plane, so the corners decide).
            int k = 0;
            for (int c = 0; c < 4; ++c) k += dot(pl.plane.xyz, q[c]) < 0.0 ? 1 : 0;
            if (k == 4) return 2;
            if (k > 0) partial = true;
        } else {
            vec3 e[4];
            plane_edge_normals(pl, g_p, e);
            bool all_in = true;
            bool separated = false;
            for (int k = 0; k < 4; ++k) {
                int outside = 0;
                for (int c = 0; c < 4; ++c) outside += dot(q[c], e[k]) < 0.0 ? 1 : 0;
                all_in = all_in && outside == 0;
                separated = separated || outside == 4;
            }
            if (all_in) return 2;
            if (!separated) partial = true;
        }
    }
    return partial ? 1 : 0;
}

// One visibility product: v = ∫_{Ω+} (rl c) over the hemisphere of n; false (pruned, counted) when its
// luminance is below threshold · |U|.
bool lobes_leaf_product(Lobe rl, Lobe c, vec3 n, float u_lum, inout uint products, inout uint pruned, out vec3 v) {
    v = lobes_hemisphere_integral(lobes_mul(rl, c), n);
    products += 1u;
    if (abs(lobes_lum(v)) < lp.threshold * abs(u_lum)) {
        pruned += 1u;
        return false;
    }
    return true;
}

// The lobe of a mask cell (corners raw, unit centre, bounding-cone half-angle gamma): the cap lobe of its
// bounding cone scaled so that its integral is `weight` times the cell's solid angle (w_i = weight Ω_cell / ∫c_i).
Lobe lobes_cell_lobe(vec3 raw[4], vec3 centre, float gamma, float weight) {
    float omega = lobes_triangle_solid_angle(raw[0], raw[1], raw[2]) + lobes_triangle_solid_angle(raw[0], raw[2], raw[3]);
    Lobe c;
    c.axis = centre;
    c.e = lobes_cap_exponent(gamma);
    c.s = vec3(weight * omega * (c.e + 1.0) / (2.0 * LOBES_PI));
    return c;
}

// env=map: a cell's environment light ∫_{Ω+} (cos c) times the prefiltered environment at its axis, filtered
// like the cell's lobe (cos^e ≈ an SG of sharpness e); false when pruned (below t_i).
bool lobes_env_cell(Lobe cosine, Lobe c, vec3 n, float u_lum, inout uint products, inout uint pruned, out vec3 v) {
    if (!lobes_leaf_product(cosine, c, n, u_lum, products, pruned, v)) return false;
    v *= prefiltered_lookup(prefiltered_env, c.axis, max(c.e, 1.0));
    return true;
}

// Depth adaptation (ours, after §4.3 and §5.3): a partial cell is refined only while what its subtree can add
// matters. Its products are bounded by 2 Ω_γ Σ_k |rl_k| max_cell rl_k (Ω_γ = 4π sin²(γ/2) the bounding cone's
// solid angle, the maximum at the cell's point nearest the lobe's axis, 2 for the leaf lobes' tails); when that
// is below LOBES_ADAPT × t_i × |U| the cell is a leaf at its depth (as at the maximal depth). t_i = 0 refines
// everywhere. Measured (compare, 80×60): at 300 t_i (3 % of U at the default t_i) the bunny's products per
// receiver fall from 159 to 84 with its error 7.67 → 7.74 %; lamp_key and spheres move by ≤ 0.01 %. Not for
// env=lobes (its products are the environment lobes', not rl's). Twin: cpu::Twin::cell_negligible.
#define LOBES_ADAPT 300.0
bool lobes_cell_negligible(Lobe rl[LOBES_MAX_R], int rl_count, bool env, vec3 centre, float sg, float cg, float u_lum) {
#if LOBES_ENV_K > 0
    if (env) return false;
#endif
    float cos_g = 1.0 - 2.0 * sg * sg;
    float sin_g = 2.0 * sg * cg;
    float bound = 0.0;
    for (int k = 0; k < rl_count; ++k) {
        float ct = dot(rl[k].axis, centre);
        float st = length(cross(rl[k].axis, centre));
        // The cosine of the angle from the lobe's axis to the cell's nearest point (1 inside the bounding cone).
        float c = ct >= cos_g ? 1.0 : ct * cos_g + st * sin_g;
        if (c > 0.0) bound += abs(lobes_lum(rl[k].s)) * exp(rl[k].e * log(c));
    }
    return 2.0 * 4.0 * LOBES_PI * sg * sg * bound < LOBES_ADAPT * lp.threshold * abs(u_lum);
}

// S = Σ_leaves Σ_k w_i ∫_{Ω+} (rl_k c_i) for the light whose mask frame is (axis, t, b, tan_half). For the
// environment's mask (env, env=map) also the free light, into g_env_free.
vec3 lobes_shadow(Lobe rl[LOBES_MAX_R], int rl_count, vec3 n, vec3 axis, vec3 t, vec3 b, float tan_half, float u_lum,
                  bool planes, bool env, uint depth_req, inout uint products, inout uint pruned, inout uint leaves, out bool hidden) {
    vec3 shadow = vec3(0.0);
    hidden = false;
    uint stack[LOBES_STACK];
    // The blockers that met the last split cell of each depth: in depth-first order a popped cell's parent is
    // the last cell split one level up, so its children read level_subset[d − 1] (all blockers at the root).
    uvec2 level_subset[LOBES_MAX_DEPTH + 1];
    uvec2 all_blockers = lobes_all_blockers(g_blocker_count);
    uint size = 1u;
    stack[0] = 0u;  // (depth, ix, iy) packed as depth | ix << 4 | iy << 16
    uint depth_max = min(depth_req, uint(LOBES_MAX_DEPTH));
    uint work = 0u;
    while (size > 0u) {
        size -= 1u;
        uint cell = stack[size];
        uint d = cell & 15u;
        uint ix = (cell >> 4) & 0xfffu;
        uint iy = cell >> 16;
        uvec2 subset = d == 0u ? all_blockers : level_subset[d - 1u];
        float h = 1.0 / float(1u << d);  // half side in [-1, 1]^2
        float cx = -1.0 + (2.0 * float(ix) + 1.0) * h;
        float cy = -1.0 + (2.0 * float(iy) + 1.0) * h;
        vec3 q[4];
        vec3 raw[4];
        bool any_above = false;
        for (int c = 0; c < 4; ++c) {
            float x = cx + ((c == 1 || c == 2) ? h : -h);
            float y = cy + ((c >= 2) ? h : -h);
            raw[c] = axis + tan_half * (x * t + y * b);
            q[c] = normalize(raw[c]);
            any_above = any_above || dot(q[c], n) > 0.0;
        }
        if (!any_above) continue;  // wholly below the tangent plane: contributes nothing
        vec3 centre = normalize(axis + tan_half * (cx * t + cy * b));
        // The bounding cone's half-angle γ from the longest chord to a corner: sg = sin(γ/2), cg = cos(γ/2).
        float chord2 = 0.0;
        for (int c = 0; c < 4; ++c) {
            vec3 dq = q[c] - centre;
            chord2 = max(chord2, dot(dq, dq));
        }
        float sg = min(0.5 * sqrt(chord2), 1.0);
        float cg = sqrt(max(1.0 - sg * sg, 0.0));
        float gamma = 2.0 * atan(sg, cg);
        work += 4u;
        int state = lobes_cell_state(q, centre, sg, cg, planes, subset, work);
#if LOBES_ENV_K == 0 && LOBES_PHASE >= 5
        // env=map: a free cell's light, for the ratio of free to hidden light (shade_point).
        if (state == 0 && env) {
            vec3 v;
            if (lobes_env_cell(rl[0], lobes_cell_lobe(raw, centre, gamma, lp.weight), n, u_lum, products, pruned, v)) {
                g_env_free += v;
            }
            continue;
        }
#endif
        if (state == 0) continue;
        bool refine = work < lp.budget;
        // A cell that would have split but the budget stops: counted (lobes_stats[7]).
        if (!refine && ((state == 2 && d < min(lp.split, depth_max)) || (state == 1 && d < depth_max))) g_budget_hit = true;
        // The whole mask covered: the light is hidden (S = U; the cap lobe's tail past the mask is
        // counted hidden too).
        if (state == 2 && d == 0u) {
            hidden = true;
            return shadow;
        }
        // Covered cells split down to `split` so that their lobes are narrower than the light's:
        // one broad leaf lobe peaks at ~0.6 and leaves its centre lit.
        if (state == 2 && d < min(lp.split, depth_max) && refine) {
            level_subset[d] = subset;
            for (uint k = 0u; k < 4u; ++k) {
                stack[size] = (d + 1u) | ((2u * ix + (k & 1u)) << 4) | ((2u * iy + (k >> 1)) << 16);
                size += 1u;
            }
            continue;
        }
        if (state == 1) {
            if (d < depth_max && refine && !lobes_cell_negligible(rl, rl_count, env, centre, sg, cg, u_lum)) {
                level_subset[d] = subset;
                for (uint k = 0u; k < 4u; ++k) {
                    uint cix = 2u * ix + (k & 1u);
                    uint ciy = 2u * iy + (k >> 1);
                    stack[size] = (d + 1u) | (cix << 4) | (ciy << 16);
                    size += 1u;
                }
                continue;
            }
            if (lp.conservative == 0u) continue;
        }
        // leaves=half: a partial leaf at the maximal depth counts half covered.
        float leaf_weight = (state == 1 && lp.conservative == 2u) ? 0.5 : 1.0;
        // A shadow leaf: the cap lobe of its bounding cone, w_i = weight Ω_cell / ∫c_i.
        leaves += 1u;
#if LOBES_PHASE < 4
        shadow += vec3(gamma * 1e-30);
        continue;
#endif
        float w_d = env ? 1.0 : lp.light_weights[d];
        Lobe c = lobes_cell_lobe(raw, centre, gamma, leaf_weight * lp.weight * w_d);
#if LOBES_PHASE < 5
        shadow += c.s * c.e * 1e-30;
        continue;
#endif
#if LOBES_ENV_K > 0
        // env=lobes: the environment's products (R_r L_k) × c_i, as a light's.
        if (env) {
            for (int k = 0; k < g_env_rl_count; ++k) {
                vec3 v;
                if (lobes_leaf_product(g_env_rl[k], c, n, u_lum, products, pruned, v)) shadow += v;
            }
            continue;
        }
#endif
        // env=map: the leaf's hidden light; the uncovered share of a half-weight leaf is free.
        if (env) {
            vec3 v;
            c.s /= leaf_weight;
            if (lobes_env_cell(rl[0], c, n, u_lum, products, pruned, v)) {
                shadow += leaf_weight * v;
                g_env_free += (1.0 - leaf_weight) * v;
            }
            continue;
        }
        for (int k = 0; k < rl_count; ++k) {
            vec3 v;
            if (lobes_leaf_product(rl[k], c, n, u_lum, products, pruned, v)) shadow += v;
        }
    }
    return shadow;
}

// The radiance-weighting samples of the planes' environment term: LOBES_PLANE_SAMPLES directions about n,
// distributed as the cosine (a golden-angle spiral on the unit disc lifted to the hemisphere), each read from
// the prefiltered environment at the atlas level of λ = LOBES_PLANE_SAMPLES (an SG footprint of about one
// sample's share 2π/N of the hemisphere). A sample's blocked fraction ramps linearly over ±LOBES_PLANE_SOFT
// (sine of the angle) across a plane's boundary, so that the weights move smoothly with n.
#define LOBES_PLANE_SAMPLES 32
const float LOBES_PLANE_SOFT = 0.1;
const float LOBES_GOLDEN_ANGLE = 2.39996323;

vec3 lobes_plane_sample(int i, vec3 n, vec3 t, vec3 b) {
    float r2 = (float(i) + 0.5) / float(LOBES_PLANE_SAMPLES);
    float phi = float(i) * LOBES_GOLDEN_ANGLE;
    return normalize(sqrt(r2) * (cos(phi) * t + sin(phi) * b) + sqrt(1.0 - r2) * n);
}

// The blocked fraction of sample direction w for plane pl seen from p (edge normals e of a rectangle).
float lobes_plane_blocked(BlockerPlane pl, vec3 e[4], vec3 w) {
    float inside;
    if (plane_is_rectangle(pl)) {
        inside = min(min(dot(w, e[0]), dot(w, e[1])), min(dot(w, e[2]), dot(w, e[3])));
    } else {
        inside = -dot(w, pl.plane.xyz);
    }
    return clamp(0.5 + 0.5 * inside / LOBES_PLANE_SOFT, 0.0, 1.0);
}

// ---------------------------------------------------------------------------------------------
// Environment: the same quad-tree mask about n over the widest square (half-angle 1.4 rad: the
// directions within 10° of the horizon, 3 % of the cosine-weighted hemisphere, are not masked;
// one level deeper than the lights' masks: its cells around n are wide). Plane blockers are left out of
// the mask: each blocks a cosine-weighted solid angle o of the hemisphere of n, exactly: π(1 − n·m)/2 for a
// half-space, Lambert's formula over the clipped plate for a rectangle. lobes_env_planes returns Π (1 − o/π),
// their visibility under a constant environment (env=lobes uses it), and in `weighted` per channel
// Π (π − o) L̄_V / ((π − o) L̄_V + o L̄_B): L̄_B and L̄_V the mean prefiltered radiance of the cosine-distributed
// samples the plane blocks and leaves free (each sample weighted by its blocked fraction). A ground under a
// bright sky hides the dark lower half, not a share of the whole hemisphere's light (env=map). The visible and
// the blocked light are each estimated from their own directions, and the factor is their ratio: it stays in
// [0, 1] per channel and equals 1 − o/π under a constant environment. The factor it replaced,
// clamp(1 − o L̄/E(n), 0, 1) with L̄ one lookup about the plate's mean direction at its cap lobe's sharpness,
// read the whole sphere's light (sky included) once a plate filled the hemisphere (the cap lobe's exponent
// → 0 as its half-angle → π/2), so o L̄ passed E(n) under downward-facing receivers near the ground: blue, then
// every channel, clamped to 0 (the orange blotches and black pixels of issue 37 on bunny, chess and battle).
float lobes_env_planes(vec3 p, vec3 n, out vec3 weighted) {
    float v_hs = 1.0;
    weighted = vec3(1.0);
    bool any = false;
    for (uint i = 0u; i < plane_count; ++i) any = any || plane_blocks_receiver(blocker_planes[i], p);
    if (!any) return v_hs;
    vec3 t, b;
    orthonormal_basis(n, t, b);
    vec3 radiance[LOBES_PLANE_SAMPLES];
    float level = prefiltered_nearest_level(float(LOBES_PLANE_SAMPLES));
    for (int k = 0; k < LOBES_PLANE_SAMPLES; ++k) {
        radiance[k] = prefiltered_level(prefiltered_env, lobes_plane_sample(k, n, t, b), level);
    }
    for (uint i = 0u; i < plane_count; ++i) {
        BlockerPlane pl = blocker_planes[i];
        if (!plane_blocks_receiver(pl, p)) continue;
        float o = plane_projected_solid_angle(pl, p, n);
        vec3 e[4] = vec3[4](vec3(0.0), vec3(0.0), vec3(0.0), vec3(0.0));
        if (plane_is_rectangle(pl)) plane_edge_normals(pl, p, e);
        v_hs *= clamp(1.0 - o / PI, 0.0, 1.0);
        vec3 sum_b = vec3(0.0), sum_v = vec3(0.0);
        float w_b = 0.0, w_v = 0.0;
        for (int k = 0; k < LOBES_PLANE_SAMPLES; ++k) {
            float f = lobes_plane_blocked(pl, e, lobes_plane_sample(k, n, t, b));
            sum_b += f * radiance[k];
            sum_v += (1.0 - f) * radiance[k];
            w_b += f;
            w_v += 1.0 - f;
        }
        // A side no sample falls on takes the other's mean (then the factor is 1 − o/π).
        vec3 mean = (sum_b + sum_v) / float(LOBES_PLANE_SAMPLES);
        vec3 l_b = w_b > 1e-3 ? sum_b / w_b : mean;
        vec3 l_v = w_v > 1e-3 ? sum_v / w_v : mean;
        vec3 visible = (PI - o) * l_v;
        vec3 den = visible + o * l_b;
        weighted *= mix(vec3(1.0 - o / PI), visible / max(den, vec3(1e-30)), greaterThan(den, vec3(0.0)));
    }
    return v_hs;
}

// The environment mask's occlusion S_env = Σ_leaves w_i ∫ (rl c_i): with env=map rl is the cosine
// lobe and each leaf's product integral is weighted by the prefiltered environment at its axis; with
// env=lobes the products are the receiver's R_r L_k (g_env_rl). `u_lum` scales the pruning; `hidden`:
// the whole mask is covered.
vec3 lobes_env_mask(vec3 p, vec3 n, Lobe rl[LOBES_MAX_R], float u_lum, out bool hidden, inout uint products,
                    inout uint pruned, inout uint leaves, inout uint overflow) {
    hidden = false;
    if (lp.sphere_count == 0u) return vec3(0.0);
    float tan_half = tan(LOBES_MASK_MAX_HALF_ANGLE);
    g_blocker_count = 0u;
    g_overflow = false;
#if LOBES_PHASE < 2
    return vec3(u_lum * 1e-30);
#endif
    g_alpha_rule = true;
    lobes_gather(p, n, n, tan_half, lp.depth + 1u);
    g_alpha_rule = false;
    if (g_overflow) {
        overflow |= 1u;
        g_dropped_env = max(g_dropped_env, min(4.0 * g_dropped, 1.0));
    }
#if LOBES_PHASE < 3
    return vec3(float(g_blocker_count) * 1e-30);
#endif
    g_p = p;
    vec3 t, b;
    orthonormal_basis(n, t, b);
    return lobes_shadow(rl, 1, n, n, t, b, tan_half, u_lum, false, true, lp.depth + 1u, products, pruned, leaves, hidden);
}

vec3 shade_point(ShadePoint sp) {
    vec3 n = sp.normal;
    vec3 p = sp.position;
    bvh_reach = lp.reach;
    uint products = 0u, pruned = 0u, leaves = 0u, overflow = 0u;
    g_dropped_env = 0.0;
    g_dropped_light = 0.0;
    g_budget_hit = false;
    g_alpha_rule = false;

    vec3 rho = sp.material.diffuse.rgb;
    // Reflectance lobes f_r · cos (§5.1).
    Lobe r[LOBES_MAX_R];
    r[0].axis = n;
    r[0].e = 1.0;
    r[0].s = rho / PI;
    Lobe spec[LOBES_MAX_R - 1];
    int spec_count = lobes_specular_lobes(sp.material, n, sp.view, spec);
    bool phong = spec_count > 0;
    Lobe cosine = r[0];
    cosine.s = vec3(1.0);
    for (int k = 0; k < LOBES_MAX_R - 1; ++k) {
        r[k + 1] = k < spec_count ? lobes_mul(spec[k], cosine) : r[0];
        if (k < spec_count && (light_count > 0u || LOBES_ENV_K > 0)) products += 1u;
    }
    int r_count = 1 + spec_count;
    vec3 result = vec3(0.0);
    // A black environment (the paper's set-ups: lights alone) adds nothing: its mask is skipped.
    if (lp.env_black == 0u) {
        vec3 e_free = irradiance_lookup(irradiance_map, n);
        vec3 v_planes;
        float v_hs = lobes_env_planes(p, n, v_planes);
        bool env_hidden;
#if LOBES_ENV_K > 0
        // env=lobes: each environment lobe as the paper takes a light: R × L_k, U_env = Σ ∫_{Ω+} R_r L_k,
        // S_env through the normal's mask; the environment adds max(U_env − S_env, 0) (light=lobes) or the
        // shared unshadowed terms × clamp(1 − S_env/U_env, 0, 1) (light=ratio), times the planes' v_hs.
        vec3 u_env = vec3(0.0);
        g_env_rl_count = 0;
        for (uint k = 0u; k < min(lp.env_lobe_count, uint(LOBES_ENV_K)); ++k) {
            Lobe l;
            l.axis = env_lobes[k].axis_e.xyz;
            l.e = env_lobes[k].axis_e.w;
            l.s = env_lobes[k].scale.rgb;
            for (int j = 0; j < r_count; ++j) {
                Lobe rl = lobes_mul(r[j], l);
                products += 1u;
                u_env += lobes_hemisphere_integral(rl, n);
                g_env_rl[g_env_rl_count] = rl;
                g_env_rl_count += 1;
            }
        }
        float u_env_lum = lobes_lum(u_env);
        vec3 s_env = lobes_env_mask(p, n, r, u_env_lum, env_hidden, products, pruned, leaves, overflow);
        float v_env = env_hidden ? 0.0 : (u_env_lum > 0.0 ? clamp(1.0 - lobes_lum(s_env) / u_env_lum, 0.0, 1.0) : 1.0) * v_hs;
        if (lp.light_mode == 1u) {
            result = v_env * rho / PI * e_free;
            if (brdf_has_specular(sp.material)) result += v_env * specular_prefiltered(prefiltered_env, sp.material, n, sp.view);
        } else {
            result = env_hidden ? vec3(0.0) : max(u_env - s_env, vec3(0.0)) * v_hs;
            // Specular kinds that are not lobes: the shared prefiltered term × the lobe visibility.
            if (!phong && brdf_has_specular(sp.material)) result += v_env * specular_prefiltered(prefiltered_env, sp.material, n, sp.view);
        }
#else
        // Environment: shared unshadowed terms times the lobe visibility estimate.
        Lobe cos_rl[LOBES_MAX_R];
        cos_rl[0].axis = n;
        cos_rl[0].e = 1.0;
        cos_rl[0].s = vec3(1.0);
        for (int k = 1; k < LOBES_MAX_R; ++k) cos_rl[k] = cos_rl[0];
        float u_cos = lobes_hemisphere_integral(cos_rl[0], n).x;
        g_env_free = vec3(0.0);
        vec3 s_env = lobes_env_mask(p, n, cos_rl, u_cos, env_hidden, products, pruned, leaves, overflow);
        // The free share of the light: the mask's free light plus the band it leaves out (E(n) less all its
        // cells' light, unshadowed), over all of it. Where the mask's cells hold less than E(n) this is
        // E − S; where they hold more (their lobes overlap the band or each other), the ratio keeps the
        // estimate in [0, E] and its colour that of the free directions. E − S alone, clamped at 0 per
        // channel, went black with a hard edge wherever S passed E (the ground under the cloth, issue 37).
        vec3 band = max(e_free - s_env - g_env_free, vec3(0.0));
        vec3 all_light = s_env + g_env_free + band;
        vec3 free_share = mix(vec3(1.0), (g_env_free + band) / max(all_light, vec3(1e-30)), greaterThan(all_light, vec3(0.0)));
        vec3 e_env = env_hidden ? vec3(0.0) : e_free * free_share * v_planes;
        result = rho / PI * e_env;
        if (brdf_has_specular(sp.material)) {
            // Glossy: the unshadowed prefiltered term times the diffuse visibility (luminance).
            float den = lobes_lum(e_free);
            float v_env = den > 0.0 ? clamp(lobes_lum(e_env) / den, 0.0, 1.0) : 1.0;
            result += v_env * specular_prefiltered(prefiltered_env, sp.material, n, sp.view);
        }
#endif
    }

    if (light_count > 0u) {
        SpecLobe sg[BRDF_MAX_LOBES];
        int sg_count = brdf_specular_lobes(sp.material, sp.normal, sp.view, sg);
        for (uint j = 0u; j < light_count; ++j) {
            vec3 axis;
            float sa, ca;
            bool outside = light_cap(j, p, axis, sa, ca);
            if (!outside) {
                // Inside the light: it fills every direction, unshadowed (closed form).
                result += light_unshadowed(sp, j, sg, sg_count, false, axis, sa, ca);
                continue;
            }
            float alpha = atan(sa, ca);
            Lobe light = lobes_cap_lobe(axis, alpha, lights[j].radiance, lp.energy_scale == 1u, lp.sharpen);
            Lobe rl[LOBES_MAX_R];
            vec3 u = vec3(0.0);
            for (int k = 0; k < r_count; ++k) {
                rl[k] = lobes_mul(r[k], light);
                products += 1u;
                u += lobes_hemisphere_integral(rl[k], n);
            }
            float u_lum = lobes_lum(u);
            vec3 s = vec3(0.0);
            if (LOBES_PHASE >= 2 && u_lum > 0.0 && (lp.sphere_count > 0u || plane_count > 0u)) {
                float half_angle = min(lp.extent * alpha, LOBES_MASK_MAX_HALF_ANGLE);
                float tan_half = tan(half_angle);
                g_blocker_count = 0u;
                g_overflow = false;
                g_alpha_rule = lp.light_alpha != 0u;
                if (lp.sphere_count > 0u) lobes_gather(p, n, axis, tan_half, lp.depth);
                g_alpha_rule = false;
                if (g_overflow) {
                    overflow |= 2u;
                    float sa = sin(0.5 * alpha);
                    g_dropped_light = max(g_dropped_light, min(g_dropped / max(sa * sa, 1e-30), 1.0));
                }
                g_p = p;
                vec3 t, b;
                orthonormal_basis(axis, t, b);
                bool hidden = false;
#if LOBES_PHASE < 3
                s = vec3(float(g_blocker_count) * 1e-30);
#else
                s = lobes_shadow(rl, r_count, n, axis, t, b, tan_half, u_lum, true, false, lp.depth, products, pruned, leaves, hidden);
#endif
                if (hidden) s = u;
            }
            float vis = u_lum > 0.0 ? clamp(1.0 - lobes_lum(s) / u_lum, 0.0, 1.0) : 1.0;
            if (lp.light_mode == 1u) {
                result += vis * light_unshadowed(sp, j, sg, sg_count, true, axis, sa, ca);
            } else {
                result += max(u - s, vec3(0.0));
                if (!phong && sg_count > 0) {
                    // Non-Phong specular: the exact SG light term times the lobe visibility.
                    vec3 spec = vec3(0.0);
                    for (int k = 0; k < sg_count; ++k) {
                        if (all(equal(sg[k].weight, vec3(0.0)))) continue;
                        spec += sg[k].weight * cap_sg_integral(sg[k].axis, sg[k].lambda, axis, sa, ca);
                    }
                    result += vis * lights[j].radiance * max(spec, vec3(0.0));
                }
            }
        }
    }
    atomicAdd(lobes_stats[0], 1u);
    if (overflow != 0u) atomicAdd(lobes_stats[1], 1u);
    if ((overflow & 1u) != 0u) atomicAdd(lobes_stats[5], 1u);
    if ((overflow & 2u) != 0u) atomicAdd(lobes_stats[6], 1u);
    atomicAdd(lobes_stats[2], products);
    atomicAdd(lobes_stats[3], pruned);
    atomicAdd(lobes_stats[4], leaves);
    if (g_budget_hit) atomicAdd(lobes_stats[7], 1u);
    // Non-negative floats order as their bits.
    if (g_dropped_env > 0.0) atomicMax(lobes_stats[8], floatBitsToUint(g_dropped_env));
    if (g_dropped_light > 0.0) atomicMax(lobes_stats[9], floatBitsToUint(g_dropped_light));
    if (g_dropped_env > 0.01) atomicAdd(lobes_stats[10], 1u);
    if (g_dropped_light > 0.01) atomicAdd(lobes_stats[11], 1u);
    // Sums in thousandths (each at most 1000: 2^32 holds 4.29 million receivers).
    atomicAdd(lobes_stats[12], uint(round(1000.0 * g_dropped_env)));
    atomicAdd(lobes_stats[13], uint(round(1000.0 * g_dropped_light)));
    return result;
}
