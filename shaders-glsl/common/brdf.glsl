// Specular BRDF models of the material (Blinn-Phong, Cook-Torrance, Ashikhmin-Shirley, Lafortune): the exact
// f_s, their sampling densities, and the SG lobes per point (ISG Eq. 7–10, Wang et al. 2009).
// Twin: engine::math::brdf (formulas and conventions documented there).
#ifndef BRDF_GLSL
#define BRDF_GLSL
#include "scene.glsl"
#include "frame.glsl"

#define BRDF_BLINN_PHONG 0
#define BRDF_CT_BECKMANN 1
#define BRDF_CT_GGX 2
#define BRDF_ASHIKHMIN_SHIRLEY 3
#define BRDF_LAFORTUNE 4
#define BRDF_MAX_LOBES 7
const float BRDF_MIN_NDV = 1e-3;

int brdf_kind(Material m) {
    return int(m.kind + 0.5);
}

bool brdf_has_specular(Material m) {
    return any(notEqual(m.specular.rgb, vec3(0.0)));
}

// Schlick's Fresnel, F0 = k_s.
vec3 brdf_schlick(vec3 ks, float cos_vh) {
    float x = 1.0 - clamp(cos_vh, 0.0, 1.0);
    float x2 = x * x;
    return ks + (1.0 - ks) * (x2 * x2 * x);
}

// Beckmann or GGX D(cos θ_h) for width α (twin: engine::math::sg::Ndf::eval).
float brdf_ndf(bool ggx, float c, float alpha) {
    if (c <= 0.0) return 0.0;
    float a2 = alpha * alpha;
    float c2 = c * c;
    if (ggx) {
        float d = (a2 - 1.0) * c2 + 1.0;
        return a2 / (PI * d * d);
    }
    return exp((c2 - 1.0) / (c2 * a2)) / (PI * a2 * c2 * c2);
}

// Smith G1 (twin: engine::math::brdf::smith_g1).
float brdf_smith_g1(bool ggx, float alpha, float c) {
    if (c <= 0.0) return 0.0;
    c = min(c, 1.0);
    float s2 = max(1.0 - c * c, 0.0);
    if (ggx) return 2.0 * c / (c + sqrt(c * c + alpha * alpha * s2));
    float s = sqrt(s2);
    if (alpha * s <= 0.0) return 1.0;
    float a = c / (alpha * s);
    return a >= 1.6 ? 1.0 : (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a);
}

// ln(n·h)/s2, s2 = 1 − (n·h)² (twin: ln_cos_over_sin2).
float brdf_ln_cos_over_sin2(float nh, float s2) {
    return s2 < 1e-3 ? -0.5 * (1.0 + s2 * (0.5 + s2 / 3.0)) : log(nh) / s2;
}

// Ashikhmin-Shirley (n·h)^{e(h)}, x = h·t, y = h·b.
float brdf_as_power(float nu, float nv, float x, float y, float nh) {
    if (nh <= 0.0) return 0.0;
    return exp((nu * x * x + nv * y * y) * brdf_ln_cos_over_sin2(nh, x * x + y * y));
}

// The tangent at a point: the material's direction projected on the tangent plane of n
// (twin: tangent_from_direction).
vec3 brdf_tangent(Material m, vec3 n) {
    vec3 d = m.tangent.xyz;
    vec3 p = d - dot(d, n) * n;
    float l2 = dot(p, p);
    if (l2 > 1e-8 * max(dot(d, d), 1e-30)) return p * inversesqrt(l2);
    vec3 t, b;
    orthonormal_basis(n, t, b);
    return t;
}

// max(x, 0)^e as exp(e ln x) (twin: pow_pos).
float brdf_pow_pos(float x, float e) {
    return x > 0.0 ? exp(e * log(x)) : 0.0;
}

#define BRDF_LAFORTUNE_LOBES 3

// Lafortune lobe i (0 .. BRDF_LAFORTUNE_LOBES − 1): (C_x, C_y, C_z, e), and its weight w_i (0: absent).
vec4 brdf_lafortune_ce(Material m, int i) {
    return i == 0 ? m.brdf : m.more[i - 1];
}
float brdf_lafortune_w(Material m, int i) {
    return m.lobes[i];
}

// A Lafortune lobe ce = (C, e) seen from v: axis d = M v/|M v| (M = diag(C) in the frame (t, n × t, n))
// and the peak factor g^e, g = |M v| (0 with d = n where M v = 0). Twin: lafortune_lobe.
vec3 brdf_lafortune_lobe(vec4 ce, vec3 n, vec3 t, vec3 v, out float peak) {
    vec3 b = cross(n, t);
    vec3 mv = ce.x * dot(v, t) * t + ce.y * dot(v, b) * b + ce.z * dot(v, n) * n;
    float g = length(mv);
    if (g <= 1e-12) {
        peak = 0.0;
        return n;
    }
    peak = exp(ce.w * log(g));
    return mv / g;
}

// The Lafortune normalization (e+2)/(2π) (twin: lafortune_norm).
float brdf_lafortune_norm(float e) {
    return (e + 2.0) / (2.0 * PI);
}

// Lafortune lobe i at a point seen from v, when present (w_i > 0): its axis d_i, exponent e_i and the scale
// w_i (e_i+2)/(2π) |M_i v|^e_i of max(d_i·l, 0)^e_i (times k_s: the lobe's f_s).
bool brdf_lafortune_term(Material m, int i, vec3 n, vec3 t, vec3 v, out vec3 axis, out float e, out float scale) {
    float w = brdf_lafortune_w(m, i);
    vec4 ce = brdf_lafortune_ce(m, i);
    float peak;
    axis = brdf_lafortune_lobe(ce, n, t, v, peak);
    e = ce.w;
    scale = w * brdf_lafortune_norm(ce.w) * peak;
    return w > 0.0;
}

// The probabilities of sampling each Lafortune lobe from v, ∝ w_i g_i^e_i (e_i+2)/(e_i+1) (uniform over
// the present lobes where all vanish), and the lobes' axes. Twin: lafortune_pick.
void brdf_lafortune_pick(Material m, vec3 n, vec3 t, vec3 v, out float p[BRDF_LAFORTUNE_LOBES],
                         out vec3 axis[BRDF_LAFORTUNE_LOBES]) {
    float sum = 0.0, present = 0.0;
    for (int i = 0; i < BRDF_LAFORTUNE_LOBES; ++i) {
        float e, scale;
        bool here = brdf_lafortune_term(m, i, n, t, v, axis[i], e, scale);
        // w g^e (e+2)/(e+1) = the term's scale w (e+2)/(2π) g^e times 2π/(e+1).
        p[i] = here ? scale * (2.0 * PI) / (e + 1.0) : 0.0;
        sum += p[i];
        present += here ? 1.0 : 0.0;
    }
    for (int i = 0; i < BRDF_LAFORTUNE_LOBES; ++i) {
        p[i] = sum > 0.0 ? p[i] / sum : (brdf_lafortune_w(m, i) > 0.0 ? 1.0 / present : 0.0);
    }
}

// Exact specular f_s(l, v) without the cosine (twin: specular_brdf).
vec3 brdf_specular(Material m, vec3 n, vec3 t, vec3 v, vec3 l) {
    float nl = dot(n, l);
    float nv = dot(n, v);
    if (nl <= 0.0 || nv <= 0.0 || !brdf_has_specular(m)) return vec3(0.0);
    vec3 hv = l + v;
    float len = length(hv);
    if (len <= 0.0) return vec3(0.0);
    vec3 h = hv / len;
    float nh = max(dot(n, h), 0.0);
    float vh = max(dot(v, h), 0.0);
    vec3 ks = m.specular.rgb;
    int kind = brdf_kind(m);
    if (kind == BRDF_BLINN_PHONG) {
        float s = m.shininess;
        return ks * ((s + 8.0) / (8.0 * PI)) * pow(nh, s);
    }
    if (kind == BRDF_CT_BECKMANN || kind == BRDF_CT_GGX) {
        bool ggx = kind == BRDF_CT_GGX;
        float alpha = m.brdf.x;
        float d = brdf_ndf(ggx, nh, alpha);
        float g = brdf_smith_g1(ggx, alpha, nv) * brdf_smith_g1(ggx, alpha, nl);
        return brdf_schlick(ks, vh) * (d * g / (4.0 * nl * nv));
    }
    if (kind == BRDF_LAFORTUNE) {
        float f = 0.0;
        for (int i = 0; i < BRDF_LAFORTUNE_LOBES; ++i) {
            vec3 d;
            float e, scale;
            if (brdf_lafortune_term(m, i, n, t, v, d, e, scale)) f += scale * brdf_pow_pos(dot(d, l), e);
        }
        return ks * f;
    }
    if (vh <= 0.0) return vec3(0.0);
    vec3 b = cross(n, t);
    float p = brdf_as_power(m.brdf.x, m.brdf.y, dot(h, t), dot(h, b), nh);
    float c = sqrt((m.brdf.x + 1.0) * (m.brdf.y + 1.0)) / (8.0 * PI);
    return brdf_schlick(ks, vh) * (c * p / max(vh * max(nl, nv), 1e-12));
}

// Density over half vectors of the specular sampling (per solid angle of h):
// Blinn-Phong (s+1)/(2π)(n·h)^s; Cook-Torrance D(h)(n·h); Ashikhmin-Shirley √((n_u+1)(n_v+1))/(2π)(n·h)^{e}.
float brdf_half_pdf(Material m, vec3 n, vec3 t, vec3 h) {
    float nh = dot(n, h);
    int kind = brdf_kind(m);
    // Lafortune is sampled over directions (brdf_dir_pdf).
    if (nh <= 0.0 || kind == BRDF_LAFORTUNE) return 0.0;
    if (kind == BRDF_BLINN_PHONG) {
        float s = m.shininess;
        return (s + 1.0) / (2.0 * PI) * pow(nh, s);
    }
    if (kind == BRDF_CT_BECKMANN || kind == BRDF_CT_GGX) return brdf_ndf(kind == BRDF_CT_GGX, nh, m.brdf.x) * nh;
    vec3 b = cross(n, t);
    float nu = m.brdf.x, nv = m.brdf.y;
    return sqrt((nu + 1.0) * (nv + 1.0)) / (2.0 * PI) * brdf_as_power(nu, nv, dot(h, t), dot(h, b), nh);
}

// A half vector distributed by brdf_half_pdf, from two uniforms.
vec3 brdf_sample_half(Material m, vec3 n, vec3 t, float u1, float u2) {
    int kind = brdf_kind(m);
    vec3 b = cross(n, t);
    float cos_h, phi;
    if (kind == BRDF_BLINN_PHONG) {
        cos_h = pow(1.0 - u1, 1.0 / (m.shininess + 1.0));
        phi = 2.0 * PI * u2;
    } else if (kind == BRDF_CT_BECKMANN || kind == BRDF_CT_GGX) {
        float a2 = m.brdf.x * m.brdf.x;
        // tan²θ: Beckmann −α² ln(1 − u), GGX α² u/(1 − u); cos θ = 1/√(1 + tan²θ).
        float tan2 = kind == BRDF_CT_GGX ? a2 * u1 / max(1.0 - u1, 1e-30) : -a2 * log(max(1.0 - u1, 1e-30));
        cos_h = inversesqrt(1.0 + tan2);
        phi = 2.0 * PI * u2;
    } else {
        // Ashikhmin & Shirley 2000, Eq. 9 per quadrant.
        float nu = m.brdf.x, nv = m.brdf.y;
        float q = floor(4.0 * u2);
        float u = 4.0 * u2 - q;
        float p0 = atan(sqrt((nu + 1.0) / (nv + 1.0)) * tan(0.5 * PI * min(u, 0.999999)));
        phi = q == 0.0 ? p0 : (q == 1.0 ? PI - p0 : (q == 2.0 ? PI + p0 : 2.0 * PI - p0));
        float cp = cos(phi), sp = sin(phi);
        cos_h = pow(1.0 - u1, 1.0 / (nu * cp * cp + nv * sp * sp + 1.0));
    }
    float sin_h = sqrt(max(0.0, 1.0 - cos_h * cos_h));
    return normalize(sin_h * cos(phi) * t + sin_h * sin(phi) * b + cos_h * n);
}

// Density over light directions of the specular sampling (twin: dir_pdf): brdf_half_pdf / (4 v·h)
// for the half-vector models; Lafortune the mixture Σ_i p_i (e_i+1)/(2π) max(d_i·l, 0)^e_i about the
// lobes' axes d_i (p_i of brdf_lafortune_pick).
float brdf_dir_pdf(Material m, vec3 n, vec3 t, vec3 v, vec3 l) {
    if (brdf_kind(m) == BRDF_LAFORTUNE) {
        float p[BRDF_LAFORTUNE_LOBES];
        vec3 d[BRDF_LAFORTUNE_LOBES];
        brdf_lafortune_pick(m, n, t, v, p, d);
        float pdf = 0.0;
        for (int i = 0; i < BRDF_LAFORTUNE_LOBES; ++i) {
            float e = brdf_lafortune_ce(m, i).w;
            if (p[i] > 0.0) pdf += p[i] * (e + 1.0) / (2.0 * PI) * brdf_pow_pos(dot(d[i], l), e);
        }
        return pdf;
    }
    vec3 h = v + l;
    float len = length(h);
    if (len <= 0.0) return 0.0;
    h /= len;
    float vh = dot(v, h);
    // Half-vector density / (4 v·h), the reflection's Jacobian.
    if (dot(n, h) <= 0.0 || vh <= 0.0) return 0.0;
    return brdf_half_pdf(m, n, t, h) / (4.0 * vh);
}

// A light direction distributed by brdf_dir_pdf, from two uniforms (may point below the surface).
vec3 brdf_sample_dir(Material m, vec3 n, vec3 t, vec3 v, float u1, float u2) {
    if (brdf_kind(m) == BRDF_LAFORTUNE) {
        // Pick lobe i with probability p_i by u1, then reuse u1 rescaled within its interval.
        float p[BRDF_LAFORTUNE_LOBES];
        vec3 axes[BRDF_LAFORTUNE_LOBES];
        brdf_lafortune_pick(m, n, t, v, p, axes);
        // The last present lobe whose interval starts at or below u1 (lobe 0, w = 1, always is one).
        int i = 0;
        float lo = 0.0, acc = 0.0;
        for (int k = 0; k < BRDF_LAFORTUNE_LOBES; ++k) {
            if (p[k] <= 0.0) continue;
            if (u1 >= acc) {
                i = k;
                lo = acc;
            }
            acc += p[k];
        }
        u1 = p[i] > 0.0 ? clamp((u1 - lo) / p[i], 0.0, 1.0) : u1;
        vec3 d = axes[i];
        float e = brdf_lafortune_ce(m, i).w;
        float c = pow(1.0 - u1, 1.0 / (e + 1.0));
        float s = sqrt(max(0.0, 1.0 - c * c));
        float phi = 2.0 * PI * u2;
        vec3 a, b;
        orthonormal_basis(d, a, b);
        return normalize(s * cos(phi) * a + s * sin(phi) * b + c * d);
    }
    return reflect(-v, brdf_sample_half(m, n, t, u1, u2));
}

// One specular lobe at a point: unit-amplitude SG (axis, λ) and the RGB weight of its integral.
struct SpecLobe {
    vec3 axis;
    float lambda;
    vec3 weight;
};

// The specular lobes at a point (twin: specular_lobes); returns their count (0 where k_s = 0).
int brdf_specular_lobes(Material m, vec3 n, vec3 v, out SpecLobe lobes[BRDF_MAX_LOBES]) {
    if (!brdf_has_specular(m)) return 0;
    vec3 ks = m.specular.rgb;
    float nv = max(dot(n, v), BRDF_MIN_NDV);
    vec3 r = reflect(-v, n);
    int kind = brdf_kind(m);
    if (kind == BRDF_BLINN_PHONG) {
        float s = m.shininess;
        lobes[0].axis = r;
        lobes[0].lambda = s / (4.0 * nv);
        lobes[0].weight = ks * ((s + 8.0) / (8.0 * PI)) * max(dot(n, r), 0.0);
        return 1;
    }
    if (kind == BRDF_CT_BECKMANN || kind == BRDF_CT_GGX) {
        bool ggx = kind == BRDF_CT_GGX;
        r = normalize(r);
        float nl = dot(n, r);
        float alpha = m.brdf.x;
        float g = brdf_smith_g1(ggx, alpha, nv) * brdf_smith_g1(ggx, alpha, nl);
        lobes[0].axis = r;
        lobes[0].lambda = m.brdf.y / (4.0 * nv);
        lobes[0].weight = nl > 0.0 ? brdf_schlick(ks, nv) * (m.brdf.z * g / (4.0 * nv)) : vec3(0.0);
        return 1;
    }
    vec3 t = brdf_tangent(m, n);
    if (kind == BRDF_LAFORTUNE) {
        // One SG per lobe about its axis with λ = e + 1 (the same peak and integral).
        int count = 0;
        for (int i = 0; i < BRDF_LAFORTUNE_LOBES; ++i) {
            vec3 d;
            float e, scale;
            if (!brdf_lafortune_term(m, i, n, t, v, d, e, scale)) continue;
            lobes[count].axis = d;
            lobes[count].lambda = e + 1.0;
            lobes[count].weight = ks * (scale * max(dot(n, d), 0.0));
            count += 1;
        }
        return count;
    }
    vec3 b = cross(n, t);
    vec3 wide = m.lobes_along_b > 0.5 ? b : t;
    float nu = m.brdf.x, nvx = m.brdf.y;
    float c = sqrt((nu + 1.0) * (nvx + 1.0)) / (8.0 * PI);
    for (int k = -3; k <= 3; ++k) {
        float ang = float(k) * m.brdf.w;
        vec3 h = cos(ang) * n + sin(ang) * wide;
        float vh = dot(v, h);
        vec3 l = 2.0 * vh * h - v;
        float nl = dot(n, l);
        int j = k + 3;
        lobes[j].axis = l;
        lobes[j].lambda = m.brdf.z / (4.0 * max(abs(vh), 1e-6));
        float mu = m.lobes[abs(k)];
        lobes[j].weight =
            (vh > 0.0 && nl > 0.0) ? brdf_schlick(ks, vh) * (mu * c * nl / max(vh * max(nl, nv), 1e-12)) : vec3(0.0);
    }
    return 7;
}

#endif // BRDF_GLSL
