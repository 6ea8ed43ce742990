// Cosine lobes c(v) = s * max(a.v, 0)^e (Meunier et al. 2009, Eq. 4): f32 twins of the
// GPU-relevant parts of engine/math/src/lobes/ (lobes::X). Functions and constants only: tables are not
// bound here; the lookup helpers return fractional table coordinates and take fetched values in.
//
// Table layouts (see engine/math/src/lobes/ for the generators):
//   product    [(i_e1 * 97 + i_e2) * 49 + i_alpha] -> (ln_pr_rel, e_r), exponents 16/decade, alpha 49 over [0, pi]
//   hemisphere [i_e * 129 + i_y] -> (f_h, f_b), exponents 128/decade, y 129 over [-1, 1]
//   cap        [i] -> k = e_cap * alpha^2, 1000 entries over alpha in [0, pi/2]
#ifndef LOBES_GLSL
#define LOBES_GLSL

const float LOBES_PI = 3.14159265358979;
const float LOBES_HALF_PI = 1.57079632679490;
const float LOBES_MAX_EXPONENT = 1.0e5;
// Stand-in for -infinity (GLSL has no literal for it): exp() of it is exactly 0.
const float LOBES_NEG_INF = -3.0e38;
const float LOBES_CAP_MIN_ALPHA = 1.0e-4;

// log(1 + x) without losing x when |x| << 1. For |x| < 0.5 by arithmetic only: 2 atanh(z),
// z = x/(2 + x), |z| <= 1/3, odd series to z^17 (truncation < 2e-9 relative). GLSL log near 1 is
// accurate only absolutely (Vulkan allows 2^-21; lavapipe's errs by ~7e-8), so the classic
// log(u) * x/(u - 1) lost up to 16 % of log1p(-4e-7) on lavapipe, 0.7 % of a lobe value at e = 1e5
// (found by tests/tests/math_gpu_lobes.rs). Below -0.5, 1 + x is exact and log is 3 ulp relative.
float lobes_log1p(float x) {
    if (abs(x) < 0.5) {
        float z = x / (2.0 + x);
        float z2 = z * z;
        float p = 1.0 / 17.0;
        p = p * z2 + 1.0 / 15.0;
        p = p * z2 + 1.0 / 13.0;
        p = p * z2 + 1.0 / 11.0;
        p = p * z2 + 1.0 / 9.0;
        p = p * z2 + 1.0 / 7.0;
        p = p * z2 + 1.0 / 5.0;
        p = p * z2 + 1.0 / 3.0;
        return 2.0 * z + 2.0 * z * z2 * p;
    }
    return log(1.0 + x);
}

// ln cos x for |x| < pi/2, accurate near 0: log1p(-2 sin^2(x/2)).
float lobes_ln_cos(float x) {
    float h = sin(0.5 * x);
    return lobes_log1p(max(-2.0 * h * h, -1.0));
}

// pi/2 - float(pi/2): with it, pi/2 - x = (LOBES_HALF_PI - x) + LOBES_HALF_PI_LO keeps its digits
// for x near pi/2 (the first difference is exact).
const float LOBES_HALF_PI_LO = -4.37113883e-8;
// ln cos x for x in [0, pi/2], accurate near both ends: near pi/2, ln sin(pi/2 - x) (1 - 2 sin^2
// cancels there). pi/2 - x is floored at 6e-8, the resolution of an f32 angle near pi/2: an angle
// rounded onto or past pi/2 gives a large negative value, not -inf (see lobe_product_log_peak).
float lobes_ln_cos_to_half_pi(float x) {
    if (x < 0.785398) {
        return lobes_ln_cos(x);
    }
    float m = max((LOBES_HALF_PI - x) + LOBES_HALF_PI_LO, 6.0e-8);
    return log(sin(m));
}

// Angle between unit vectors via atan2 (accurate near 0 and pi).
float lobe_angle_between(vec3 a, vec3 b) {
    return atan(length(cross(a, b)), dot(a, b));
}

// ln max(a.v, 0)^e (twin of lobes::lobe_log_eval): LOBES_NEG_INF outside the hemisphere, 0 inside
// for e = 0. For unit a, v: 1 - a.v = |a - v|^2 / 2, which keeps the digits that a.v rounds away
// near the axis, where large exponents need them.
float lobe_log_eval(vec3 axis, float e, vec3 v) {
    float d = dot(axis, v);
    if (d <= 0.0) {
        return LOBES_NEG_INF;
    }
    if (e == 0.0) {
        return 0.0;
    }
    vec3 w = axis - v;
    float m = 0.5 * dot(w, w);
    float ln_d = (m < 0.5) ? lobes_log1p(-m) : log(d);
    return e * ln_d;
}

// s * max(a.v, 0)^e evaluated as s * exp(e ln(a.v)) (twin of lobes::lobe_eval).
float lobe_eval(vec3 axis, float s, float e, vec3 v) {
    float l = lobe_log_eval(axis, e, v);
    return (l <= LOBES_NEG_INF) ? 0.0 : s * exp(l);
}

// s * 2 pi / (e + 1) (paper Eq. 20-21; twin of lobes::sphere_integral times s).
float lobe_sphere_integral(float s, float e) {
    return s * 2.0 * LOBES_PI / (e + 1.0);
}

// Axis angle t of the product lobe from a1 towards a2: e1 tan t = e2 tan(alpha - t), solved as
// t = (alpha + asin((e2 - e1)/(e1 + e2) sin alpha)) / 2 (twin of lobes::product_axis_angle).
// asin(x) is written atan2(x, sqrt((1 - x)(1 + x))): GLSL asin is loose (lavapipe errs by up to
// 3.9e-4, the spec allows more), atan2 by 3.4e-6 (measured by tests/tests/math_gpu_sg.rs).
float lobe_product_axis_angle(float e1, float e2, float alpha) {
    float sum = e1 + e2;
    float r = (sum > 0.0) ? (e2 - e1) / sum : 0.0;
    float x = clamp(r * sin(alpha), -1.0, 1.0);
    return 0.5 * (alpha + atan(x, sqrt((1.0 - x) * (1.0 + x))));
}

// ln(c1(a_r) c2(a_r)) for unit scales (twin of lobes::product_log_peak); _at takes the axis angle t of
// lobe_product_axis_angle(e1, e2, alpha), which lobes_mul computes once for the axis and the peak.
// For alpha < pi, t and alpha - t lie in [0, pi/2) exactly, but in f32 (and through the GPU's atan2,
// 3.4e-6 on lavapipe) they can round onto or past pi/2 when one exponent is below ~1e-5 of the
// other; testing cos > 0 then returned -inf (a zero product) where the broad lobe is still ~1 at
// its horizon and the product is not small (found by tests/tests/math_gpu_lobes.rs: e1 = 2e-4,
// e2 = 2.3e4, alpha = 1.58 gave -inf for -0.91). lobes_ln_cos_to_half_pi floors the distance to pi/2
// at the f32 resolution instead.
float lobe_product_log_peak_at(float e1, float e2, float alpha, float t) {
    if (alpha >= LOBES_PI) {
        return LOBES_NEG_INF;
    }
    float l = 0.0;
    if (e1 != 0.0) {
        l += e1 * lobes_ln_cos_to_half_pi(abs(t));
    }
    if (e2 != 0.0) {
        l += e2 * lobes_ln_cos_to_half_pi(abs(alpha - t));
    }
    return max(l, LOBES_NEG_INF);
}
float lobe_product_log_peak(float e1, float e2, float alpha) {
    return lobe_product_log_peak_at(e1, e2, alpha, lobe_product_axis_angle(e1, e2, alpha));
}

// Any unit vector orthogonal to the unit vector a.
vec3 lobes_any_orthogonal(vec3 a) {
    vec3 h = (abs(a.x) < 0.9) ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0);
    return normalize(cross(a, h));
}

// Product lobe axis: a1 rotated by t towards a2 (twin of lobes::product_axis); _at takes t.
vec3 lobe_product_axis_at(vec3 a1, vec3 a2, float t) {
    vec3 perp = a2 - a1 * dot(a1, a2);
    float lp = length(perp);
    vec3 b = (lp > 1.0e-6) ? perp / lp : lobes_any_orthogonal(a1);
    return normalize(a1 * cos(t) + b * sin(t));
}
vec3 lobe_product_axis(vec3 a1, float e1, vec3 a2, float e2) {
    return lobe_product_axis_at(a1, a2, lobe_product_axis_angle(e1, e2, lobe_angle_between(a1, a2)));
}

// p_r from the closed-form peak (at the axis angle t) and the table's ln_pr_rel (twin of ProductFit::p_r).
float lobe_product_scale_at(float e1, float e2, float alpha, float t, float ln_pr_rel) {
    float lp = lobe_product_log_peak_at(e1, e2, alpha, t);
    return (lp <= LOBES_NEG_INF) ? 0.0 : exp(lp + ln_pr_rel);
}

// Fractional index of e on a table axis with per_decade samples per decade (twin of
// lobes::exponent_coord): [0,1), [1,10), ..., [1e4,1e5) then 1e5 at 6*per_decade. Decade bounds
// are exact constants (no pow, whose GPU rounding could misplace e = 10^k).
float lobe_exponent_coord(float e, float per_decade) {
    float last = 6.0 * per_decade;
    if (!(e > 0.0)) {
        return 0.0;
    }
    if (e < 1.0) {
        return e * per_decade;
    }
    if (e >= LOBES_MAX_EXPONENT) {
        return last;
    }
    float lo = 1.0;
    float d = 0.0;
    if (e >= 1.0e4) {
        lo = 1.0e4;
        d = 4.0;
    } else if (e >= 1.0e3) {
        lo = 1.0e3;
        d = 3.0;
    } else if (e >= 100.0) {
        lo = 100.0;
        d = 2.0;
    } else if (e >= 10.0) {
        lo = 10.0;
        d = 1.0;
    }
    return min(per_decade * (d + 1.0) + per_decade * (e - lo) / (9.0 * lo), last);
}

// Hemisphere table column y = (2/pi) atan2(sqrt(e+1) cos(beta), sin(beta)) in [-1, 1]
// (twin of lobes::hemisphere_coord_y); the fractional index is (y + 1)/2 * (n_y - 1).
float lobe_hemisphere_coord_y(float e, float cos_beta) {
    float c = clamp(cos_beta, -1.0, 1.0);
    float s = sqrt(max((1.0 - c) * (1.0 + c), 0.0));
    return (2.0 / LOBES_PI) * atan(sqrt(e + 1.0) * c, s);
}

// Integrals from the hemisphere table's fetched fractions.
float lobe_hemisphere_from_fraction(float e, float f_h) {
    return f_h * 2.0 * LOBES_PI / (e + 1.0);
}
float lobe_clamped_cosine_from_fraction(float e, float cos_beta, float f_b) {
    return (clamp(cos_beta, 0.0, 1.0) + f_b) * 2.0 * LOBES_PI / (e + 2.0);
}

// Fractional index of alpha in a product table with n alpha samples over [0, pi].
float lobe_alpha_coord(float alpha, float n) {
    return clamp(alpha / LOBES_PI, 0.0, 1.0) * (n - 1.0);
}

// Fractional index of alpha_cap in a cap table of n entries over [0, pi/2] (twin of lobes::cap_coord).
float lobe_cap_coord(float alpha, float n) {
    return clamp(alpha / LOBES_HALF_PI, 0.0, 1.0) * (n - 1.0);
}

// e_cap from the interpolated k = e alpha^2 (twin of lobes::cap_exponent_from_k).
float lobe_cap_exponent(float k, float alpha) {
    if (alpha >= LOBES_HALF_PI) {
        return 0.0;
    }
    float a = max(alpha, LOBES_CAP_MIN_ALPHA);
    return k / (a * a);
}

// Half-angle of the cone a sphere subtends from x; pi/2 inside it (twin of lobes::sphere_cap_angle).
// asin(r/d) as atan2(r, sqrt((d - r)(d + r))): accurate GPU atan2 instead of loose asin (see
// lobe_product_axis_angle), and no cancellation in 1 - (r/d)^2 as r/d -> 1.
float lobe_sphere_cap_angle(vec3 center, float radius, vec3 x) {
    float d = length(center - x);
    return (d <= radius) ? LOBES_HALF_PI : atan(radius, sqrt((d - radius) * (d + radius)));
}

// Lafortune lobe (C, rho, e) for outgoing direction v_o as a cosine lobe (paper Eq. 30; twin of
// lobes::lafortune_lobe): returns (axis, scale) with scale = rho |w|^e = rho exp(e ln|w|),
// w = C * (v_o in the frame t, b, n). A zero w returns (n, 0).
vec4 lobe_lafortune(vec3 c, float rho, float e, vec3 t, vec3 b, vec3 n, vec3 v_o) {
    vec3 u = vec3(dot(v_o, t), dot(v_o, b), dot(v_o, n));
    vec3 wl = c * u;
    vec3 w = t * wl.x + b * wl.y + n * wl.z;
    float lw = length(w);
    if (lw == 0.0) {
        return vec4(n, 0.0);
    }
    float scale = (e == 0.0) ? rho : rho * exp(e * log(lw));
    return vec4(w / lw, scale);
}

#endif
