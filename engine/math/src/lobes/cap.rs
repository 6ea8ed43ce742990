//! The spherical-cap exponent (paper Sec. 5.2, Eq. 32–34): the lobe exponent whose L2 fit best
//! matches the indicator of a cap of half-angle α, and its table over α.

use super::{axis_lerp, ln_cos, CAP_SAMPLES};
use std::f64::consts::{FRAC_PI_2, PI};

/// `∫_{S²} (f_cap − max(a·v, 0)^e)² dω` for a cap of angular radius α (unit-scale lobe, as in
/// Eq. 34): `A − 2·2π(1 − cos^{e+1} α_h)/(e+1) + 2π/(2e+1)` with `A = 2π(1 − cos α)` the cap's
/// solid angle and `α_h = min(α, π/2)` (the lobe vanishes below its horizon).
pub fn cap_l2_residual(alpha: f64, e: f64) -> f64 {
    let area = 4.0 * PI * (0.5 * alpha).sin().powi(2);
    let inside = if alpha >= FRAC_PI_2 { 1.0 / (e + 1.0) } else { -((e + 1.0) * ln_cos(alpha)).exp_m1() / (e + 1.0) };
    area - 4.0 * PI * inside + 2.0 * PI / (2.0 * e + 1.0)
}

/// Relative L2 error `‖f_cap − c‖ / ‖f_cap‖` of a lobe with exponent e against a cap of radius α.
pub fn cap_relative_l2_error(alpha: f64, e: f64) -> f64 {
    let area = 4.0 * PI * (0.5 * alpha).sin().powi(2);
    (cap_l2_residual(alpha, e).max(0.0) / area).sqrt()
}

/// Limit of `e_cap · α²` as α → 0: with `e α² = 2m` the residual becomes
/// `πα²(1/2 − 2(1 − e^{−m})/(2m) + 1/(4m))`, stationary where `(1 + m) e^{−m} = 3/4`.
pub fn cap_small_angle_limit() -> f64 {
    let mut m: f64 = 1.0;
    for _ in 0..50 {
        let f = (1.0 + m) * (-m).exp() - 0.75;
        let df = -m * (-m).exp();
        m -= f / df;
    }
    2.0 * m
}

/// The exponent of the unit-scale lobe nearest (L2 over the sphere, Eq. 32) to a cap of radius α.
/// Zero for α ≥ π/2 (the residual then increases with e). Solves `dR/de = 0`, which is
/// `q L/(e+1) + (1−q)/(e+1)² = 1/(2e+1)²` with `L = ln cos α`, `q = cos^{e+1} α`, by bisection
/// in `ln(1+e)` (the left side minus the right is negative below the optimum, positive above).
pub fn cap_exponent(alpha: f64) -> f64 {
    if alpha >= FRAC_PI_2 {
        return 0.0;
    }
    if alpha <= 0.0 {
        return f64::INFINITY;
    }
    let l = ln_cos(alpha);
    let slope = |e: f64| {
        let q = ((e + 1.0) * l).exp();
        let one_minus_q = -((e + 1.0) * l).exp_m1();
        q * l / (e + 1.0) + one_minus_q / ((e + 1.0) * (e + 1.0)) - 1.0 / ((2.0 * e + 1.0) * (2.0 * e + 1.0))
    };
    let (mut lo, mut hi) = (0.0f64, (100.0 / (alpha * alpha) + 100.0).ln_1p());
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if slope(mid.exp_m1()) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (0.5 * (lo + hi)).exp_m1()
}

/// The spherical-cap exponent table: `k_i = e_cap(α_i) · α_i²` at `α_i = (π/2) i/(n−1)`,
/// i = 0..n−1 (n = 1000), with `k_0` the small-angle limit ([`cap_small_angle_limit`], 1.9226).
/// Storing `e α²` instead of e keeps the table smooth: e itself grows like 1.92/α². 3.9 KiB in f32.
#[derive(Clone, Debug, PartialEq)]
pub struct CapTable {
    pub k: Vec<f32>,
}

pub fn cap_table() -> CapTable {
    cap_table_sized(CAP_SAMPLES)
}

pub fn cap_table_sized(n: usize) -> CapTable {
    let k = (0..n)
        .map(|i| {
            let a = FRAC_PI_2 * i as f64 / (n - 1) as f64;
            let k = if i == 0 { cap_small_angle_limit() } else { cap_exponent(a) * a * a };
            k as f32
        })
        .collect();
    CapTable { k }
}

/// Smallest cap radius the lookups distinguish (e ≤ 1.9e8): a point light stays finite.
pub const CAP_MIN_ALPHA: f64 = 1e-4;

/// Fractional index of α_cap in a cap table of `n` entries over [0, π/2] (clamped).
pub fn cap_coord(alpha: f64, n: usize) -> f64 {
    (alpha / FRAC_PI_2).clamp(0.0, 1.0) * (n - 1) as f64
}

/// The exponent from an interpolated `k = e α²`: `k / max(α, CAP_MIN_ALPHA)²`, 0 for α ≥ π/2.
pub fn cap_exponent_from_k(k: f64, alpha: f64) -> f64 {
    if alpha >= FRAC_PI_2 {
        return 0.0;
    }
    let a = alpha.max(CAP_MIN_ALPHA);
    k / (a * a)
}

/// Fractional index of α in a product table with `n` α samples over [0, π] (clamped).
pub fn alpha_coord(alpha: f64, n: usize) -> f64 {
    (alpha / PI).clamp(0.0, 1.0) * (n - 1) as f64
}

impl CapTable {
    /// Exponent for a cap of radius α by linear interpolation of `e α²`, divided by α²
    /// ([`cap_coord`], [`cap_exponent_from_k`]).
    pub fn exponent(&self, alpha: f64) -> f64 {
        let n = self.k.len();
        let (i0, i1, f) = axis_lerp(cap_coord(alpha.max(CAP_MIN_ALPHA), n), n);
        let k = self.k[i0] as f64 * (1.0 - f) + self.k[i1] as f64 * f;
        cap_exponent_from_k(k, alpha)
    }

    pub fn size_bytes(&self) -> usize {
        self.k.len() * 4
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::integrate_gl;

    #[test]
    fn cap_exponent_minimizes_the_l2_residual() {
        // Closed-form residual against zonal quadrature in z = cos θ, split at the cap edge and at
        // the horizon so every piece is smooth (then GL is good to ~1e-13).
        for &(a, e) in &[(0.3, 20.0), (1.0, 1.5), (2.0, 0.5), (0.01, 2e4)] {
            let za = f64::cos(a);
            let f = |z: f64| {
                let cap = if z >= za { 1.0 } else { 0.0 };
                let d = cap - if z > 0.0 { z.powf(e) } else { 0.0 };
                2.0 * PI * d * d
            };
            let mut cuts = vec![-1.0, 0.0, za, 1.0];
            // The lobe's own width in z is 1/e: cut there too so GL panels resolve it.
            cuts.extend([1.0, 4.0, 16.0, 64.0].iter().map(|k| 1.0 - k / e).filter(|z| *z > 0.0));
            cuts.sort_by(|x, y| x.total_cmp(y));
            let q: f64 = cuts.windows(2).map(|w| integrate_gl(f, w[0], w[1], 20, 64)).sum();
            // (e < 1: the z^e horizon singularity limits GL to ~1e-7.)
            let tol = if e < 1.0 { 1e-6 } else { 1e-9 };
            assert!((cap_l2_residual(a, e) - q).abs() < tol * q, "α={a} e={e}: {} vs {q}", cap_l2_residual(a, e));
        }
        for &a in &[1e-3, 0.05, 0.3, 1.0, 1.5] {
            let e = cap_exponent(a);
            let r = cap_l2_residual(a, e);
            for s in [0.99, 1.01] {
                assert!(cap_l2_residual(a, e * s) > r, "α={a}: e_cap={e} not a minimum");
            }
        }
        // DESIGN §3: e_cap α² → 1.92 and relative L2 error ≈ 0.48 for small caps.
        let k0 = cap_small_angle_limit();
        assert!((k0 - 1.9226).abs() < 1e-3, "{k0}");
        let a = 1e-3;
        assert!((cap_exponent(a) * a * a - k0).abs() < 1e-5);
        assert!((cap_relative_l2_error(a, cap_exponent(a)) - 0.485).abs() < 5e-3);
        assert_eq!(cap_exponent(FRAC_PI_2), 0.0);
        assert_eq!(cap_exponent(2.0), 0.0);
        // The table: linear interpolation of e α² over 1000 entries is within 1e-3 relative.
        let t = cap_table();
        assert_eq!(t.k.len(), 1000);
        for &a in &[1e-3, 0.0123, 0.2, 0.77, 1.3, 1.55] {
            let direct = cap_exponent(a);
            assert!((t.exponent(a) - direct).abs() < 1e-3 * direct + 1e-4, "α={a}: {} vs {direct}", t.exponent(a));
        }
        assert_eq!(t.exponent(2.0), 0.0);
        assert!(t.exponent(0.0).is_finite());
    }
}
