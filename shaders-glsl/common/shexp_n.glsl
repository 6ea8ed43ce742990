// SH exponentiation and circle log-visibility at a compile-time order SHEXP_N (3..8), tables read
// from device buffers (assets/tables sh{n}_gamma, sh{n}_ol, sh{n}_circle_log): the f32 twin of
// engine/math/src/shexp.rs (exp_ol, exp_hyb, exp_ps_star) and sh/log.rs (CircleLogTable::lookup_u),
// checked per receiver by tests/tests/shexp.rs against engine::passes::shade::shexp::cpu.
//
// Requires, before inclusion: sh.glsl, SHEXP_N, and the table accessors
//   SHN_GAMMA(e)        uvec2 (i | j << 8 | k << 16, floatBits(value)) of tensor entry e (j ≤ k, value
//                       halved on j == k), SHN_GAMMA_COUNT entries;
//   SHN_OL(k)           vec2 (a, b) at ‖f̂‖ = k/(SHN_OL_COUNT − 1) · SHN_OL_NORM_MAX;
//   SHN_CIRCLE(e, c)    float component c of circle-table entry e (c < n: f*_c/u, c = n: u),
//                       SHN_CIRCLE_SEGMENTS × SHN_CIRCLE_SAMPLES entries, segment-major.
#ifndef SHEXP_N_GLSL
#define SHEXP_N_GLSL

#define SHN_C (SHEXP_N * SHEXP_N)
// Squarings are capped: 2^16 scaling covers ‖f̂‖ ≤ 16384 · target; past that the receiver is
// deeply occluded and the result is sanitized below anyway. Bounds every loop (llvmpipe's limit).
#define SHN_MAX_SQUARINGS 16

const float SHN_SQRT_4PI = 3.5449077018;

// (a * b)_i = Σ Γ_ijk a_j b_k (SHEXP Eq. 3); sh/tensor.rs `ShTensor::product_into`. Orders 3..6 use the
// generated straight-line code (sh_product_gen.glsl, engine_math::sh::glsl_products); the others this
// loop over the tensor's table.
#include "sh_product_gen.glsl"
#ifndef SHN_PRODUCT_GENERATED
void shn_product(float a[SHN_C], float b[SHN_C], out float c[SHN_C]) {
    for (int i = 0; i < SHN_C; ++i) c[i] = 0.0;
    for (uint e = 0u; e < uint(SHN_GAMMA_COUNT); ++e) {
        uvec2 w = SHN_GAMMA(e);
        int i = int(w.x & 255u);
        int j = int((w.x >> 8) & 255u);
        int k = int(w.x >> 16);
        c[i] += uintBitsToFloat(w.y) * (a[j] * b[k] + a[k] * b[j]);
    }
}
#endif

float shn_norm_hat(float f[SHN_C]) {
    float s = 0.0;
    for (int i = 1; i < SHN_C; ++i) s += f[i] * f[i];
    return sqrt(s);
}

// OL (a, b) by linear interpolation in the uniform table, clamped at its end (shexp.rs OlTable::lookup).
vec2 shn_ol_ab(float nrm) {
    float x = clamp(nrm / SHN_OL_NORM_MAX, 0.0, 1.0) * float(SHN_OL_COUNT - 1);
    int k = min(int(floor(x)), SHN_OL_COUNT - 2);
    float w = x - float(k);
    return mix(SHN_OL(k), SHN_OL(k + 1), w);
}

// OL (SHEXP Eq. 23): exp(f_0/√(4π)) (a(‖f̂‖) 1 + b(‖f̂‖) f̂).
void shn_exp_ol(float f[SHN_C], out float g[SHN_C]) {
    vec2 ab = shn_ol_ab(shn_norm_hat(f));
    float dc = exp(f[0] / SHN_SQRT_4PI);
    g[0] = dc * ab.x * SHN_SQRT_4PI;
    for (int i = 1; i < SHN_C; ++i) g[i] = dc * ab.y * f[i];
}

void shn_square_repeatedly(inout float g[SHN_C], int s) {
    for (int q = 0; q < s; ++q) {
        float t[SHN_C];
        shn_product(g, g, t);
        g = t;
    }
}

// HYB (Sec. 4.3): scale f̂ to norm ≤ target, OL, square s times, times the DC factor.
void shn_exp_hyb(float f[SHN_C], float target, out float g[SHN_C]) {
    float nrm = shn_norm_hat(f);
    int s = nrm > target ? min(int(ceil(log2(nrm / target))), SHN_MAX_SQUARINGS) : 0;
    float scale = exp2(-float(s));
    float x[SHN_C];
    x[0] = 0.0;
    for (int i = 1; i < SHN_C; ++i) x[i] = f[i] * scale;
    shn_exp_ol(x, g);
    shn_square_repeatedly(g, s);
    float dc = exp(f[0] / SHN_SQRT_4PI);
    for (int i = 0; i < SHN_C; ++i) g[i] *= dc;
}

// PS*-p (Sec. 4.1–4.3): DC isolation, scaling by 2^-s with s = max(0, ⌊log2 ‖f̂‖⌋ + 3), the even/odd
// factored series of degree p (Eq. 22), s squarings.
void shn_exp_ps_star(float f[SHN_C], int p, out float g[SHN_C]) {
    float nrm = shn_norm_hat(f);
    int s = nrm > 0.0 ? clamp(int(floor(log2(nrm))) + 3, 0, SHN_MAX_SQUARINGS) : 0;
    float scale = exp2(-float(s));
    float x[SHN_C];
    x[0] = 0.0;
    for (int i = 1; i < SHN_C; ++i) x[i] = f[i] * scale;
    float even[SHN_C];
    float odd_rest[SHN_C];
    float x2[SHN_C];
    for (int i = 0; i < SHN_C; ++i) {
        even[i] = 0.0;
        odd_rest[i] = 0.0;
        x2[i] = 0.0;
    }
    even[0] = SHN_SQRT_4PI;
    if (p >= 1) {
        if (p >= 2) shn_product(x, x, x2);
        float pw[SHN_C] = x2;
        float fact = 1.0;
        for (int k = 2; k <= min(p, 12); ++k) {
            fact *= float(k);
            if ((k & 1) == 0) {
                if (k == 4) {
                    shn_product(x2, x2, pw);
                } else if (k > 4) {
                    float t[SHN_C];
                    shn_product(pw, x2, t);
                    pw = t;
                }
                for (int i = 0; i < SHN_C; ++i) even[i] += pw[i] / fact;
            } else {
                for (int i = 0; i < SHN_C; ++i) odd_rest[i] += pw[i] / fact;
            }
        }
        for (int i = 0; i < SHN_C; ++i) even[i] += x[i];
        if (p >= 3) {
            float xo[SHN_C];
            shn_product(x, odd_rest, xo);
            for (int i = 0; i < SHN_C; ++i) even[i] += xo[i];
        }
    }
    g = even;
    shn_square_repeatedly(g, s);
    float dc = exp(f[0] / SHN_SQRT_4PI);
    for (int i = 0; i < SHN_C; ++i) g[i] *= dc;
}

// The basis of order SHEXP_N at direction d (normalized here; a zero vector gives +z): sh_eval's
// recurrence (sh/basis.rs `eval_basis`) in an array of SHN_C. sh_eval sizes its array for order 8 and
// zeroes all 64 entries per call, which llvmpipe keeps in private memory; this runs once per blocker per
// receiver, the hot path of the technique, with every bound a compile-time constant (loops unroll and the
// recurrence's square roots fold).
void shn_eval(vec3 d, out float y[SHN_C]) {
    float len = length(d);
    vec3 u = len > 0.0 ? d / len : vec3(0.0, 0.0, 1.0);
    float qmm = 1.0 / SHN_SQRT_4PI;
    float cm = 1.0;
    float sm = 0.0;
    for (int m = 0; m < SHEXP_N; ++m) {
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
        for (int l = m; l < SHEXP_N; ++l) {
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

// Scaled circle log f*_l at u = 1 − cos θ ∈ [0, 1] (sh/log.rs CircleLogTable::lookup_u): the segment
// holding u, then u × the linear interpolation of the stored ratio f*_l/u.
void shn_circle_fstar(float u, out float fstar[SH_MAX_ORDER]) {
    for (int l = 0; l < SH_MAX_ORDER; ++l) fstar[l] = 0.0;
    u = clamp(u, 0.0, 1.0);
    int seg = 0;
    for (int k = 1; k < SHN_CIRCLE_SEGMENTS; ++k) {
        if (u >= SHN_CIRCLE(k * SHN_CIRCLE_SAMPLES, SHEXP_N)) seg = k;
    }
    int base = seg * SHN_CIRCLE_SAMPLES;
    float u0 = SHN_CIRCLE(base, SHEXP_N);
    float u1 = SHN_CIRCLE(base + SHN_CIRCLE_SAMPLES - 1, SHEXP_N);
    float x = clamp((u - u0) / (u1 - u0), 0.0, 1.0) * float(SHN_CIRCLE_SAMPLES - 1);
    int i0 = min(int(floor(x)), SHN_CIRCLE_SAMPLES - 2);
    float w = x - float(i0);
    for (int l = 0; l < SHEXP_N; ++l) {
        fstar[l] = u * mix(SHN_CIRCLE(base + i0, l), SHN_CIRCLE(base + i0 + 1, l), w);
    }
}

// Add the log-visibility of a circle (u = 1 − cos θ) about unit `axis` to f (SHEXP Eq. 34), scaled per band by
// a ratio vector W (SHEXP Eq. 38: f = W F(θ) y(s)), w_l = w[l].
void shn_add_circle_log_weighted(inout float f[SHN_C], float u, vec3 axis, float w[8]) {
    float fstar[SH_MAX_ORDER];
    shn_circle_fstar(u, fstar);
    float y[SHN_C];
    shn_eval(axis, y);
    for (int l = 0; l < SHEXP_N; ++l) {
        float a = w[l] * fstar[l];
        for (int i = l * l; i < (l + 1) * (l + 1); ++i) f[i] += a * y[i];
    }
}

// The same unscaled (W = 1).
void shn_add_circle_log(inout float f[SHN_C], float u, vec3 axis) {
    shn_add_circle_log_weighted(f, u, axis, float[8](1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0));
}

// u = 1 − cos θ of a sphere blocker b seen from p (sin θ = r/d), without cancellation; 1 (the
// half-space) when p is on or inside it, 0 for a zero radius.
float shn_sphere_u(vec3 p, vec4 b) {
    float d = distance(p, b.xyz);
    if (!(b.w > 0.0)) return 0.0;
    if (d <= b.w) return 1.0;
    float s = b.w / d;
    return s * s / (1.0 + sqrt(max(1.0 - s * s, 0.0)));
}

#endif // SHEXP_N_GLSL
