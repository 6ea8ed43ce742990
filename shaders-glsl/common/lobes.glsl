// Cosine lobes c(v) = s * max(a.v, 0)^e (Meunier et al. 2009, Eq. 4): f32 twins of the
// GPU-relevant parts of engine/math/src/lobes.rs. Functions and constants only: tables are not
// bound here; the lookup helpers return fractional table coordinates and take fetched values in.
//
// Table layouts (see lobes.rs for the generators):
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

// log(1 + x) without losing x when |x| << 1 (Goldberg: the rounding of 1 + x cancels in the
// ratio). 'precise' keeps the compiler from folding (u - 1) back into x.
float lobes_log1p(float x) {
    precise float u = 1.0 + x;
    precise float d = u - 1.0;
    if (d == 0.0) {
        return x;
    }
    return log(u) * (x / d);
}

// ln cos x for |x| < pi/2, accurate near 0: log1p(-2 sin^2(x/2)).
float lobes_ln_cos(float x) {
    float h = sin(0.5 * x);
    return lobes_log1p(max(-2.0 * h * h, -1.0));
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
float lobe_product_axis_angle(float e1, float e2, float alpha) {
    float sum = e1 + e2;
    float r = (sum > 0.0) ? (e2 - e1) / sum : 0.0;
    return 0.5 * (alpha + asin(clamp(r * sin(alpha), -1.0, 1.0)));
}

// ln(c1(a_r) c2(a_r)) for unit scales (twin of lobes::product_log_peak).
float lobe_product_log_peak(float e1, float e2, float alpha) {
    if (alpha >= LOBES_PI) {
        return LOBES_NEG_INF;
    }
    float t = lobe_product_axis_angle(e1, e2, alpha);
    float l = 0.0;
    if (e1 != 0.0) {
        l += (cos(t) > 0.0) ? e1 * lobes_ln_cos(t) : LOBES_NEG_INF;
    }
    if (e2 != 0.0) {
        l += (cos(alpha - t) > 0.0) ? e2 * lobes_ln_cos(alpha - t) : LOBES_NEG_INF;
    }
    return max(l, LOBES_NEG_INF);
}

// Any unit vector orthogonal to the unit vector a.
vec3 lobes_any_orthogonal(vec3 a) {
    vec3 h = (abs(a.x) < 0.9) ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0);
    return normalize(cross(a, h));
}

// Product lobe axis: a1 rotated by t towards a2 (twin of lobes::product_axis).
vec3 lobe_product_axis(vec3 a1, float e1, vec3 a2, float e2) {
    float alpha = lobe_angle_between(a1, a2);
    float t = lobe_product_axis_angle(e1, e2, alpha);
    vec3 perp = a2 - a1 * dot(a1, a2);
    float lp = length(perp);
    vec3 b = (lp > 1.0e-6) ? perp / lp : lobes_any_orthogonal(a1);
    return normalize(a1 * cos(t) + b * sin(t));
}

// p_r from the closed-form peak and the table's ln_pr_rel (twin of ProductFit::p_r).
float lobe_product_scale(float e1, float e2, float alpha, float ln_pr_rel) {
    float lp = lobe_product_log_peak(e1, e2, alpha);
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
float lobe_sphere_cap_angle(vec3 center, float radius, vec3 x) {
    float d = length(center - x);
    return (d <= radius) ? LOBES_HALF_PI : asin(radius / d);
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
