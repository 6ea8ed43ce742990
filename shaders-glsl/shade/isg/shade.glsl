// Technique `isg` (engine passes::shade::isg): soft shadows from blocker spheres with integral
// spherical Gaussians (Iwasaki et al. 2012).
// Diffuse (Eq. 5–6): ρ/π Σ_k μ_k ∫ G_k G_cos V, each product lobe's visible integral by
// isg_occlusion (common/isg_visibility.glsl). Specular (Eq. 7–10): the unshadowed prefiltered
// Blinn-Phong term (as in `none`) times the visibility ratio of Eq. 9 on the product of the BRDF lobe
// and the cosine lobe. Spherical lights (ours): each light's unshadowed term (../lights.glsl) times its
// visibility V_j = 1 − Σ_occluded C_p / Σ C_p over the patches of the hemisphere grid above n whose
// centres lie in the light's cap (the patch holding the cap's axis when no centre does), the same
// grid and marking as `diffuse=map`, in every diffuse mode. f64 twin: isg::cpu::light_visibility.
// Blockers: spheres (the BVH), thin-shell triangles and planes (half-spaces and rectangles), each
// marking the patches whose centre direction it blocks.
#include "../common.glsl"
#include "../prefiltered.glsl"
#include "../lights.glsl"
#include "../../common/sg.glsl"
#define BVH_STACK_SIZE 32
#define ISG_MAX_BLOCKERS 32
#include "../tiles.glsl"
#include "../../common/bvh.glsl"

layout(binding = 8) uniform sampler2D prefiltered_env;
layout(binding = 13) uniform sampler2D irradiance_map;
// Twin: engine::passes::shade::isg::GpuSgLobe.
struct EnvLobe {
    vec3 axis;
    float lambda;
    vec3 mu;
    float pad0;
};
layout(std430, binding = 9) readonly buffer EnvSgs { EnvLobe env_lobes[]; };
layout(std430, binding = 10) readonly buffer IsgTable { vec4 isg_table[]; };
layout(std430, binding = 11) readonly buffer BvhNodes { BvhNode bvh_nodes[]; };
// Twin: engine::passes::shade::isg::GpuIsgParams.
struct IsgParams {
    uint lobe_count;          // K: environment lobes in EnvSgs
    uint side;                // patches per side of the visibility grid
    uint evaluator;           // 0 table, 1 paper
    uint sphere_count;
    float log_epsilon;        // ln ε
    float node_threshold;     // patch widths
    float cosine_lambda;      // the cosine SG's λ
    float cosine_mu;          // the cosine SG's μ
    float gather_take_whole;  // the shared gather's node-size threshold (radians), from prepare
    uint diffuse_mode;        // 0 sg, 1 ratio, 2 map
    float reach;              // bounded reach (common/bvh.glsl), scene units; 0: off
    uint pad1;
};
layout(std430, binding = 12) readonly buffer IsgParamsBuf { IsgParams isg; };

#define ISG_LUT_FETCH(i) isg_table[i]
#define ISG_BVH_NODE(i) bvh_nodes[i]
// Thin shells (common/isg_thin.glsl): world-space triangles and clusters from the thin_shells pass.
// Only in the variant the technique builds for scenes with thin meshes (ISG_THIN_SHELLS); otherwise
// isg_thin.glsl's no-op stubs, so scenes without them pay nothing.
#ifdef ISG_THIN_SHELLS
#include "../../common/thin.glsl"
layout(std430, binding = 14) readonly buffer ThinTriangles { ThinTriangle thin_triangles[]; };
layout(std430, binding = 15) readonly buffer ThinClusters { ThinCluster thin_clusters[]; };
#define ISG_THIN
#define ISG_THIN_TRIANGLE(i) thin_triangles[i]
#define ISG_THIN_CLUSTER(i) thin_clusters[i]
#define ISG_THIN_CLUSTER_COUNT uint(thin_clusters.length())
#endif
// Plane blockers (common/isg_planes.glsl): the scene's half-spaces and rectangles, world space.
#include "../../common/planes.glsl"
layout(std430, binding = 21) readonly buffer BlockerPlanes {
    uint plane_count;
    BlockerPlane blocker_planes[];  // at least one record (zero when plane_count = 0)
};
#define ISG_PLANES
#define ISG_PLANE_COUNT plane_count
#define ISG_PLANE(i) blocker_planes[i]
#include "../../common/isg_visibility.glsl"
#include "specular.glsl"

// (1 − e^{−2λ})/λ · 2π: the sphere integral of a unit-amplitude SG.
float isg_full_integral(float lambda) {
    return 2.0 * PI * sg_unit_integral_over_2pi(lambda);
}

// The hemisphere grid above n (Γ = π/2 around n) with the patches occluded by the blockers marked in
// isg_mask: the grid of diffuse mode `map` and of the lights' visibility.
IsgGrid isg_hemisphere_mask(vec3 p, vec3 n, IsgSettings st, uint spheres) {
    IsgGrid g = isg_grid(n, 0.0, st);
    isg_mask_clear();
    if (spheres > 0u) isg_mark_traversed(g, p, n, isg.gather_take_whole, spheres);
    isg_thin_mark(g);  // thin-shell triangles (common/isg_thin.glsl)
    isg_planes_mark(g);  // plane blockers (common/isg_planes.glsl)
    return g;
}

// Cosine-weighted solid angle of the patches of `bits` in row i: a_i Σ_j (cos φ0_j − cos φ1_j).
float isg_row_weight(IsgGrid g, int i, uint bits) {
    float w = 0.0;
    while (bits != 0u) {
        int j = findLSB(bits);
        bits &= bits - 1u;
        float p0 = g.lo + float(j) * g.delta;
        w += cos(p0) - cos(p0 + g.delta);
    }
    return isg_row_sin2(g, i) * w;
}

// The prefiltered light of cells of w × w patches (w = 1 or 2) whose first row is i, one read per cell at
// its centre from atlas level `level`, times the cell's exact cosine-weighted solid angle
// ½[θ − sin θ cos θ] over its rows times [−cos φ] over its columns; bit j of `bits`: the cell whose first
// column is j.
vec3 isg_map_cells(IsgGrid g, int i, int w, uint bits, float level) {
    float width = float(w) * g.delta;
    float t0 = g.lo + float(i) * g.delta;
    float t1 = t0 + width;
    float a = 0.5 * ((t1 - sin(t1) * cos(t1)) - (t0 - sin(t0) * cos(t0)));
    float th = t0 + 0.5 * width;
    float st_ = sin(th);
    vec3 row_dir = cos(th) * g.y;
    vec3 sum = vec3(0.0);
    while (bits != 0u) {
        int j = findLSB(bits);
        bits &= bits - 1u;
        ISG_COUNT(4, 1);
        float p0 = g.lo + float(j) * g.delta;
        float ph = p0 + 0.5 * width;
        vec3 dir = st_ * cos(ph) * g.x + row_dir + st_ * sin(ph) * g.z;
        sum += prefiltered_level(prefiltered_env, dir, level) * (a * (cos(p0) - cos(p0 + width)));
    }
    return sum;
}

// Diffuse mode `map`: E(n) minus the light of the occluded patches (isg_mask) of one P × P grid over
// the hemisphere above n, each patch's radiance read from the prefiltered environment (filter width
// matched to the patch: the atlas level nearest to it) times its exact cosine-weighted solid angle.
// An aligned 2 × 2 block of occluded patches (rows 2k, 2k+1, columns 2l, 2l+1) is read once, at its
// centre and at the level of width 2δ, times its own weight (the four patches' sum): a quarter of the
// reads where the blockers cover whole regions, for +0.01–0.06 points of error on the bunny (README).
vec3 isg_map_irradiance(vec3 n, IsgGrid g) {
    vec3 irr = irradiance_lookup(irradiance_map, n);
    // Box of width δ ↔ SG of the same variance: 1/λ = δ²/12 (P = 32: λ = 1245, level 6 at λ = 1024).
    float level = prefiltered_nearest_level(12.0 / (g.delta * g.delta));
    float block_level = prefiltered_nearest_level(3.0 / (g.delta * g.delta));  // width 2δ
    vec3 occluded = vec3(0.0);
    for (int i = 0; i < g.side; i += 2) {
        uint m0 = isg_mask[i];
        uint m1 = i + 1 < g.side ? isg_mask[i + 1] : 0u;
        if ((m0 | m1) == 0u) continue;
        // Aligned 2 × 2 blocks wholly occluded (bit 2l: columns 2l and 2l + 1 of both rows).
        uint both = m0 & m1;
        uint blocks = both & (both >> 1u) & 0x55555555u;
        if (blocks != 0u) {
            occluded += isg_map_cells(g, i, 2, blocks, block_level);
            uint taken = blocks | (blocks << 1u);
            m0 &= ~taken;
            m1 &= ~taken;
        }
        occluded += isg_map_cells(g, i, 1, m0, level);
        if (i + 1 < g.side) occluded += isg_map_cells(g, i + 1, 1, m1, level);
    }
    return max(irr - occluded, vec3(0.0));
}

// Visibility of a light's cap (axis, half-angle α; `outside` false: the whole sphere) in the
// hemisphere grid (occluded patches in isg_mask): 1 − Σ_occluded C_p / Σ C_p over the patches whose
// centres lie in the cap; a cap holding no patch centre takes the patch that holds its axis (1 when the
// axis is below the grid).
float isg_light_visibility(IsgGrid g, bool outside, vec3 axis, float sin_alpha, float cos_alpha) {
    float total = 0.0;
    float occluded = 0.0;
    float psi = outside ? atan(sin_alpha, cos_alpha) : ISG_PI;
    uint full = isg_bit_range(0, g.side - 1);
    vec4 uc = isg_cap_coords(g, axis);
    float cos_psi = cos(psi);
    ivec2 rows = psi >= ISG_PI ? ivec2(0, g.side - 1) : isg_cap_rows(g, psi, uc);
    for (int i = rows.x; i <= rows.y; ++i) {
        uint cap = psi >= ISG_PI ? full : isg_cap_row_bits(g, i, uc.x, uc.y, uc.z, cos_psi);
        if (cap == 0u) continue;
        total += isg_row_weight(g, i, cap);
        occluded += isg_row_weight(g, i, cap & isg_mask[i]);
    }
    if (total > 0.0) return clamp(1.0 - occluded / total, 0.0, 1.0);
    float ux = dot(axis, g.x), uy = dot(axis, g.y), uz = dot(axis, g.z);
    if (uz <= 0.0) return 1.0;
    float theta = atan(sqrt(ux * ux + uz * uz), uy);
    float phi = atan(uz, ux);
    int i = clamp(int(floor((theta - g.lo) / g.delta)), 0, g.side - 1);
    int j = clamp(int(floor((phi - g.lo) / g.delta)), 0, g.side - 1);
    return (isg_mask[i] >> uint(j) & 1u) != 0u ? 0.0 : 1.0;
}

// A light whose cap is narrower than this half-angle is seen on a grid of its own (isg_small_light_visibility),
// wider ones on the hemisphere grid.
const float ISG_LIGHT_OWN_GRID = 0.25 * ISG_PI;
const float ISG_SQRT2 = 1.41421356237310;
// Patches per side of a light's own grid.
const int ISG_LIGHT_SIDE = 8;

// Visibility of a light's cap (unit axis, half-angle alpha < π/2) on a grid of its own: ISG_LIGHT_SIDE²
// patches over (θ, φ) ∈ [π/2 − α, π/2 + α]² around its axis (Γ = α), blockers marked as for a lobe (its own
// traversal, nodes below node_threshold of its patch width taken whole), then 1 − Σ_occluded C_p / Σ C_p over
// the patches whose centres lie in the cap, C_p = the patch's solid angle (cos θ0 − cos θ1) δ times (n·ω)⁺ at
// its centre. On the hemisphere grid (δ = π/32 at P = 32) a light of 0.14 rad covers about six patches, so a
// penumbra's visibility came in sixths and its darkest sixth went black where the light was still partly seen
// (issue 35: `spheres`); here the cap covers about fifty patches whatever its size. f64 twin:
// isg::cpu::light_visibility.
float isg_small_light_visibility(vec3 p, vec3 n, vec3 axis, float alpha, IsgSettings st, uint spheres) {
    IsgGrid g;
    g.z = axis;
    orthonormal_basis(axis, g.x, g.y);
    g.side = ISG_LIGHT_SIDE;
    g.lo = ISG_HALF_PI - alpha;
    g.delta = 2.0 * alpha / float(g.side);
    float c = cos(alpha);
    g.cone = acos(clamp(c * c, 0.0, 1.0));
    isg_mask_clear();
    if (spheres > 0u) isg_mark_traversed(g, p, n, st.node_threshold * g.delta, spheres);
    isg_thin_mark(g);
    isg_planes_mark(g);
    uint any = 0u;
    for (int i = 0; i < g.side; ++i) any |= isg_mask[i];
    if (any == 0u) return 1.0;  // nothing in the light's cone (most receivers): no weights to sum
    vec4 uc = isg_cap_coords(g, axis);
    // n in the grid's frame, and the rotation by δ that steps a patch centre's φ along a row.
    vec3 nl = vec3(dot(n, g.x), dot(n, g.y), dot(n, g.z));
    vec2 step = vec2(cos(g.delta), sin(g.delta));
    float total = 0.0;
    float occluded = 0.0;
    for (int i = 0; i < g.side; ++i) {
        // The cap's patches in a row of a grid centred on it are one run of bits.
        uint cap = isg_cap_row_bits(g, i, uc.x, uc.y, uc.z, c);
        if (cap == 0u) continue;
        int j0 = findLSB(cap);
        int j1 = findMSB(cap);
        float t0 = g.lo + float(i) * g.delta;
        float th = t0 + 0.5 * g.delta;
        float row = (cos(t0) - cos(t0 + g.delta)) * g.delta;
        float st_ = sin(th);
        float ny = nl.y * cos(th);
        float ph = g.lo + (float(j0) + 0.5) * g.delta;
        vec2 cs = vec2(cos(ph), sin(ph));
        uint hidden = isg_mask[i];
        for (int j = j0; j <= j1; ++j) {
            float w = row * max(st_ * (nl.x * cs.x + nl.z * cs.y) + ny, 0.0);
            total += w;
            if ((hidden >> uint(j) & 1u) != 0u) occluded += w;
            cs = vec2(cs.x * step.x - cs.y * step.y, cs.y * step.x + cs.x * step.y);
        }
    }
    return total > 0.0 ? clamp(1.0 - occluded / total, 0.0, 1.0) : 1.0;
}

// Whether any occluded patch of the hemisphere grid (isg_mask) has its centre within psi of unit u.
bool isg_cap_touches_mask(IsgGrid g, vec3 u, float psi) {
    vec4 uc = isg_cap_coords(g, u);
    float cos_psi = cos(psi);
    ivec2 rows = isg_cap_rows(g, psi, uc);
    for (int i = rows.x; i <= rows.y; ++i) {
        if ((isg_cap_row_bits(g, i, uc.x, uc.y, uc.z, cos_psi) & isg_mask[i]) != 0u) return true;
    }
    return false;
}

// Σ over the lights of their unshadowed radiance times their visibility, with the hemisphere grid g and its
// occluded patches (isg_mask) marked when `occluders`. A light narrower than ISG_LIGHT_OWN_GRID is seen on its
// own grid (isg_small_light_visibility) unless no occluded patch of the hemisphere grid lies within its cap
// grown by a patch diagonal (V = 1: most receivers; a blocker of half-angle at least half a patch diagonal
// that overlaps the cap holds such a patch); the others in the hemisphere grid. The own grids reuse isg_mask,
// so they run after every light that reads the hemisphere grid (lights 32 and on: the hemisphere grid only).
vec3 isg_lights(ShadePoint sp, bool occluders, IsgGrid g, IsgSettings st, uint spheres) {
    SpecLobe lobes[BRDF_MAX_LOBES];
    int count = brdf_specular_lobes(sp.material, sp.normal, sp.view, lobes);
    vec3 sum = vec3(0.0);
    uint own = 0u;
    for (uint j = 0u; j < light_count; ++j) {
        vec3 axis;
        float sa, ca;
        bool outside = light_cap(j, sp.position, axis, sa, ca);
        float alpha = atan(sa, ca);
        float v = 1.0;
        if (occluders && outside && alpha < ISG_LIGHT_OWN_GRID && j < 32u) {
            if (isg_cap_touches_mask(g, axis, alpha + ISG_SQRT2 * g.delta)) {
                own |= 1u << j;
                continue;
            }
        } else if (occluders) {
            v = isg_light_visibility(g, outside, axis, sa, ca);
        }
        if (v > 0.0) sum += v * light_unshadowed(sp, j, lobes, count, outside, axis, sa, ca);
    }
    while (own != 0u) {
        uint j = uint(findLSB(own));
        own &= own - 1u;
        vec3 axis;
        float sa, ca;
        bool outside = light_cap(j, sp.position, axis, sa, ca);
        float v = isg_small_light_visibility(sp.position, sp.normal, axis, atan(sa, ca), st, spheres);
        if (v > 0.0) sum += v * light_unshadowed(sp, j, lobes, count, outside, axis, sa, ca);
    }
    return sum;
}

vec3 shade_point_radiance(ShadePoint sp);

// The counter variant (option `counters`): this point's work counts instead of its radiance,
// counters 0–2 (ISG_COUNTERS 1) or 3–5 (ISG_COUNTERS 2); see common/isg_visibility.glsl.
vec3 shade_point(ShadePoint sp) {
#ifdef ISG_COUNTERS
    uint base = 6u * gl_LocalInvocationIndex;
    for (uint i = 0u; i < 6u; ++i) s_isg_count[base + i] = 0u;
    vec3 radiance = shade_point_radiance(sp);
    // The radiance stays live (a negligible term) so that the compiler keeps the whole computation.
    uint first = ISG_COUNTERS == 1 ? 0u : 3u;
    vec3 counts = vec3(s_isg_count[base + first], s_isg_count[base + first + 1u], s_isg_count[base + first + 2u]);
    return counts + min(abs(radiance), vec3(1.0)) * 1e-30;
#else
    return shade_point_radiance(sp);
#endif
}

vec3 shade_point_radiance(ShadePoint sp) {
    IsgSettings st;
    st.side = int(isg.side);
    st.evaluator = int(isg.evaluator);
    uint diffuse_mode = isg.diffuse_mode;
    bool diffuse_ratio = diffuse_mode == 1u;
    st.log_epsilon = isg.log_epsilon;
    st.node_threshold = isg.node_threshold;
    uint spheres = isg.sphere_count;
    bvh_reach = isg.reach;
    float cos_lambda = isg.cosine_lambda;
    float cos_mu = isg.cosine_mu;
    vec3 n = sp.normal;
    isg_thin_begin(sp.position, n);
    isg_planes_begin(sp.position);

    // One gather for all diffuse lobes: the hemisphere above the tangent plane, nodes taken whole below
    // `threshold` widths of the finest grid any diffuse lobe can have (computed once at prepare). Points
    // whose blockers overflow the list (ISG_MAX_BLOCKERS) traverse once per lobe instead.
    uint k_count = diffuse_mode == 2u ? 0u : isg.lobe_count;
    isg_cap_count = 0;
    isg_caps_dropped = 0;
    if (spheres > 0u && k_count > 0u) {
        isg_gather(sp.position, n, n, ISG_HALF_PI, isg.gather_take_whole, spheres);
    }
    // (A per-lobe traversal replaces the list: decided once.)
    bool shared_list = isg_caps_dropped == 0;
    vec3 e = vec3(0.0);
    vec3 e_full = vec3(0.0);
    for (uint k = 0u; k < k_count; ++k) {
        EnvLobe l = env_lobes[k];
        vec3 axis;
        float lambda;
        float log_mu = sg_product_log(l.axis, l.lambda, 1.0, n, cos_lambda, cos_mu, axis, lambda);
        // A full blocker list would lose occlusion: such points traverse per lobe instead.
        vec2 occ = shared_list ? isg_occlusion_of(n, axis, lambda, st)
                               : isg_occlusion(sp.position, n, axis, lambda, st, spheres);
        float mu = exp(log_mu);
        float full = isg_full_integral(lambda);
        float h = isg_normalization(lambda);
        e += l.mu.rgb * max(mu * (full - h * occ.y), 0.0);
        e_full += l.mu.rgb * max(mu * (full - h * occ.x), 0.0);
    }
    if (diffuse_ratio) {
        // Exact irradiance times the lobes' visibility ratio (per channel; 1 where the fit is ~0).
        vec3 irr = irradiance_lookup(irradiance_map, n);
        vec3 ratio = vec3(1.0);
        for (int c = 0; c < 3; ++c) {
            if (e_full[c] > 1e-20) ratio[c] = clamp(e[c] / e_full[c], 0.0, 1.0);
        }
        e = irr * ratio;
    }
    // The hemisphere grid with its occluded patches (isg_mask), for `map` and for the lights; the
    // specular lobes below reuse isg_mask after them.
    bool occluders = spheres > 0u || isg_thin_present() || isg_planes_present();
    IsgGrid hemi;
    if (occluders && (diffuse_mode == 2u || light_count > 0u)) hemi = isg_hemisphere_mask(sp.position, n, st, spheres);
    if (diffuse_mode == 2u) e = occluders ? isg_map_irradiance(n, hemi) : irradiance_lookup(irradiance_map, n);
    vec3 result = sp.material.diffuse.rgb / PI * e;
    if (light_count > 0u) result += isg_lights(sp, occluders, hemi, st, spheres);

    vec3 ks = sp.material.specular.rgb;
    if (all(equal(ks, vec3(0.0)))) return result;
    if (brdf_kind(sp.material) != BRDF_BLINN_PHONG) return result + isg_specular_lobes(sp, st, spheres, cos_lambda, cos_mu);
    float s = sp.material.shininess;
    vec3 spec = blinn_phong_prefiltered(prefiltered_env, n, sp.view, ks, s);
    float ratio = 1.0;
    if (occluders) {
        float ndv = max(abs(dot(n, sp.view)), 1e-6);
        vec3 r = normalize(2.0 * dot(n, sp.view) * n - sp.view);
        vec3 axis;
        float lambda;
        sg_product_log(r, s / (4.0 * ndv), 1.0, n, cos_lambda, cos_mu, axis, lambda);
        vec2 occ = isg_occlusion(sp.position, n, axis, lambda, st, spheres);
        float full = isg_full_integral(lambda);
        float h = isg_normalization(lambda);
        float above = full - h * occ.x;
        ratio = above > 0.0 ? clamp((full - h * occ.y) / above, 0.0, 1.0) : 1.0;
    }
    return result + spec * ratio;
}
