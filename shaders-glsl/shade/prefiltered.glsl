// Lookups into the SG-prefiltered environment atlas (engine passes::shade::none::prefiltered_atlas):
// levels k = 0..frame.prefiltered_levels−1 hold Γ̄_L at λ_k = 4^(k−1) (ISG Eq. 10), stacked vertically.
#ifndef SHADE_PREFILTERED_GLSL
#define SHADE_PREFILTERED_GLSL
#include "common.glsl"
#include "../common/brdf.glsl"
#include "../common/sg.glsl"

vec3 prefiltered_level(sampler2D atlas, vec3 r, float level) {
    float levels = float(frame.prefiltered_levels);
    vec2 uv = envmap_uv(r);
    float rows = float(textureSize(atlas, 0).y) / levels;
    float v = clamp(uv.y, 0.5 / rows, 1.0 - 0.5 / rows);
    return textureLod(atlas, vec2(uv.x, (level + v) / levels), 0.0).rgb;
}

// The atlas's level coordinate of sharpness λ: log_4 λ + 1, clamped to the levels.
float prefiltered_level_coord(float lambda) {
    return clamp(log(lambda) / log(4.0) + 1.0, 0.0, float(frame.prefiltered_levels) - 1.0);
}

// The atlas level nearest to sharpness λ in log λ: one texture read per direction where
// prefiltered_lookup blends two.
float prefiltered_nearest_level(float lambda) {
    return round(prefiltered_level_coord(lambda));
}

// Irradiance E(n) from the pole-inclusive grid (engine_math::prefilter::IrradianceGrid): rows at
// θ_j = π j/(rows − 1), so the first and last rows' centres sit on the poles.
vec3 irradiance_lookup(sampler2D grid, vec3 n) {
    vec2 uv = envmap_uv(n);
    float rows = float(textureSize(grid, 0).y);
    return textureLod(grid, vec2(uv.x, (uv.y * (rows - 1.0) + 0.5) / rows), 0.0).rgb;
}

// Normalized prefiltered radiance around r for an SG of sharpness λ, interpolated in log λ.
vec3 prefiltered_lookup(sampler2D atlas, vec3 r, float lambda) {
    float t = prefiltered_level_coord(lambda);
    float k = floor(t);
    float f = t - k;
    vec3 a = prefiltered_level(atlas, r, k);
    vec3 b = prefiltered_level(atlas, r, min(k + 1.0, float(frame.prefiltered_levels) - 1.0));
    return mix(a, b, f);
}

// Normalized Blinn-Phong k_s (s+8)/(8π) (n·h)^s as one SG around the reflection direction r with
// λ = s / (4 n·v) (half-vector warp), integrated against the prefiltered environment:
//   L_s ≈ k_s (s+8)/(8π) (n·r)⁺ Γ̄(r, λ) · 2π(1 − e^{−2λ})/λ.
vec3 blinn_phong_prefiltered(sampler2D atlas, vec3 n, vec3 view, vec3 ks, float s) {
    float nv = max(dot(n, view), 1e-3);
    vec3 r = reflect(-view, n);
    float lambda = s / (4.0 * nv);
    float nr = max(dot(n, r), 0.0);
    float sg_integral = 2.0 * PI * (1.0 - exp(-2.0 * lambda)) / lambda;
    return ks * ((s + 8.0) / (8.0 * PI)) * nr * prefiltered_lookup(atlas, r, lambda) * sg_integral;
}
// ∫ L G_j for one specular lobe (unit amplitude): Γ̄(a_j, λ_j) · 2π(1 − e^{−2λ_j})/λ_j.
vec3 prefiltered_lobe_integral(sampler2D atlas, SpecLobe lobe) {
    return prefiltered_lookup(atlas, lobe.axis, lobe.lambda) * sg_integral(lobe.lambda, 1.0);
}

// The unshadowed specular term of any material (common/brdf.glsl): Σ_j w_j ∫ L G_j, clamped at 0
// (twin: engine::math::brdf::specular_sum). Blinn-Phong keeps blinn_phong_prefiltered exactly.
vec3 specular_prefiltered(sampler2D atlas, Material m, vec3 n, vec3 view) {
    if (brdf_kind(m) == BRDF_BLINN_PHONG) return blinn_phong_prefiltered(atlas, n, view, m.specular.rgb, m.shininess);
    SpecLobe lobes[BRDF_MAX_LOBES];
    int count = brdf_specular_lobes(m, n, view, lobes);
    vec3 sum = vec3(0.0);
    for (int j = 0; j < count; ++j) {
        if (all(equal(lobes[j].weight, vec3(0.0)))) continue;
        sum += lobes[j].weight * prefiltered_lobe_integral(atlas, lobes[j]);
    }
    return max(sum, vec3(0.0));
}
#endif
