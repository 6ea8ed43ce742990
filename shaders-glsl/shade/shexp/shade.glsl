// Technique `shexp` (engine passes::shade::shexp): soft shadows by SH exponentiation (Ren et al.
// 2006) at the compile-time order SHEXP_N (default 4; tables from device buffers).
// Per receiver p with normal n:
// - blockers: the cut of the sphere BVH by subtended angle θ_max (SHEXP Eq. 36, bvh_cut.glsl), spheres
//   entirely behind the tangent plane culled, straddling ones shrunk, receivers inside handled
//   (the §6.2 rules, blocker_for_receiver); a node taken whole blocks as its bounding sphere. With
//   receiver clusters (cluster > 0) the cut is the cluster's (clusters.glsl) and each node taken whole
//   is scaled by its ratio vector W (Eq. 38). Each blocker adds the circle
//   log f*(u = 1 − cos θ) from the table rotated to its direction (Eq. 34). Plane blockers: a
//   half-space below p multiplies g by the exact projection of the half-space's visibility
//   (u = 1 about −m); a rectangle by that of a circle of its exact solid angle about its cone's mean
//   direction (approximation). Not a log: the clipped log of a hemisphere-sized circle is poor.
// - g = exp*(Σ f) by HYB (default), OL or PS*-p (common/shexp_n.glsl).
// - diffuse: ρ (L * H(N)) · g = ρ L · (H(N) * g), L the windowed order-n projection of the environment,
//   H(N) the clamped cosine (zonal, rotated to n); diffuse=ratio instead scales the exact irradiance
//   E(n) by (L·(H*g))/(L·H).
// - spherical lights: each light's exact unshadowed term (../lights.glsl) times its SH visibility
//   (C·(H*g))/(C·H), C the windowed SH projection of the light's cap (zonal, rotated to its axis).
// - glossy: the unshadowed prefiltered glossy term (as technique `none`) times the diffuse
//   visibility ratio (Lum(L)·(H*g))/(Lum(L)·H): SHEXP itself shadows only diffuse.
// f64 twin: engine::passes::shade::shexp::cpu.
// SHEXP_PHASE (option `phase`, a timing variant): every receiver stops after 1 visiting its blockers,
// 2 summing their logs, 3 the exponential, or 4 (default) shades.
#ifndef SHEXP_PHASE
#define SHEXP_PHASE 4
#endif
#include "../common.glsl"
#include "../prefiltered.glsl"
#include "../lights.glsl"
layout(binding = 8) uniform sampler2D prefiltered_env;
layout(binding = 9) uniform sampler2D irradiance_map;
#include "../tiles.glsl"
#include "bindings.glsl"
#include "../../common/planes.glsl"
layout(std430, binding = 21) readonly buffer BlockerPlanes {
    uint plane_count;
    BlockerPlane blocker_planes[];  // at least one record (zero when plane_count = 0)
};


// The cut's visitor adds into these (bvh_cut.glsl calls BVH_CUT_VISIT from its loop).
float g_log[SHN_C];
vec3 g_p;
vec3 g_n;
uint g_blockers;

// Spheres subtending more than the clip's first kink (large=product): their visibility multiplies g
// after the exponential, up to SHEXP_MAX_LARGE of them (the rest go to the log).
#define SHEXP_MAX_LARGE 4
vec4 g_large[SHEXP_MAX_LARGE];  // (axis, u)
uint g_large_count;
// accumulate=product: the running product of the spheres' projected visibilities (g_blockers of them).
float g_prod[SHN_C];

void shexp_multiply_circle_visibility(inout float g[SHN_C], float u, vec3 axis, bool g_is_one);

// The §6.2 rules (spheres.glsl), with the radius scale α under alpha_scale=on.
bool shexp_rule(vec4 s, out vec4 b) {
    return shx.alpha_scale != 0u ? blocker_for_receiver_alpha(g_p, g_n, s, b) : blocker_for_receiver(g_p, g_n, s, b);
}

void shexp_visit(vec4 s) {
    s = bvh_reach_fade(g_p, s);
    vec4 b;
    if (!shexp_rule(s, b)) return;
    float u = shn_sphere_u(g_p, b);
    if (!(u > 0.0)) return;
    if (shx.accumulate == 1u) {
        shexp_multiply_circle_visibility(g_prod, u, b.xyz - g_p, g_blockers == 0u);
        g_blockers += 1u;
        return;
    }
    if (u > shx.large_u && g_large_count < uint(SHEXP_MAX_LARGE)) {
        g_large[g_large_count] = vec4(b.xyz - g_p, u);
        g_large_count += 1u;
        return;
    }
#if SHEXP_PHASE == 1
    g_log[0] += u;
#else
    shn_add_circle_log(g_log, u, b.xyz - g_p);
#endif
    g_blockers += 1u;
}
// A receiver-cluster entry (cluster > 0): as shexp_visit, its log scaled per band by the entry's ratio
// vector W (SHEXP Eq. 38). A sphere past the clip (large=product) multiplies unweighted: only leaves
// (W = 1) get there unless θ_max exceeds θ_clip, as a node taken whole subtends less than θ_max.
void shexp_visit_weighted(ClusterEntry ce) {
    vec4 b;
    if (!shexp_rule(bvh_reach_fade(g_p, ce.sphere), b)) return;
    float u = shn_sphere_u(g_p, b);
    if (!(u > 0.0)) return;
    if (u > shx.large_u && g_large_count < uint(SHEXP_MAX_LARGE)) {
        g_large[g_large_count] = vec4(b.xyz - g_p, u);
        g_large_count += 1u;
        return;
    }
#if SHEXP_PHASE == 1
    g_log[0] += u * ce.w_lo.x;
#else
    float w[8] = float[8](ce.w_lo.x, ce.w_lo.y, ce.w_lo.z, ce.w_lo.w, ce.w_hi.x, ce.w_hi.y, ce.w_hi.z, ce.w_hi.w);
    shn_add_circle_log_weighted(g_log, u, b.xyz - g_p, w);
#endif
    g_blockers += 1u;
}

#ifdef SHEXP_PIXEL
// This invocation's pixel (target_pixel.glsl, included after this file).
ivec2 target_pixel();
#endif

// The receiver's bake=on record: its vertex, or its pixel (row-major).
uint shexp_bake_record() {
#ifdef SHEXP_PIXEL
    uvec2 px = uvec2(target_pixel());
    return (px.y * frame.size.x + px.x) * uint(SHEXP_BAKE_STRIDE);
#else
    return gl_GlobalInvocationID.x * uint(SHEXP_BAKE_STRIDE);
#endif
}

#ifdef SHEXP_PIXEL
// The G-buffer's geometric w at this pixel: its triangle's first vertex (defined in pixel.comp, after
// target_pixel.glsl declares the image).
float shexp_pixel_first_vertex();
#endif

// The receiver cluster of this invocation (clusters.glsl numbers them the same way).
uint shexp_cluster_of_invocation() {
    uint t = max(shx.cluster, 1u);
#ifdef SHEXP_PIXEL
    // pixel_clusters=world: the cluster of the triangle's first vertex (the G-buffer's geometric w).
    if (shx.pixel_world != 0u) {
        float v = shexp_pixel_first_vertex();
        return v >= 0.0 && v < float(vc_of.length()) ? vc_of[uint(v)] : 0u;
    }
    uint tiles_x = (frame.size.x + t - 1u) / t;
    uvec2 px = uvec2(target_pixel());
    return (px.y / t) * tiles_x + px.x / t;
#else
    return vc_of[gl_GlobalInvocationID.x];
#endif
}

#define BVH_CUT_VISIT(index, s) shexp_visit(s)
// theta_min (SHEXP §7, tiny blockers): a node whose bounding sphere subtends less than θ_min from p is
// dropped with its subtree (its spheres lie inside it, so each subtends less too). Twin: the f64 cpu's
// `too_small`, on the leaf spheres.
#define BVH_CUT_DROP(s) (s.w < shx.sin_theta_min * distance(g_p, s.xyz))
#include "../../common/bvh_cut.glsl"

float shexp_atan_triangle(vec3 a, vec3 b, vec3 c) {
    float la = length(a), lb = length(b), lc = length(c);
    float num = abs(dot(a, cross(b, c)));
    float den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
    return 2.0 * atan(num, den);  // Van Oosterom–Strackee: the triangle's solid angle
}

// The scaled zonal coefficients c*_l = 2π ∫_c^1 P_l(z) dz of the cap z ≥ c (l < SHEXP_N).
void shexp_cap_star_raw(float c, out float cstar[SH_MAX_ORDER]) {
    // Legendre P_0..P_n at c by the three-term recurrence.
    float p[SH_MAX_ORDER + 1];
    p[0] = 1.0;
    p[1] = c;
    for (int l = 1; l < SH_MAX_ORDER; ++l) p[l + 1] = (float(2 * l + 1) * c * p[l] - float(l) * p[l - 1]) / float(l + 1);
    for (int l = 0; l < SH_MAX_ORDER; ++l) {
        float integral = l == 0 ? 1.0 - c : (p[l - 1] - p[l + 1]) / float(2 * l + 1);
        cstar[l] = l < SHEXP_N ? 2.0 * PI * integral : 0.0;
    }
}

// g ← g * V, V the exact order-n projection of the visibility of a circle (u = 1 − cos θ) about
// `axis` (closed form, sh/zonal.rs circle_visibility). Plane blockers multiply the visibility this
// way rather than adding a log: the log of a hemisphere-sized circle lies far past the eigenvalue
// clip (θ = π/2 > θ_clip ≈ 0.85 at n = 4) and its exponential darkens an upward receiver by 7 %
// (14 % at n = 6), where the projection is exact.
void shexp_multiply_circle_visibility(inout float g[SHN_C], float u, vec3 axis, bool g_is_one) {
    float cstar[SH_MAX_ORDER];
    shexp_cap_star_raw(1.0 - clamp(u, 0.0, 2.0), cstar);
    float y[SHN_C];
    shn_eval(axis, y);
    float v[SHN_C];
    for (int l = 0; l < SHEXP_N; ++l) {
        float vstar = (l == 0 ? 4.0 * PI : 0.0) - cstar[l];
        for (int i = l * l; i < (l + 1) * (l + 1); ++i) v[i] = vstar * y[i];
    }
    if (g_is_one) {
        g = v;
    } else {
        float t[SHN_C];
        shn_product(g, v, t);
        g = t;
    }
}

// Plane blockers multiply g (see shexp_multiply_circle_visibility): a half-space the visibility of
// the half-space (u = 1 about −m, exact), a rectangle that of a circle of its exact solid angle Ω
// (u = Ω/2π) about its cone's mean direction. Returns how many blocked.
uint shexp_planes(vec3 p, inout float g[SHN_C], bool g_is_one) {
    uint count = 0u;
    for (uint i = 0u; i < plane_count; ++i) {
        BlockerPlane pl = blocker_planes[i];
        if (!plane_blocks_receiver(pl, p)) continue;
        if (!plane_is_rectangle(pl)) {
            shexp_multiply_circle_visibility(g, 1.0, -pl.plane.xyz, g_is_one && count == 0u);
        } else {
            vec3 c = pl.center.xyz - p;
            vec3 a0 = c - pl.half_u.xyz - pl.half_v.xyz;
            vec3 a1 = c + pl.half_u.xyz - pl.half_v.xyz;
            vec3 a2 = c + pl.half_u.xyz + pl.half_v.xyz;
            vec3 a3 = c - pl.half_u.xyz + pl.half_v.xyz;
            float omega = shexp_atan_triangle(a0, a1, a2) + shexp_atan_triangle(a0, a2, a3);
            // The circle's axis: the mean direction ∫ω dω over the plate's cone, ½ Σ_edges Θ_e n_e
            // (Arvo 1994), oriented towards the plate (for a wide plate it is −m, as for the half-space).
            vec3 a[4] = vec3[4](a0, a1, a2, a3);
            vec3 mean = vec3(0.0);
            for (int k = 0; k < 4; ++k) {
                vec3 x = cross(a[k], a[(k + 1) & 3]);
                float lx = length(x);
                if (lx > 0.0) mean += 0.5 * atan(lx, dot(a[k], a[(k + 1) & 3])) * x / lx;
            }
            if (dot(mean, c) < 0.0) mean = -mean;
            if (!(dot(mean, mean) > 0.0)) mean = c;
            shexp_multiply_circle_visibility(g, clamp(omega / (2.0 * PI), 0.0, 1.0), mean, g_is_one && count == 0u);
        }
        count += 1u;
    }
    return count;
}

// The visibility vector g at p (1 when nothing blocks); g_blockers counts spheres and planes.
void shexp_visibility(vec3 p, vec3 n, out float g[SHN_C]) {
    for (int i = 0; i < SHN_C; ++i) g_log[i] = 0.0;
    g_p = p;
    g_n = n;
    g_blockers = 0u;
    g_large_count = 0u;
    bvh_reach = shx.reach;
    if (shx.sphere_count > 0u) {
        // cluster > 0: the blockers of the cluster's cut with their ratio vectors, unless it overflowed.
        bool cut_done = false;
        if (shx.cluster > 0u) {
            uint c = shexp_cluster_of_invocation();
            uvec4 head = cluster_heads[c];
            // bake=on: the cluster's cut is the last frame's; if this receiver has not moved either, its
            // visibility is the one it recorded then.
            uint rec = shexp_bake_record();
            bool unchanged = shx.bake != 0u && (head.y & SHEXP_CLUSTER_UNCHANGED) != 0u
                          && rec + uint(SHEXP_BAKE_STRIDE) <= uint(shexp_baked.length());
            if (unchanged && shexp_baked[rec + SHN_C + 1] == p.x && shexp_baked[rec + SHN_C + 2] == p.y
                && shexp_baked[rec + SHN_C + 3] == p.z && shexp_baked[rec + SHN_C + 4] == n.x
                && shexp_baked[rec + SHN_C + 5] == n.y && shexp_baked[rec + SHN_C + 6] == n.z) {
                for (int i = 0; i < SHN_C; ++i) g[i] = shexp_baked[rec + i];
                g_blockers = uint(shexp_baked[rec + SHN_C]);
                return;
            }
            if ((head.y & 3u) == 0u) {
                for (uint e = 0u; e < min(head.x, uint(SHEXP_CLUSTER_CAP)); ++e) {
                    shexp_visit_weighted(cluster_cut[head.w + e]);
                }
                cut_done = true;
            }
        }
        if (!cut_done) bvh_cut(shx.sphere_count, vec4(p, 0.0), shx.sin_theta_max, p, n, 0.5 * PI);
    }
    for (int i = 0; i < SHN_C; ++i) g[i] = 0.0;
#if SHEXP_PHASE <= 2
    // Timing variants stop before the exponential: g carries the summed log, so nothing is optimized away.
    g = g_log;
    return;
#endif
    bool one = g_blockers == 0u;
    if (one) {
        g[0] = SHN_SQRT_4PI;
    } else if (shx.accumulate == 1u) {
        g = g_prod;
    } else if (shx.exp_method == 1u) {
        shn_exp_ol(g_log, g);
    } else if (shx.exp_method == 2u) {
        shn_exp_ps_star(g_log, shx.ps_degree, g);
    } else {
        shn_exp_hyb(g_log, shx.hyb_target, g);
    }
    for (uint k = 0u; k < g_large_count; ++k) {
        shexp_multiply_circle_visibility(g, g_large[k].w, g_large[k].xyz, one && k == 0u);
    }
    one = one && g_large_count == 0u;
    g_blockers += g_large_count;
    g_blockers += shexp_planes(p, g, one);
    // A log so large that the squarings overflowed is deep occlusion: no visibility (no NaN/inf).
    bool bad = false;
    for (int i = 0; i < SHN_C; ++i) bad = bad || isnan(g[i]) || isinf(g[i]);
    if (bad) {
        for (int i = 0; i < SHN_C; ++i) g[i] = 0.0;
    }
    // bake=on: this receiver's record for the next frame (only from its cluster's cut: a cluster cut per
    // receiver after an overflow is never marked unchanged).
    if (shx.bake != 0u && shx.cluster > 0u && shx.sphere_count > 0u) {
        uint rec = shexp_bake_record();
        // Records for fewer receivers than the target has (too many pixels for the budget): no baking.
        if (rec + uint(SHEXP_BAKE_STRIDE) > uint(shexp_baked.length())) return;
        for (int i = 0; i < SHN_C; ++i) shexp_baked[rec + i] = g[i];
        shexp_baked[rec + SHN_C] = float(g_blockers);
        shexp_baked[rec + SHN_C + 1] = p.x;
        shexp_baked[rec + SHN_C + 2] = p.y;
        shexp_baked[rec + SHN_C + 3] = p.z;
        shexp_baked[rec + SHN_C + 4] = n.x;
        shexp_baked[rec + SHN_C + 5] = n.y;
        shexp_baked[rec + SHN_C + 6] = n.z;
    }
}

float shexp_h_star(int l) {
    return shx.h_star[l >> 2][l & 3];
}

// The windowed scaled zonal coefficients of a light's cap of half-angle α (the whole sphere when
// `outside` is false).
void shexp_cap_star(bool outside, float cos_alpha, out float cstar[SH_MAX_ORDER]) {
    shexp_cap_star_raw(outside ? cos_alpha : -1.0, cstar);
    for (int l = 0; l < SHEXP_N; ++l) cstar[l] *= shx.window[l >> 2][l & 3];
}

vec3 shade_point(ShadePoint sp) {
    vec3 n = sp.normal;
    float g[SHN_C];
    shexp_visibility(sp.position, n, g);
#if SHEXP_PHASE <= 3
    // Timing variants: a tiny value that depends on every coefficient of g (nothing is optimized away).
    float keep = float(g_blockers);
    for (int i = 0; i < SHN_C; ++i) keep += abs(g[i]);
    return vec3(1e-30 * keep);
#endif
    // H(N), and P = H * g: every shaded quantity is a dot product with P (shadowed) or H (unshadowed).
    float y[SHN_C];
    shn_eval(n, y);
    float hv[SHN_C];
    for (int l = 0; l < SHEXP_N; ++l) {
        for (int i = l * l; i < (l + 1) * (l + 1); ++i) hv[i] = shexp_h_star(l) * y[i];
    }
    bool shadowed = g_blockers > 0u;
    float pv[SHN_C];
    if (shadowed) {
        shn_product(hv, g, pv);
    } else {
        // g = 1: H * 1 = H exactly.
        pv = hv;
    }
    vec3 e_sh = vec3(0.0);
    vec3 e_free = vec3(0.0);
    for (int i = 0; i < SHN_C; ++i) {
        e_sh += env_sh[i].rgb * pv[i];
        e_free += env_sh[i].rgb * hv[i];
    }
    // Ringing: in a crevice the order-n product L·(H * g) can fall to or below 0 where the true irradiance is small
    // but positive (black pixels where the reference is lit). There, and only there, the visibility's mean over
    // the sphere (g_0 Y_0, the DC term, non-negative for any exp method) times the unshadowed irradiance; twin:
    // shexp::cpu::ringing_fallback.
    if (shadowed && any(lessThanEqual(e_sh, vec3(0.0)))) e_sh = max(g[0] * 0.28209479177387814, 0.0) * max(e_free, vec3(0.0));
    vec3 ratio = vec3(1.0);
    for (int c = 0; c < 3; ++c) {
        if (e_free[c] > 1e-20) ratio[c] = clamp(e_sh[c] / e_free[c], 0.0, 1.0);
    }
    vec3 rho = sp.material.diffuse.rgb;
    vec3 result = shx.diffuse_mode == 1u ? rho / PI * irradiance_lookup(irradiance_map, n) * ratio : rho * max(e_sh, vec3(0.0));

    if (light_count > 0u) {
        SpecLobe lobes[BRDF_MAX_LOBES];
        int count = brdf_specular_lobes(sp.material, sp.normal, sp.view, lobes);
        for (uint j = 0u; j < light_count; ++j) {
            vec3 axis;
            float sa, ca;
            bool outside = light_cap(j, sp.position, axis, sa, ca);
            float v = 1.0;
            if (shadowed) {
                float cstar[SH_MAX_ORDER];
                shexp_cap_star(outside, ca, cstar);
                float yc[SHN_C];
                shn_eval(axis, yc);
                float num = 0.0, den = 0.0;
                for (int l = 0; l < SHEXP_N; ++l) {
                    for (int i = l * l; i < (l + 1) * (l + 1); ++i) {
                        num += cstar[l] * yc[i] * pv[i];
                        den += cstar[l] * yc[i] * hv[i];
                    }
                }
                v = den > 1e-12 ? clamp(num / den, 0.0, 1.0) : 1.0;
            }
            if (v > 0.0) result += v * light_unshadowed(sp, j, lobes, count, outside, axis, sa, ca);
        }
    }

    vec3 ks = sp.material.specular.rgb;
    if (all(equal(ks, vec3(0.0)))) return result;
    // Glossy: the diffuse visibility ratio (luminance-weighted) times the unshadowed glossy term.
    vec3 lum_w = vec3(0.2126, 0.7152, 0.0722);
    float den = dot(lum_w, e_free);
    float vd = den > 1e-20 ? clamp(dot(lum_w, e_sh) / den, 0.0, 1.0) : 1.0;
    return result + vd * specular_prefiltered(prefiltered_env, sp.material, sp.normal, sp.view);
}
