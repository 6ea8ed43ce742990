// Real spherical harmonics, f32 twin of engine/math/src/sh/ (evaluation, zonal rotation, dot).
//
// Conventions (as engine/math/src/sh/): order n = bands 0..n-1, n² coefficients, index l² + l + m; polar axis +z;
// no Condon–Shortley phase (y_1,-1 = K y, y_10 = K z, y_11 = K x); the constant 1 is (√(4π), 0, ...).
// Orders 1..SH_MAX_ORDER (8); arrays are sized for the maximum and entries ≥ n² are set to 0.
#ifndef SH_GLSL
#define SH_GLSL

#define SH_MAX_ORDER 8
#define SH_MAX_COEFFS 64

const float SH_SQRT_4PI = 3.5449077018;

// Basis of order n at direction d (normalized here; a zero vector gives +z).
// Normalized associated-Legendre recurrences on Q_l^m = K_lm P_l^m(z) / sin^m θ with
// C_m + i S_m = (x + i y)^m: no factorials, no trigonometry (sh/basis.rs `eval_basis`).
void sh_eval(vec3 d, int n, out float y[SH_MAX_COEFFS]) {
    for (int i = 0; i < SH_MAX_COEFFS; ++i) {
        y[i] = 0.0;
    }
    float len = length(d);
    vec3 u = len > 0.0 ? d / len : vec3(0.0, 0.0, 1.0);
    float qmm = 1.0 / SH_SQRT_4PI;
    float cm = 1.0;
    float sm = 0.0;
    for (int m = 0; m < n; ++m) {
        if (m > 0) {
            qmm *= sqrt(float(2 * m + 1) / float(2 * m));
            float c = cm * u.x - sm * u.y;
            float s = cm * u.y + sm * u.x;
            cm = c;
            sm = s;
        }
        float fm = float(m);
        float q_lm2 = 0.0;
        float q_lm1 = qmm;
        for (int l = m; l < n; ++l) {
            float q;
            if (l == m) {
                q = qmm;
            } else if (l == m + 1) {
                q = u.z * sqrt(2.0 * fm + 3.0) * qmm;
            } else {
                float fl = float(l);
                float a = sqrt((4.0 * fl * fl - 1.0) / (fl * fl - fm * fm));
                float b = sqrt(((fl - 1.0) * (fl - 1.0) - fm * fm) / (4.0 * (fl - 1.0) * (fl - 1.0) - 1.0));
                q = a * (u.z * q_lm1 - b * q_lm2);
            }
            if (l > m) {
                q_lm2 = q_lm1;
                q_lm1 = q;
            }
            int base = l * l + l;
            if (m == 0) {
                y[base] = q;
            } else {
                y[base + m] = 1.41421356 * q * cm;
                y[base - m] = 1.41421356 * q * sm;
            }
        }
    }
}

// Rotate a zonal function with scaled coefficients f*_l = f_l √(4π/(2l+1)) from +z to `axis`:
// f_lm = f*_l y_lm(axis) (SHEXP Eq. 34; sh/zonal.rs `zh_rotate_star_into`).
void sh_zh_rotate(float fstar[SH_MAX_ORDER], vec3 axis, int n, out float f[SH_MAX_COEFFS]) {
    sh_eval(axis, n, f);
    for (int l = 0; l < n; ++l) {
        for (int i = l * l; i < (l + 1) * (l + 1); ++i) {
            f[i] *= fstar[l];
        }
    }
}

// ∫ f̃ g̃ over the sphere for order-n vectors (sh/basis.rs `dot`).
float sh_dot(float a[SH_MAX_COEFFS], float b[SH_MAX_COEFFS], int n) {
    float s = 0.0;
    for (int i = 0; i < n * n; ++i) {
        s += a[i] * b[i];
    }
    return s;
}

// Order-4 conveniences for the SH exponential (shexp.glsl works on float[16]).
void sh4_eval(vec3 d, out float y[16]) {
    float t[SH_MAX_COEFFS];
    sh_eval(d, 4, t);
    for (int i = 0; i < 16; ++i) {
        y[i] = t[i];
    }
}

// f_lm = fstar[l] y_lm(axis) at order 4 (a circle's log from the table, rotated to its axis).
void sh4_zh_rotate(vec4 fstar, vec3 axis, out float f[16]) {
    sh4_eval(axis, f);
    f[0] *= fstar.x;
    for (int i = 1; i < 4; ++i) {
        f[i] *= fstar.y;
    }
    for (int i = 4; i < 9; ++i) {
        f[i] *= fstar.z;
    }
    for (int i = 9; i < 16; ++i) {
        f[i] *= fstar.w;
    }
}

float sh4_dot(float a[16], float b[16]) {
    float s = 0.0;
    for (int i = 0; i < 16; ++i) {
        s += a[i] * b[i];
    }
    return s;
}

#endif
