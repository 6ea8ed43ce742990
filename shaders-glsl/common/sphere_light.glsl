// Spherical lights, f32 twins of engine/math/src/sphere_light.rs (derivations and measured errors
// there): the cap a sphere subtends, the clamped cosine over it (exact) and an SG over it.
// Conventions: every direction vector is unit; a cap is (unit axis, sin α, cos α) with α ≤ π/2;
// 1 − cos α is always formed as sin²α/(1 + cos α) (small lights lose nothing).
//
// Entry points:
//   bool  cap_from_sphere(p, center, radius, out axis, out sin_alpha, out cos_alpha)
//   float cap_clamped_cosine(cos_theta, sin_alpha, cos_alpha)            ∫_cap max(n·ω, 0) dω
//   float cap_sg_integral(sg_axis, lambda, cap_axis, sin_alpha, cos_alpha) ∫_cap e^{λ(a·ω − 1)} dω
//   float sphere_light_clamped_cosine(p, n, center, radius)   (π when p is inside the light)
//   float sphere_light_sg_integral(p, center, radius, sg_axis, lambda)   (whole-sphere SG inside)
#ifndef SPHERE_LIGHT_GLSL
#define SPHERE_LIGHT_GLSL

#include "sg.glsl"

const float SL_PI = 3.14159265358979;
const float SL_HALF_PI = 1.57079632679490;
const float SL_QUARTER_PI = 0.785398163397448;
const float SL_TAN_PI_8 = 0.414213562373095;

// Cap of the sphere (center, radius ≥ 0) seen from p; false when p is inside or on it (then the
// light covers every direction; the outputs are axis towards the centre or +y, sin α = 1, cos α = 0).
// Twin of cap_from_sphere.
bool cap_from_sphere(vec3 p, vec3 center, float radius, out vec3 axis, out float sin_alpha, out float cos_alpha) {
    float r = max(radius, 0.0);
    vec3 d = center - p;
    float dist = length(d);
    if (!(dist > r)) {
        axis = dist > 0.0 ? d / dist : vec3(0.0, 1.0, 0.0);
        sin_alpha = 1.0;
        cos_alpha = 0.0;
        return false;
    }
    axis = d / dist;
    sin_alpha = r / dist;
    cos_alpha = sqrt(max((dist - r) * (dist + r), 0.0)) / dist;
    return true;
}

// atan(t) − t for |t| ≤ tan(π/8): −t³ Σ_k (−t²)^k/(2k+3), 9 terms (truncation < 2e-8 relative).
// The GLSL atan may err by 4096 ulp (the spec; lavapipe 3.4e-6 absolute), too coarse for small caps.
float sl_atan_tail(float t) {
    float z = t * t;
    float p = 1.0 / 19.0;
    p = 1.0 / 17.0 - z * p;
    p = 1.0 / 15.0 - z * p;
    p = 1.0 / 13.0 - z * p;
    p = 1.0 / 11.0 - z * p;
    p = 1.0 / 9.0 - z * p;
    p = 1.0 / 7.0 - z * p;
    p = 1.0 / 5.0 - z * p;
    p = 1.0 / 3.0 - z * p;
    return -t * z * p;
}

// atan2(y, x) for x, y ≥ 0 (not both 0), by reduction to |t| ≤ tan(π/8): a few ulp.
float sl_atan2_pos(float y, float x) {
    if (y <= SL_TAN_PI_8 * x) {
        float t = y / x;
        return t + sl_atan_tail(t);
    }
    if (x <= SL_TAN_PI_8 * y) {
        float t = -x / y;
        return SL_HALF_PI + t + sl_atan_tail(t);
    }
    float t = (y - x) / (y + x);
    return SL_QUARTER_PI + t + sl_atan_tail(t);
}

// atan(x) − x for x ≥ 0 (no cancellation for small x).
float sl_atan_minus_x(float x) {
    if (x <= SL_TAN_PI_8) {
        return sl_atan_tail(x);
    }
    return sl_atan2_pos(x, 1.0) - x;
}

// ∫_cap max(n·ω, 0) dω, cos_theta = n·axis; exact (Snyder 1996; Lagarde & de Rousiers 2014 §4.7.2),
// rewritten as π sin²α max(cos θ, 0) + M so that small caps do not cancel. Twin of cap_clamped_cosine.
float cap_clamped_cosine(float cos_theta, float sin_alpha, float cos_alpha) {
    float c = clamp(cos_theta, -1.0, 1.0);
    float sa = clamp(sin_alpha, 0.0, 1.0);
    float ca = clamp(cos_alpha, 0.0, 1.0);
    float sa2 = sa * sa;
    if (c >= sa) {
        return SL_PI * sa2 * c;
    }
    if (c <= -sa) {
        return 0.0;
    }
    float w = sqrt((sa - c) * (sa + c));
    float ac = abs(c);
    float m;
    if (w < ca) {
        float u = w / ca;
        float t2 = u <= SL_TAN_PI_8 * ac ? -sa2 * ac * sl_atan_tail(u / ac)
                                          : sa2 * (u - ac * sl_atan2_pos(u, ac));
        m = sl_atan_minus_x(u) + t2;
    } else {
        m = sl_atan2_pos(w, ca) - ca * w - sa2 * ac * sl_atan2_pos(w, ca * ac);
    }
    return clamp(SL_PI * sa2 * max(c, 0.0) + m, 0.0, SL_PI * sa2);
}

// λq at which cap_sg_integral's window ends, and its 5 Gauss–Legendre nodes and weights on [−1, 1].
const float SL_WINDOW = 10.0;
const float SL_GL_X[5] = float[5](-0.906179845938664, -0.538469310105683, 0.0, 0.538469310105683, 0.906179845938664);
const float SL_GL_W[5] = float[5](0.236926885056189, 0.478628670499366, 0.568888888888889, 0.478628670499366, 0.236926885056189);

// e^x I0e(κ) = e^{x − κ} I₀(κ), κ ≥ 0, x ≤ 0: Abramowitz & Stegun 9.8.1–9.8.2 (relative < 5e-7).
float sl_exp_i0e(float x, float kappa) {
    if (kappa < 3.75) {
        float t = kappa / 3.75;
        t *= t;
        float p = 1.0 + t * (3.5156229 + t * (3.0899424 + t * (1.2067492 + t * (0.2659732 + t * (0.0360768 + t * 0.0045813)))));
        return exp(x - kappa) * p;
    }
    float t = 3.75 / kappa;
    float p = 0.39894228 + t * (0.01328592 + t * (0.00225319 + t * (-0.00157565 + t * (0.00916281
            + t * (-0.02057706 + t * (0.02635537 + t * (-0.01647633 + t * 0.00392377)))))));
    return exp(x) * p * inversesqrt(kappa);
}

// Points of the radial range as vec2(ρ, δ = ρ − ρ_β): each window end is formed in both
// coordinates from its own definition, never one from the other (sphere_light.rs Point): a tiny cap
// far from the lobe would lose ρ to ρ_β + δ, a sharp lobe would lose δ to ρ − ρ_β.
float sl_width(vec2 a, vec2 b) {
    return abs(a.x) + abs(b.x) <= abs(a.y) + abs(b.y) ? b.x - a.x : b.y - a.y;
}

// The radial integrand F(ρ) = ρ e^{−λq} I0e(λ sin β sin s) (ρ = 2 sin(s/2) about the cap axis,
// ρ_β = 2 sin(β/2)); q = 2 sin²(s/2 − β/2) from δ, without cancellation at the peak.
float sl_cap_radial(vec2 x, float lambda, float rho_b, float cos_hb) {
    float cos_hs = sqrt(max(1.0 - 0.25 * x.x * x.x, 0.0));
    float sin_s = x.x * cos_hs;
    float den = max(cos_hb + cos_hs, 1e-30);
    float sin_hd = 0.5 * x.y * (cos_hb + rho_b * (2.0 * rho_b + x.y) / (4.0 * den));
    float q = 2.0 * sin_hd * sin_hd;
    return x.x * sl_exp_i0e(-lambda * q, lambda * rho_b * cos_hb * sin_s);
}

float sl_cap_panel(vec2 lo, vec2 hi, float lambda, float rho_b, float cos_hb) {
    float h = 0.5 * sl_width(lo, hi);
    vec2 mid = lo + h;
    float s = 0.0;
    for (int i = 0; i < 5; ++i) {
        s += SL_GL_W[i] * sl_cap_radial(mid + h * SL_GL_X[i], lambda, rho_b, cos_hb);
    }
    return h * s;
}

// Two panels on [lo, hi] split at the peak, kept 30% of the width from either end.
float sl_cap_two_panels(vec2 lo, vec2 hi, vec2 peak, float lambda, float rho_b, float cos_hb) {
    float w = sl_width(lo, hi);
    if (w <= 0.0) {
        return 0.0;
    }
    vec2 m = peak.y < lo.y + 0.3 * w ? lo + 0.3 * w : (peak.y > hi.y - 0.3 * w ? hi - 0.3 * w : peak);
    return sl_cap_panel(lo, m, lambda, rho_b, cos_hb) + sl_cap_panel(m, hi, lambda, rho_b, cos_hb);
}

// (1 − e^{−x})/x for x ≥ 0: f32 has no expm1, and 1 − exp(−x) loses 12 ulp of exp / x relative, so
// below 0.5 the series Σ (−x)^k/(k+1)! to k = 9 (truncation < 2e-10).
float sl_one_minus_exp_over_x(float x) {
    if (x < 0.5) {
        return 1.0 - x / 2.0 * (1.0 - x / 3.0 * (1.0 - x / 4.0 * (1.0 - x / 5.0 * (1.0 - x / 6.0
             * (1.0 - x / 7.0 * (1.0 - x / 8.0 * (1.0 - x / 9.0 * (1.0 - x / 10.0))))))));
    }
    return (1.0 - exp(-x)) / x;
}

// Root of λ(slope d + d²/2) = SL_WINDOW, at most 4.
float sl_window_reach(float lambda, float slope) {
    float ls = lambda * slope;
    float den = ls + sqrt(ls * ls + 2.0 * SL_WINDOW * lambda);
    return 2.0 * SL_WINDOW / max(den, 0.5 * SL_WINDOW);
}

// ∫_cap e^{λ(a·ω − 1)} dω (multiply by the lobe's μ and the light's radiance). Exact on axis,
// else the 10-node rule of sphere_light.rs (measured within 3.4e-4 relative, λ ∈ [1e-3, 1e5]).
// Twin of cap_sg_integral.
float cap_sg_integral(vec3 sg_axis, float lambda_in, vec3 cap_axis, float sin_alpha, float cos_alpha) {
    float lambda = max(lambda_in, 0.0);
    float sa = clamp(sin_alpha, 0.0, 1.0);
    float ca = clamp(cos_alpha, 0.0, 1.0);
    float one_minus_ca = sa * sa / (1.0 + ca);
    float solid_angle = 2.0 * SL_PI * one_minus_ca;
    float full = sg_integral(lambda, 1.0);
    float rho_b = length(sg_axis - cap_axis);
    if (rho_b == 0.0) {
        return solid_angle * sl_one_minus_exp_over_x(lambda * one_minus_ca);
    }
    float cos_hb = sqrt(max(1.0 - 0.25 * rho_b * rho_b, 0.0));
    float sb = rho_b * cos_hb;
    float cb = 1.0 - 0.5 * rho_b * rho_b;
    float r_cap = sqrt(2.0 * one_minus_ca);
    float edge = r_cap - rho_b;
    float cos_half_alpha = sqrt(0.5 * (1.0 + ca));
    // Direct → complement as the axis goes 0.25 → 1.25 lobe widths inside the cap and λ 10 → 20.
    float t = clamp(edge * sqrt(lambda) - 0.25, 0.0, 1.0) * clamp(lambda / 10.0 - 1.0, 0.0, 1.0);
    vec2 at_edge = vec2(r_cap, edge);
    float result = 0.0;
    if (t < 1.0) {
        vec2 peak = edge < 0.0 ? at_edge : vec2(rho_b, 0.0);
        float slope = edge < 0.0 ? max(sb * ca - cb * sa, 0.0) / cos_half_alpha : 0.0;
        float reach = sl_window_reach(lambda, slope);
        vec2 lo = peak.y - reach > -rho_b ? peak - reach : vec2(0.0, -rho_b);
        vec2 hi = peak.y + reach < edge ? peak + reach : at_edge;
        result += (1.0 - t) * 2.0 * SL_PI * sl_cap_two_panels(lo, hi, peak, lambda, rho_b, cos_hb);
    }
    if (t > 0.0) {
        float reach = sl_window_reach(lambda, max(sa * cb - ca * sb, 0.0) / cos_half_alpha);
        vec2 hi = edge + reach < 2.0 - rho_b ? at_edge + reach : vec2(2.0, 2.0 - rho_b);
        result += t * (full - 2.0 * SL_PI * sl_cap_two_panels(at_edge, hi, at_edge, lambda, rho_b, cos_hb));
    }
    return clamp(result, 0.0, min(solid_angle, full));
}

// Twin of sphere_light_clamped_cosine: π inside the light (seen in every direction).
float sphere_light_clamped_cosine(vec3 p, vec3 n, vec3 center, float radius) {
    vec3 axis;
    float sa, ca;
    if (!cap_from_sphere(p, center, radius, axis, sa, ca)) {
        return SL_PI;
    }
    return cap_clamped_cosine(dot(n, axis), sa, ca);
}

// Twin of sphere_light_sg_integral: the whole-sphere integral inside the light.
float sphere_light_sg_integral(vec3 p, vec3 center, float radius, vec3 sg_axis, float lambda) {
    vec3 axis;
    float sa, ca;
    if (!cap_from_sphere(p, center, radius, axis, sa, ca)) {
        return sg_integral(max(lambda, 0.0), 1.0);
    }
    return cap_sg_integral(sg_axis, lambda, axis, sa, ca);
}

#endif
