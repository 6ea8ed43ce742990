//! The lobe `c(v) = s·max(a·v, 0)^e` and its exact integrals: evaluation in log space, the
//! special functions and the tanh–sinh quadrature of the 1D reduction (module docs of `lobes`),
//! and the integrals over a hemisphere (of the lobe, and of the lobe times a clamped cosine).

use super::{dot, normalize};
use std::f64::consts::{FRAC_PI_2, PI};
use std::sync::OnceLock;

/// A cosine lobe `scale · max(axis·v, 0)^exponent` (paper Eq. 4); `axis` is a unit vector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lobe {
    pub axis: [f64; 3],
    pub scale: f64,
    pub exponent: f64,
}

impl Lobe {
    pub fn new(axis: [f64; 3], scale: f64, exponent: f64) -> Self {
        Self { axis: normalize(axis), scale, exponent }
    }

    /// Value at the unit direction `v`.
    pub fn eval(&self, v: [f64; 3]) -> f64 {
        lobe_eval(self.axis, self.scale, self.exponent, v)
    }

    /// Integral over the whole sphere: `s · 2π/(e+1)` (paper Eq. 20–21).
    pub fn sphere_integral(&self) -> f64 {
        self.scale * sphere_integral(self.exponent)
    }

    /// Integral over the hemisphere `n·v > 0` (exact, by 1D quadrature).
    pub fn hemisphere_integral(&self, n: [f64; 3]) -> f64 {
        self.scale * hemisphere_integral(self.exponent, dot(self.axis, n))
    }

    /// `∫ c(v) max(n·v, 0) dω` (exact, by 1D quadrature).
    pub fn clamped_cosine_integral(&self, n: [f64; 3]) -> f64 {
        self.scale * clamped_cosine_integral(self.exponent, dot(self.axis, n))
    }
}

/// `ln max(a·v, 0)^e` without the scale: `e · ln(a·v)`, `−∞` outside the hemisphere, `0` inside
/// for `e = 0` (never `0 · −∞`). Log space is how large exponents stay exact: `(a·v)^e` with
/// `a·v = 1 − 1e-6` and `e = 1e5` is `exp(−0.1)`, which f32 `pow` cannot see.
pub fn lobe_log_eval(axis: [f64; 3], exponent: f64, v: [f64; 3]) -> f64 {
    let d = dot(axis, v);
    if d <= 0.0 {
        f64::NEG_INFINITY
    } else if exponent == 0.0 {
        0.0
    } else {
        exponent * d.ln()
    }
}

/// `s · max(a·v, 0)^e` evaluated as `s · exp(e · ln(a·v))`.
pub fn lobe_eval(axis: [f64; 3], scale: f64, exponent: f64, v: [f64; 3]) -> f64 {
    let l = lobe_log_eval(axis, exponent, v);
    if l == f64::NEG_INFINITY {
        0.0
    } else {
        scale * l.exp()
    }
}

/// `∫_{S²} max(a·v, 0)^e dω = 2π/(e+1)` (paper Eq. 20–21; the integral depends only on e).
pub fn sphere_integral(exponent: f64) -> f64 {
    2.0 * PI / (exponent + 1.0)
}

// ---------------------------------------------------------------------------------------------
// Special functions and quadrature.

/// `ln Γ(x)` for `x ≥ 0.5` (Lanczos, g = 7, 9 terms; relative error ~1e-15).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const P: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    debug_assert!(x >= 0.5, "ln_gamma is only used for x ≥ 0.5");
    let x = x - 1.0;
    let mut a = P[0];
    for (i, p) in P.iter().enumerate().skip(1) {
        a += p / (x + i as f64);
    }
    let t = x + G + 0.5;
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// `ln W(n)`, `W(n) = ∫_{−π/2}^{π/2} cos^n y dy = √π Γ(n/2 + ½)/Γ(n/2 + 1)`, for `n ≥ 0`.
///
/// For large n the difference of two ln Γ of size ~n ln n would lose ~n·1e-16 absolutely, so
/// above z = n/2 = 32 the ratio √z Γ(z+½)/Γ(z+1) uses its asymptotic series in 1/z to the z⁻⁶
/// term (the first omitted term is < 1e-14 there; the test checks the seam against Lanczos).
pub fn ln_wallis(n: f64) -> f64 {
    let z = 0.5 * n;
    if z < 32.0 {
        0.5 * PI.ln() + ln_gamma(z + 0.5) - ln_gamma(z + 1.0)
    } else {
        let r = 1.0 / z;
        let series = 1.0
            + r * (-1.0 / 8.0
                + r * (1.0 / 128.0
                    + r * (5.0 / 1024.0 + r * (-21.0 / 32768.0 + r * (-399.0 / 262144.0 + r * (869.0 / 4194304.0))))));
        0.5 * PI.ln() - 0.5 * z.ln() + series.ln()
    }
}

/// `W(n)` (see [`ln_wallis`]).
pub fn wallis(n: f64) -> f64 {
    ln_wallis(n).exp()
}

/// `ln(cos(x + t) / cos t)` for `cos(x + t) > 0`, `cos t > 0`, without the cancellation of
/// `ln cos(x+t) − ln cos t` (both near −∞ when t → π/2, both near 0 when x, t → 0):
/// `cos(x+t)/cos t = cos x − tan t sin x = 1 − 2 sin²(x/2) − tan t sin x`, then `log1p`.
pub(super) fn ln_cos_ratio(x: f64, t: f64) -> f64 {
    let h = (0.5 * x).sin();
    // At the support's edge the argument is −1 up to rounding: clamp so log1p gives −∞, not NaN.
    (-2.0 * h * h - t.tan() * x.sin()).max(-1.0).ln_1p()
}

/// `ln cos x` for |x| < π/2, accurate near 0 (`log1p(−2 sin²(x/2))`).
pub(super) fn ln_cos(x: f64) -> f64 {
    let h = (0.5 * x).sin();
    (-2.0 * h * h).max(-1.0).ln_1p()
}

/// Tanh–sinh nodes on [0, 1]: (position from the left end, weight), step h = 1/20, |t| ≤ 3.6.
/// Nodes crowd double-exponentially at both ends: this resolves a peak sitting at the left end (we
/// always put the peak there) and `(1 − ξ)^e` endpoint singularities on the right.
fn tanh_sinh_nodes() -> &'static [(f64, f64)] {
    static NODES: OnceLock<Vec<(f64, f64)>> = OnceLock::new();
    NODES.get_or_init(|| {
        let h = 1.0 / 20.0;
        let k_max = (3.6 / h) as i64;
        (-k_max..=k_max)
            .map(|k| {
                let t = k as f64 * h;
                let u = FRAC_PI_2 * t.sinh();
                // ξ = (1 + tanh u)/2 = 1/(1 + e^{−2u}); dξ/dt = (π/4) cosh t / cosh² u.
                let xi = 1.0 / (1.0 + (-2.0 * u).exp());
                let w = h * 0.25 * PI * t.cosh() / (u.cosh() * u.cosh());
                (xi, w)
            })
            .collect()
    })
}

/// Fixed quadrature rule for `∫_0^L exp(g(x)) · m(x) dx` where g is concave and decreasing from
/// its maximum `g(0) = 0`: the interval is first cut where g drops below −60 (the rest weighs
/// < e^-60 ≈ 1e-26 of the peak), then tanh–sinh nodes are placed on the cut interval.
/// Returns (x_k, w_k) with the Jacobian folded into w_k.
pub(super) fn peak_at_zero_rule(g: &impl Fn(f64) -> f64, len: f64) -> Vec<(f64, f64)> {
    if len <= 0.0 {
        return Vec::new();
    }
    const DROP: f64 = -60.0;
    let mut hi = len;
    if g(len) < DROP {
        // g is monotone on [0, len]: bisect for g(x) = DROP.
        let mut lo = 0.0;
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            if g(mid) < DROP {
                hi = mid;
            } else {
                lo = mid;
            }
            if hi - lo <= 1e-15 * hi {
                break;
            }
        }
    }
    tanh_sinh_nodes().iter().map(|&(xi, w)| (xi * hi, w * hi)).collect()
}

/// `∫_0^L exp(g(x)) dx` for g concave, decreasing, `g(0) = 0` (see [`peak_at_zero_rule`]).
fn integrate_peak_at_zero(g: impl Fn(f64) -> f64, len: f64) -> f64 {
    peak_at_zero_rule(&g, len).iter().map(|&(x, w)| w * g(x).exp()).sum()
}

// ---------------------------------------------------------------------------------------------
// 1. Integrals over a hemisphere.

/// `ln T_n(x0)`, `T_n(x0) = ∫_{x0}^{π/2} cos^n x dx` for `x0 ∈ [0, π/2]`, in log space
/// (the peak `cos^n x0` factored out as `n ln cos x0`).
fn ln_cos_power_tail(n: f64, x0: f64) -> f64 {
    let len = FRAC_PI_2 - x0;
    if len <= 0.0 {
        return f64::NEG_INFINITY;
    }
    if n == 0.0 {
        return len.ln();
    }
    let peak = n * ln_cos(x0);
    peak + integrate_peak_at_zero(|d| n * ln_cos_ratio(d, x0), len).ln()
}

/// `∫_{n·v > 0} max(a·v, 0)^e dω` for `cos_beta = a·n`: the part of a lobe above a surface.
///
/// Separated coordinates (module doc) with the normal at longitude β: `W(e+1) ∫_{β−π/2}^{π/2}
/// cos^e x dx`. For β ≤ π/2 it is the whole `W(e+1)W(e) = 2π/(e+1)` minus a tail of at most half;
/// for β > π/2 it is the tail itself, computed in log space so that it stays exact when tiny.
pub fn hemisphere_integral(exponent: f64, cos_beta: f64) -> f64 {
    let c = cos_beta.clamp(-1.0, 1.0);
    let x0 = c.abs().asin(); // |β − π/2|, accurate near β = π/2
    let ln_w1 = ln_wallis(exponent + 1.0);
    let tail = (ln_w1 + ln_cos_power_tail(exponent, x0)).exp();
    if c >= 0.0 {
        sphere_integral(exponent) - tail
    } else {
        tail
    }
}

/// `∫ max(a·v, 0)^e max(n·v, 0) dω` for `cos_beta = a·n` (lobe × clamped cosine: what a lobe of
/// incident radiance delivers to a diffuse surface).
///
/// Over the whole sphere the unclamped cosine gives `cos β · 2π/(e+2)` exactly (the component of n
/// orthogonal to a averages out). The clamp adds back the part below the surface,
/// `W(e+2) ∫_{x0}^{π/2} cos^e x · sin(x − x0) dx` with `x0 = |β − π/2|` (it is the whole answer
/// for β > π/2), computed directly, never as a difference.
pub fn clamped_cosine_integral(exponent: f64, cos_beta: f64) -> f64 {
    let c = cos_beta.clamp(-1.0, 1.0);
    let x0 = c.abs().asin();
    let len = FRAC_PI_2 - x0;
    let below = if len <= 0.0 {
        0.0
    } else if exponent == 0.0 {
        wallis(2.0) * (1.0 - x0.sin())
    } else {
        let g = |d: f64| exponent * ln_cos_ratio(d, x0);
        let rule = peak_at_zero_rule(&g, len);
        let s: f64 = rule.iter().map(|&(d, w)| w * g(d).exp() * d.sin()).sum();
        (ln_wallis(exponent + 2.0) + exponent * ln_cos(x0)).exp() * s
    };
    if c >= 0.0 {
        c * 2.0 * PI / (exponent + 2.0) + below
    } else {
        below
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lobes::testing::{cap_quadrature, rel, theta_outer_reference};
    use crate::quadrature::{adaptive_simpson, integrate_gl, integrate_sphere};

    #[test]
    fn ln_gamma_and_wallis() {
        // Γ(1/2) = √π, Γ(5) = 24, and the recurrence ln Γ(x+1) − ln Γ(x) = ln x: Lanczos is good to
        // ~1e-15 relative, so 1e-13 absolute on ln Γ binds with margin.
        assert!((ln_gamma(0.5) - 0.5 * PI.ln()).abs() < 1e-13);
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-13);
        for &x in &[0.7, 1.3, 4.5, 17.2, 250.0] {
            assert!((ln_gamma(x + 1.0) - ln_gamma(x) - f64::ln(x)).abs() < 1e-12 * (1.0 + ln_gamma(x).abs()));
        }
        // W(n) against quadrature (exponents as low as 0 and fractional).
        for &n in &[0.0, 0.3, 1.0, 2.7, 10.0, 33.0, 100.0, 900.0] {
            let q = integrate_gl(|y: f64| y.cos().max(0.0).powf(n), -FRAC_PI_2, FRAC_PI_2, 20, 64);
            // 64 panels × 20 nodes resolve cos^900 (width 0.03) to ~1e-12; n = 0.3 has a y^0.3 endpoint
            // singularity that Gauss–Legendre converges to only ~1e-7.
            let tol = if n > 0.0 && n < 1.0 { 1e-6 } else { 1e-11 };
            assert!(rel(wallis(n), q) < tol, "W({n}) = {} vs {q}", wallis(n));
        }
        // The asymptotic branch against the Lanczos difference where the latter is still exact,
        // and the identity W(n) W(n+1) = 2π/(n+1) up to the largest products (2e5 + 1).
        for &z in &[32.0, 33.0, 40.0, 90.0] {
            let lanczos = 0.5 * PI.ln() + ln_gamma(z + 0.5) - ln_gamma(z + 1.0);
            assert!((ln_wallis(2.0 * z) - lanczos).abs() < 1e-13, "z = {z}");
        }
        for &n in &[0.0, 0.5, 5.0, 31.0, 32.0, 33.0, 1e3, 1e5, 2e5] {
            let lhs = ln_wallis(n) + ln_wallis(n + 1.0);
            assert!((lhs - (2.0 * PI / (n + 1.0)).ln()).abs() < 1e-13, "n = {n}");
        }
    }

    #[test]
    fn lobe_eval_in_log_space() {
        let a = [0.0, 1.0, 0.0];
        // (1 − 1e-6)^1e5 = exp(1e5 ln(1 − 1e-6)): the f64 log form agrees with powf to 1e-12.
        let v = normalize([(2e-6f64).sqrt(), 1.0 - 1e-6, 0.0]);
        let d = dot(a, v);
        assert!(rel(lobe_eval(a, 2.0, 1e5, v), 2.0 * d.powf(1e5)) < 1e-12);
        assert_eq!(lobe_eval(a, 1.0, 0.0, [0.0, -1.0, 0.0]), 0.0);
        assert_eq!(lobe_eval(a, 3.0, 0.0, [1.0, 0.0, 0.0]), 0.0); // on the horizon: outside
        assert_eq!(lobe_eval(a, 3.0, 0.0, normalize([1.0, 1e-9, 0.0])), 3.0);
        assert_eq!(lobe_log_eval(a, 0.0, [0.0, 1.0, 0.0]), 0.0);
        // Sphere integral vs quadrature about the axis.
        for &e in &[0.0, 0.5, 7.0, 1e3, 1e5] {
            let lobe = Lobe::new(a, 1.5, e);
            let th = if e > 10.0 { (200.0 / e).sqrt() } else { FRAC_PI_2 };
            let q = cap_quadrature(a, th, |v| lobe.eval(v), 16, 8);
            // The integrand is zonal (φ exact) and smooth in θ except the e<1 horizon singularity.
            // (GL converges only algebraically on the (π/2 − θ)^e factor: ~1e-6 at e = 0.5.)
            let tol = if e > 0.0 && e < 1.0 { 1e-5 } else { 1e-10 };
            assert!(rel(lobe.sphere_integral(), q) < tol, "e = {e}: {} vs {q}", lobe.sphere_integral());
        }
    }

    #[test]
    fn reference_formula_matches_brute_force_sphere() {
        // The θ-outer reference itself, checked once against plain sphere quadrature. The plane cut
        // is a discontinuity for integrate_sphere, so this agrees only to ~3e-4 (O(h) error).
        let (e, beta) = (3.0, 1.0f64);
        let a = [0.0, 0.0, 1.0];
        let n = [beta.sin(), 0.0, beta.cos()];
        let brute_h =
            integrate_sphere(|v| lobe_eval(a, 1.0, e, v) * if dot(n, v) > 0.0 { 1.0 } else { 0.0 }, 16, 32, 256);
        let brute_k = integrate_sphere(|v| lobe_eval(a, 1.0, e, v) * dot(n, v).max(0.0), 16, 32, 256);
        let (rh, rk) = (theta_outer_reference(e, beta.cos(), 0), theta_outer_reference(e, beta.cos(), 1));
        let (h, k) = (hemisphere_integral(e, beta.cos()), clamped_cosine_integral(e, beta.cos()));
        assert!(rel(rh, brute_h) < 1e-3 && rel(h, brute_h) < 1e-3 && rel(h, rh) < 1e-12, "H {rh} {h} vs {brute_h}");
        assert!(rel(rk, brute_k) < 1e-3 && rel(k, brute_k) < 1e-3 && rel(k, rk) < 1e-12, "K {rk} {k} vs {brute_k}");
    }

    #[test]
    fn hemisphere_integrals_match_reference() {
        let betas = [0.0, 0.3, 1.0, FRAC_PI_2 - 1e-3, FRAC_PI_2, FRAC_PI_2 + 1e-3, FRAC_PI_2 + 0.01, 2.0, 3.0, PI];
        for &e in &[0.0, 0.0625, 0.5, 1.0, 4.0, 37.0, 1e3, 1e5] {
            for &b in &betas {
                let c = f64::cos(b);
                let h = hemisphere_integral(e, c);
                let k = clamped_cosine_integral(e, c);
                assert!(h.is_finite() && k.is_finite() && h >= 0.0 && k >= 0.0);
                let (rh, rk) = (theta_outer_reference(e, c, 0), theta_outer_reference(e, c, 1));
                // Errors relative to the lobe's whole integral (absolute tails of 1e-300 are exact in
                // our log-space form but the reference's Simpson tolerance is absolute). The
                // reference is good to ~1e-9 of the total; tanh–sinh to ~1e-12.
                let scale_h = sphere_integral(e);
                let scale_k = 2.0 * PI / (e + 2.0);
                assert!((h - rh).abs() < 1e-8 * scale_h, "H e={e} β={b}: {h} vs {rh}");
                assert!((k - rk).abs() < 1e-8 * scale_k, "K e={e} β={b}: {k} vs {rk}");
            }
        }
        // Closed forms: e = 0 is a lune, 2(π − β); e = 1 at β = 0 is the full 2π/2 and K(e, 0) = 2π/(e+2).
        for &b in &betas {
            assert!((hemisphere_integral(0.0, b.cos()) - 2.0 * (PI - b)).abs() < 1e-12);
        }
        for &e in &[0.0, 1.0, 1e5] {
            assert!(rel(clamped_cosine_integral(e, 1.0), 2.0 * PI / (e + 2.0)) < 1e-12);
            assert_eq!(hemisphere_integral(e, -1.0), 0.0);
        }
        // Deep tails stay relatively exact: e = 1e5 at β = π/2 + 0.05 is ~exp(−125)·(…), compared
        // with the φ-outer form D = (1/(e+1)) ∫ exp(−(e+1)/2 log1p(cot²β sec²φ)) dφ.
        let (e, b) = (1e5f64, FRAC_PI_2 + 0.05);
        let cot2 = 1.0 / b.tan().powi(2);
        let ln_peak = -0.5 * (e + 1.0) * cot2.ln_1p();
        let f = |p: f64| (-0.5 * (e + 1.0) * (cot2 / p.cos().powi(2)).ln_1p() - ln_peak).exp();
        let d = 2.0 * adaptive_simpson(&f, 0.0, 0.5, 1e-13) / (e + 1.0);
        let ours = hemisphere_integral(e, b.cos());
        assert!(ours > 0.0 && (ours.ln() - (ln_peak + d.ln())).abs() < 1e-9, "{ours} vs exp({ln_peak})·{d}");
    }
}
