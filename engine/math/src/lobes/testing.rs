//! Independent references shared by the unit tests of the `lobes` submodules.

use super::{add3, any_orthogonal, cross, scale3};
use crate::quadrature::{adaptive_simpson, integrate_gl};
use std::f64::consts::PI;

pub(super) fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

/// ∫ f over the cap θ ≤ θ_max about `axis` (Gauss–Legendre panels in θ, trapezoid in φ):
/// an independent 2D reference for lobes too sharp for `integrate_sphere`.
pub(super) fn cap_quadrature(
    axis: [f64; 3],
    theta_max: f64,
    f: impl Fn([f64; 3]) -> f64,
    panels: usize,
    n_phi: usize,
) -> f64 {
    let u = any_orthogonal(axis);
    let w = cross(axis, u);
    integrate_gl(
        |th| {
            let (st, ct) = th.sin_cos();
            let mut s = 0.0;
            for k in 0..n_phi {
                let ph = 2.0 * PI * (k as f64 + 0.5) / n_phi as f64;
                let d = add3(scale3(axis, ct), add3(scale3(u, st * ph.cos()), scale3(w, st * ph.sin())));
                s += f(d);
            }
            s * 2.0 * PI / n_phi as f64 * st
        },
        0.0,
        theta_max,
        16,
        panels,
    )
}

/// Independent reference for both hemisphere integrals: θ-outer form about the lobe axis with
/// the φ-integral of the clamped plane term in closed form, `∫_0^1 u^e j(u) du` (u = cos θ).
/// Above the kink u_k = sin β, j is elementary. Below it, [u_k/2, u_k] uses u = u_k(1 − s²)
/// (smooths the square-root edge of j) and [0, u_k/2] uses r = u^{e+1} (absorbs u^e); both by
/// adaptive Simpson at an absolute tolerance well above round-off (so it terminates).
/// `which` 0: hemisphere, 1: clamped cosine.
pub(super) fn theta_outer_reference(e: f64, cos_beta: f64, which: usize) -> f64 {
    let sb = (1.0 - cos_beta * cos_beta).max(0.0).sqrt();
    let j = |u: f64| {
        let p = sb * (1.0 - u * u).max(0.0).sqrt();
        let q = cos_beta * u;
        if q.abs() >= p {
            if q > 0.0 {
                if which == 0 {
                    2.0 * PI
                } else {
                    2.0 * PI * q
                }
            } else {
                0.0
            }
        } else {
            let phi0 = (-q / p).clamp(-1.0, 1.0).acos();
            if which == 0 {
                2.0 * phi0
            } else {
                2.0 * ((p * p - q * q).sqrt() + q * phi0)
            }
        }
    };
    let k = e + 1.0;
    let tol = 1e-12 / k;
    let uk = sb;
    let piece_a = |s: f64| {
        let u = uk * (1.0 - s * s);
        if u <= 0.0 {
            0.0
        } else {
            (e * u.ln()).exp() * j(u) * 2.0 * uk * s
        }
    };
    // (1 − s²)^e s peaks at s ≈ 1/√(2e): break there so Simpson's first samples see the peak.
    let mut cuts = vec![0.0, 0.5f64.sqrt()];
    cuts.extend([0.5, 2.0, 8.0].iter().map(|m| m / k.sqrt()).filter(|x| *x < 0.5f64.sqrt()));
    cuts.sort_by(|x, y| x.total_cmp(y));
    let a = if uk > 0.0 { cuts.windows(2).map(|w| adaptive_simpson(&piece_a, w[0], w[1], tol)).sum() } else { 0.0 };
    let rb = (0.5 * uk).powf(k);
    let b = if rb > 0.0 { adaptive_simpson(&|r: f64| j(r.powf(1.0 / k)), 0.0, rb, tol) / k } else { 0.0 };
    let above = match (which, cos_beta > 0.0) {
        (_, false) => 0.0,
        (0, true) => 2.0 * PI * (1.0 - uk.powf(k)) / k,
        _ => 2.0 * PI * cos_beta * (1.0 - uk.powf(k + 1.0)) / (k + 1.0),
    };
    a + b + above
}
