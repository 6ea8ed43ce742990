// Technique `none`: unshadowed environment lighting.
// Diffuse: ρ_d/π · E(n) from the irradiance map (exact clamped-cosine convolution).
// Specular: normalized Blinn-Phong k_s (s+8)/(8π) (n·h)^s as one SG around the reflection
// direction r with λ = s / (4 n·v) (the half-vector warp), so
//   L_s ≈ k_s (s+8)/(8π) (n·r)⁺ Γ̄(r, λ) · 2π(1 − e^{−2λ})/λ
// with Γ̄ the normalized SG-prefiltered environment (ISG Eq. 10), interpolated in log λ.
#include "../common.glsl"
layout(binding = 8) uniform sampler2D irradiance_map;
layout(binding = 9) uniform sampler2D prefiltered_env;

vec3 prefiltered_level(vec3 r, float level) {
    float levels = float(frame.size.w);
    vec2 uv = envmap_uv(r);
    float rows = float(textureSize(prefiltered_env, 0).y) / levels;
    float v = clamp(uv.y, 0.5 / rows, 1.0 - 0.5 / rows);
    return textureLod(prefiltered_env, vec2(uv.x, (level + v) / levels), 0.0).rgb;
}

vec3 prefiltered_lookup(vec3 r, float lambda) {
    // Levels hold λ_k = 4^(k−1).
    float t = clamp(log(lambda) / log(4.0) + 1.0, 0.0, float(frame.size.w) - 1.0);
    float k = floor(t);
    float f = t - k;
    vec3 a = prefiltered_level(r, k);
    vec3 b = prefiltered_level(r, min(k + 1.0, float(frame.size.w) - 1.0));
    return mix(a, b, f);
}

vec3 shade_point(ShadePoint sp) {
    vec3 diffuse = sp.material.diffuse.rgb / PI * textureLod(irradiance_map, envmap_uv(sp.normal), 0.0).rgb;
    vec3 ks = sp.material.specular.rgb;
    if (all(equal(ks, vec3(0.0)))) return diffuse;
    float s = sp.material.specular.w;
    float nv = max(dot(sp.normal, sp.view), 1e-3);
    vec3 r = reflect(-sp.view, sp.normal);
    float lambda = s / (4.0 * nv);
    float nr = max(dot(sp.normal, r), 0.0);
    float sg_integral = 2.0 * PI * (1.0 - exp(-2.0 * lambda)) / lambda;
    vec3 spec = ks * ((s + 8.0) / (8.0 * PI)) * nr * prefiltered_lookup(r, lambda) * sg_integral;
    return diffuse + spec;
}
