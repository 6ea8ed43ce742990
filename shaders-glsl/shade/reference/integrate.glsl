// Monte Carlo ground truth: per shading point, progressive estimates of
//   L_o = ∫ f(ω_i, ω_o) (n·ω_i)⁺ [L_env(ω_i) + Σ_j L_j(ω_i)] V(ω_i) dω_i
// with three strategies per sample, combined by the power heuristic (Veach 1997, §9.2):
//   1. environment importance sampling (luminance × texel solid angle, marginal + conditional CDF);
//   2. spherical-light sampling (uniform in the subtended cone; one light chosen uniformly);
//   3. BRDF sampling (cosine for the diffuse lobe; the specular model's half-vector density,
//      common/brdf.glsl: (n·h)^s, D(h)(n·h) or Ashikhmin-Shirley's; chosen by weight).
// The environment is the piecewise-constant map (texelFetch), the same function engine_math's
// integrals use; lights add their radiance along the directions they subtend and cast no shadows.
// Nothing is clamped: a non-finite sample is counted in Diagnostics and replaced by zero.
#ifndef REFERENCE_INTEGRATE_GLSL
#define REFERENCE_INTEGRATE_GLSL
#include "../common.glsl"
#include "../lights.glsl"
#include "trace.glsl"
#include "../../common/frame.glsl"
#include "../../common/brdf.glsl"

// Twin of engine::passes::shade::reference::ReferenceParams.
layout(push_constant) uniform Params {
    uint sample_base;  // samples already accumulated (0: overwrite)
    uint samples;      // samples this dispatch
    uint seed;
    uint pad_lights;   // the light count is in the shared Lights buffer
    uint env_width;
    uint env_height;
    uint visibility;   // 0 triangles, 1 none (unoccluded), 2 blocker spheres
    uint item_count;
    float ray_offset;  // along the normal, relative to g_coordinate_scale
    float env_total;   // 0: the environment is black (no environment sampling)
    uint sphere_count;
    float pad0;
} params;

// Welford accumulation per item: mean.rgb (w = 1 on covered items), m2.rgb = Σ (x − mean)².
layout(std430, binding = 6) buffer AccumMean { vec4 accum_mean[]; };
layout(std430, binding = 7) buffer AccumM2 { vec4 accum_m2[]; };
// Marginal CDF over rows (H + 1 entries) and conditional CDFs per row (H × (W + 1)).
layout(std430, binding = 8) readonly buffer EnvMarginal { float env_marginal[]; };
layout(std430, binding = 9) readonly buffer EnvConditional { float env_conditional[]; };
layout(std430, binding = 13) buffer Diagnostics { uint nonfinite_samples; };

// ---- random numbers: PCG (Jarzynski & Olano 2020, "Hash functions for GPU rendering") ----
uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

float rand(inout uint s) {
    s = s * 747796405u + 2891336453u;
    uint w = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    w = (w >> 22u) ^ w;
    return float(w >> 8) * (1.0 / 16777216.0);  // [0, 1)
}

// ---- frames and the material ----
vec3 local_to_world(vec3 n, float cos_t, float phi) {
    vec3 t, b;
    orthonormal_basis(n, t, b);
    float sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
    return normalize(sin_t * cos(phi) * t + sin_t * sin(phi) * b + cos_t * n);
}

// f(l, v) (n·l)⁺ for f = ρ_d/π + f_s, f_s the material's exact specular term (common/brdf.glsl).
vec3 brdf_cos(Material m, vec3 n, vec3 v, vec3 l) {
    float nl = dot(n, l);
    if (nl <= 0.0) return vec3(0.0);
    vec3 f = m.diffuse.rgb / PI;
    if (brdf_has_specular(m)) f += brdf_specular(m, n, brdf_tangent(m, n), v, l);
    return f * nl;
}

// Probability of choosing the specular lobe: k_s (times Σ w_i for Lafortune lobes) against ρ_d (means over RGB).
float specular_choice(Material m) {
    float kd = dot(m.diffuse.rgb, vec3(1.0 / 3.0));
    float ks = dot(m.specular.rgb, vec3(1.0 / 3.0));
    if (brdf_kind(m) == BRDF_LAFORTUNE) ks *= m.lobes.x + m.lobes.y + m.lobes.z;
    return ks + kd > 0.0 ? ks / (ks + kd) : 0.0;
}

// Solid-angle density of BRDF sampling.
float brdf_pdf(Material m, float p_spec, vec3 n, vec3 v, vec3 l) {
    float nl = dot(n, l);
    float pdf = (1.0 - p_spec) * max(nl, 0.0) / PI;
    if (p_spec > 0.0) pdf += p_spec * brdf_dir_pdf(m, n, brdf_tangent(m, n), v, l);
    return pdf;
}

// A BRDF-sampled direction (may point below the surface: then it contributes nothing).
vec3 sample_brdf(Material m, float p_spec, vec3 n, vec3 v, inout uint rng) {
    float xi = rand(rng);
    float u1 = rand(rng);
    float u2 = rand(rng);
    if (xi < p_spec) return brdf_sample_dir(m, n, brdf_tangent(m, n), v, u1, u2);
    return local_to_world(n, sqrt(1.0 - u1), 2.0 * PI * u2);  // cosine-weighted
}

// ---- environment ----
float env_prob(uint row, uint col) {
    uint w1 = params.env_width + 1u;
    return (env_marginal[row + 1u] - env_marginal[row]) *
           (env_conditional[row * w1 + col + 1u] - env_conditional[row * w1 + col]);
}

// Largest i in [0, n) with cdf[base + i] <= x (cdf[base] = 0 <= x < 1 = cdf[base + n]).
uint search_marginal(float x) {
    uint lo = 0u, hi = params.env_height;
    while (lo + 1u < hi) {
        uint mid = (lo + hi) / 2u;
        if (env_marginal[mid] <= x) lo = mid; else hi = mid;
    }
    return lo;
}

uint search_conditional(uint row, float x) {
    uint base = row * (params.env_width + 1u);
    uint lo = 0u, hi = params.env_width;
    while (lo + 1u < hi) {
        uint mid = (lo + hi) / 2u;
        if (env_conditional[base + mid] <= x) lo = mid; else hi = mid;
    }
    return lo;
}

// Density over solid angle of environment sampling at direction d (0 where a texel has
// probability 0; -1 at the poles, where the lat-long Jacobian is singular).
float env_pdf(vec3 d, out ivec2 texel) {
    vec2 uv = envmap_uv(d);
    uint col = min(uint(uv.x * float(params.env_width)), params.env_width - 1u);
    uint row = min(uint(uv.y * float(params.env_height)), params.env_height - 1u);
    texel = ivec2(col, row);
    float sin_t = sqrt(max(0.0, 1.0 - d.y * d.y));
    if (sin_t <= 0.0) return -1.0;
    return env_prob(row, col) * float(params.env_width * params.env_height) / (2.0 * PI * PI * sin_t);
}

// ---- lights ----
// Cone of light j seen from p: returns 1 − cos θ_max (stable for small lights), or 2 if p is inside.
float light_cone(uint j, vec3 p, out vec3 axis, out float dist) {
    vec3 c = lights[j].center;
    float r = lights[j].radius;
    vec3 d = c - p;
    dist = length(d);
    axis = dist > 0.0 ? d / dist : vec3(0.0, 1.0, 0.0);
    if (dist <= r) return 2.0;
    float s2 = (r / dist) * (r / dist);
    return s2 / (1.0 + sqrt(max(0.0, 1.0 - s2)));
}

// Distance along unit d from p to light j's surface (entry; exit when p is inside), or -1.
float light_hit(uint j, vec3 p, vec3 d) {
    vec3 c = lights[j].center;
    float r = lights[j].radius;
    vec3 oc = c - p;
    float b = dot(d, oc);
    float q = dot(oc, oc) - b * b;
    float disc = r * r - q;
    if (disc < 0.0) return -1.0;
    float sq = sqrt(disc);
    float t0 = b - sq;
    float t1 = b + sq;
    if (t0 > 0.0) return t0;
    return t1 > 0.0 ? t1 : -1.0;
}

float visible_until(vec3 o, vec3 d, float t_max) {
    if (params.visibility == 1u) return t_max;
    if (params.visibility == 2u)
        return trace_planes(o, d, trace_thin(o, d, trace_spheres(o, d, t_max, params.sphere_count, false), false, true),
                            false);
    // The truth: the solid meshes' BVH and the thin meshes' live triangles, each hit exactly.
    return trace_thin(o, d, trace_triangles(o, d, t_max, false), false, false);
}

bool unoccluded(vec3 o, vec3 d, float t_max) {
    if (params.visibility == 1u) return true;
    if (params.visibility == 2u)
        return trace_spheres(o, d, t_max, params.sphere_count, true) >= t_max &&
               trace_thin(o, d, t_max, true, true) >= t_max && trace_planes(o, d, t_max, true) >= t_max;
    return trace_triangles(o, d, t_max, true) >= t_max && trace_thin(o, d, t_max, true, false) >= t_max;
}

// Power heuristic weight of a strategy with density pa against one with pb.
float power_weight(float pa, float pb) {
    float r = pb / pa;
    return 1.0 / (1.0 + r * r);
}

// The magnitude of the coordinates the shading point was computed from (set by pixel.comp and vertex.comp):
// its rounding error, and the intersection's near it, scale with them (pbrt-v4 bounds a hit point's error by
// γ_n Σ |b_i p_i|), not with the scene's size.
float g_coordinate_scale = 1.0;

float max_abs(vec3 v) {
    vec3 a = abs(v);
    return max(a.x, max(a.y, a.z));
}

// One sample of L_o: one environment sample, one light sample, one BRDF sample.
vec3 reference_sample(ShadePoint sp, inout uint rng) {
    Material m = sp.material;
    vec3 n = sp.normal;
    vec3 v = sp.view;
    // Ray origins move along the geometric normal, as pbrt-v4's OffsetRayOrigin and Mitsuba 3's
    // spawn_ray do (the shading normal may lean over the triangle's plane). Those move to the ray's
    // side; with reflection-only BRDFs the viewer's side is used for every ray, so a direction above
    // the shading plane but below the triangle's meets the surface itself instead of leaking through.
    vec3 o = sp.position + params.ray_offset * g_coordinate_scale * sp.geometric;
    g_receiver_p = sp.position;
    g_receiver_n = n;
    float p_spec = specular_choice(m);
    const float inf = 1e30;  // "no hit" distance (finite: no inf arithmetic in traversal)
    float nl_count = float(light_count);
    vec3 result = vec3(0.0);

    // 1. Environment sample.
    if (params.env_total > 0.0) {
        float x0 = rand(rng), x1 = rand(rng), x2 = rand(rng), x3 = rand(rng);
        uint row = search_marginal(x0);
        uint w1 = params.env_width + 1u;
        float p_row = env_marginal[row + 1u] - env_marginal[row];
        uint col = search_conditional(row, x2);
        float c0 = env_conditional[row * w1 + col];
        float p_col = env_conditional[row * w1 + col + 1u] - c0;
        float v_coord = (float(row) + x1) / float(params.env_height);
        float u_coord = (float(col) + x3) / float(params.env_width);
        vec3 l = envmap_direction(vec2(u_coord, v_coord));
        float sin_t = sin(PI * v_coord);
        float pdf = p_row * p_col * float(params.env_width * params.env_height) / (2.0 * PI * PI * sin_t);
        vec3 fc = brdf_cos(m, n, v, l);
        if (pdf > 0.0 && sin_t > 0.0 && any(greaterThan(fc, vec3(0.0))) && unoccluded(o, l, inf)) {
            vec3 le = texelFetch(env_map, ivec2(col, row), 0).rgb;
            float w = power_weight(pdf, brdf_pdf(m, p_spec, n, v, l));
            result += fc * le * (w / pdf);
        }
    }

    // 2. Light sample: one light, chosen uniformly.
    if (light_count > 0u) {
        uint j = min(uint(rand(rng) * nl_count), light_count - 1u);
        float x0 = rand(rng), x1 = rand(rng);
        vec3 axis;
        float dist;
        float one_minus_cos = light_cone(j, sp.position, axis, dist);
        float cos_t = 1.0 - x0 * one_minus_cos;
        vec3 l = local_to_world(axis, cos_t, 2.0 * PI * x1);
        float pdf = 1.0 / (2.0 * PI * one_minus_cos * nl_count);
        vec3 fc = brdf_cos(m, n, v, l);
        float t = light_hit(j, sp.position, l);
        if (t > 0.0 && any(greaterThan(fc, vec3(0.0))) && unoccluded(o, l, t)) {
            float w = power_weight(pdf, brdf_pdf(m, p_spec, n, v, l));
            result += fc * lights[j].radiance.rgb * (w / pdf);
        }
    }

    // 3. BRDF sample: the environment and every light it reaches.
    {
        vec3 l = sample_brdf(m, p_spec, n, v, rng);
        vec3 fc = brdf_cos(m, n, v, l);
        float pdf = brdf_pdf(m, p_spec, n, v, l);
        if (pdf > 0.0 && any(greaterThan(fc, vec3(0.0)))) {
            float t_hit = light_count > 0u ? visible_until(o, l, inf) : (unoccluded(o, l, inf) ? inf : 0.0);
            if (t_hit >= inf) {
                ivec2 texel;
                float pe = env_pdf(l, texel);
                if (params.env_total <= 0.0) pe = max(pe, 0.0);  // black: no environment strategy
                if (pe >= 0.0) {
                    vec3 le = texelFetch(env_map, texel, 0).rgb;
                    result += fc * le * (power_weight(pdf, pe) / pdf);
                }
            }
            for (uint j = 0u; j < light_count; ++j) {
                float t = light_hit(j, sp.position, l);
                if (t <= 0.0 || t > t_hit) continue;
                vec3 axis;
                float dist;
                float pl = 1.0 / (2.0 * PI * light_cone(j, sp.position, axis, dist) * nl_count);
                result += fc * lights[j].radiance.rgb * (power_weight(pdf, pl) / pdf);
            }
        }
    }
    return result;
}

// Accumulate `samples` samples of item `item` (Welford, merged with the stored batch by Chan et
// al.'s parallel update) and return the running mean.
vec3 accumulate(uint item, ShadePoint sp) {
    uint n_a = params.sample_base;
    vec3 mean_b = vec3(0.0);
    vec3 m2_b = vec3(0.0);
    for (uint k = 0u; k < params.samples; ++k) {
        uint index = n_a + k;
        uint rng = pcg_hash(params.seed ^ pcg_hash(item ^ pcg_hash(index)));
        vec3 x = reference_sample(sp, rng);
        if (any(isnan(x)) || any(isinf(x))) {
            atomicAdd(nonfinite_samples, 1u);
            x = vec3(0.0);
        }
        vec3 delta = x - mean_b;
        mean_b += delta / float(k + 1u);
        m2_b += delta * (x - mean_b);
    }
    if (n_a == 0u) {
        accum_mean[item] = vec4(mean_b, 1.0);
        accum_m2[item] = vec4(m2_b, 0.0);
        return mean_b;
    }
    float na = float(n_a);
    float nb = float(params.samples);
    float nn = na + nb;
    vec3 mean_a = accum_mean[item].rgb;
    vec3 delta = mean_b - mean_a;
    vec3 mean = mean_a + delta * (nb / nn);
    vec3 m2 = accum_m2[item].rgb + m2_b + delta * delta * (na * nb / nn);
    accum_mean[item] = vec4(mean, 1.0);
    accum_m2[item] = vec4(m2, 0.0);
    return mean;
}

// Items that are not surfaces (background pixels): fixed value, zero variance.
void store_fixed(uint item, vec3 value) {
    accum_mean[item] = vec4(value, 0.0);
    accum_m2[item] = vec4(0.0);
}

#endif
