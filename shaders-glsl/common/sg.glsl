// Spherical Gaussians, f32 twins of engine/math/src/sg.rs.
// G(v; a, λ, μ) = μ exp(λ(v·a − 1)), written with v·a − 1 = −|v − a|²/2 (no overflow, no cancellation).
#ifndef SG_GLSL
#define SG_GLSL

const float SG_PI = 3.14159265358979;
// L2-optimal clamped cosine max(n·v, 0) as one SG (sg.rs fit_clamped_cosine).
const float SG_COSINE_LAMBDA = 2.1438;
const float SG_COSINE_MU = 1.1766;

// μ exp(λ(v·a − 1)); twin of sg_eval.
float sg_eval(vec3 axis, float lambda, float mu, vec3 v) {
    vec3 d = v - axis;
    return mu * exp(-0.5 * lambda * dot(d, d));
}

// (1 − e^{−2λ})/λ without cancellation for small λ (series below 1e-3: f32 has no expm1).
float sg_unit_integral_over_2pi(float lambda) {
    if (lambda < 1e-3) {
        return 2.0 - 2.0 * lambda + (4.0 / 3.0) * lambda * lambda;
    }
    return (1.0 - exp(-2.0 * lambda)) / lambda;
}

// ∫ over the sphere: 2πμ (1 − e^{−2λ})/λ; twin of sg_integral.
float sg_integral(float lambda, float mu) {
    return 2.0 * SG_PI * mu * sg_unit_integral_over_2pi(lambda);
}

// Product of two SGs in log form; twin of sg_product_log. Writes the axis and sharpness,
// returns ln μ = ln μ1 + ln μ2 − λ1λ2|a1 − a2|²/(|p| + λ1 + λ2) (no cancellation; antipodal
// equal sharpness gives |p| = 0 and keeps a1 as the axis).
float sg_product_log(vec3 a1, float l1, float mu1, vec3 a2, float l2, float mu2,
                     out vec3 axis, out float lambda) {
    vec3 s = a1 + a2;
    vec3 d = a1 - a2;
    lambda = sqrt(max((l1 - l2) * (l1 - l2) + l1 * l2 * dot(s, s), 0.0));
    vec3 p = l1 * a1 + l2 * a2;
    float pl = length(p);
    axis = pl > 0.0 ? p / pl : a1;
    float denom = lambda + l1 + l2;
    float expo = denom > 0.0 ? -l1 * l2 * dot(d, d) / denom : 0.0;
    return log(mu1) + log(mu2) + expo;
}

// Product as an SG (x, y, z = axis, w = λ) and μ; twin of sg_product (positive amplitudes).
vec4 sg_product(vec3 a1, float l1, float mu1, vec3 a2, float l2, float mu2, out float mu) {
    vec3 axis;
    float lambda;
    float log_mu = sg_product_log(a1, l1, mu1, a2, l2, mu2, axis, lambda);
    mu = exp(log_mu);
    return vec4(axis, lambda);
}

// ∫ G1 G2 over the sphere, in log space; twin of sg_inner_product (positive amplitudes).
float sg_inner_product(vec3 a1, float l1, float mu1, vec3 a2, float l2, float mu2) {
    vec3 axis;
    float lambda;
    float log_mu = sg_product_log(a1, l1, mu1, a2, l2, mu2, axis, lambda);
    return exp(log_mu + log(2.0 * SG_PI * sg_unit_integral_over_2pi(lambda)));
}

// Reflection of v about n (both pointing away from the surface).
vec3 sg_reflect(vec3 v, vec3 n) {
    return 2.0 * dot(n, v) * n - v;
}

// Warp an SG over the half vector (axis n, sharpness λ_h) to the light direction (Wang et al.
// 2009): axis = reflect(v, n), λ = λ_h/(4|n·v|). Returns (axis, λ); μ is unchanged.
// Twin of warp_half_vector_lobe (and of blinn_phong_lobe with λ_h = s, μ = 1).
vec4 sg_warp_half_vector_lobe(vec3 n, vec3 v, float lambda_h) {
    float ndv = max(abs(dot(n, v)), 1e-6);
    return vec4(normalize(sg_reflect(v, n)), lambda_h / (4.0 * ndv));
}

#endif
