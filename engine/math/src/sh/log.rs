//! The SH log by the eigen method (paper Sec. 5, Eqs. 30–32) and the tabulated log-visibility of
//! circles (Sec. 6.1, 8).

use super::{circle_visibility_zonal, zh_rotate_star_into, zonal_star, ShTensor, SQRT_4PI};
use crate::linalg::{spectral_apply, symmetric_eigen};
use std::f64::consts::PI;

pub const LOG_CLIP_RELATIVE: f64 = 0.02;

/// Absolute floor of the clipped eigenvalues, for a `g` whose product matrix is ~0 (a blocker
/// covering the whole sphere, `θ → π`): the log is then `q'(1e-6)·(0 − 1) ≈ log(1e-6) · 1`, whose
/// exponential is a visibility of ~1e-6 everywhere instead of an infinity.
pub const LOG_CLIP_ABSOLUTE: f64 = 1e-6;

/// `q'(x) = log(x)/(x − 1)` (paper Eq. 31), continuous at `x = 1` (value 1) via `ln_1p`.
pub fn q_prime(x: f64) -> f64 {
    let t = x - 1.0;
    if t.abs() < 1e-12 {
        1.0 - 0.5 * t
    } else {
        t.ln_1p() / t
    }
}

/// The clip threshold `ε = max(0.02 λ_max, 1e-6)` applied to eigenvalues `λ` (paper Eq. 32).
pub fn log_clip_threshold(eigenvalues: &[f64]) -> f64 {
    let max = eigenvalues.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    (LOG_CLIP_RELATIVE * max).max(LOG_CLIP_ABSOLUTE)
}

/// `log(g)` by inverting the SH exponential (paper Eqs. 30–32): with `M_g = V D Vᵀ` and the clipped
/// `D̃ = max(D, ε)`, `log(g) = V q'(D̃) Vᵀ (g − 1)`, literally as the paper writes it ("apply (30)
/// to D̃ rather than D"). For unclipped eigenvalues `q'(λ)(λ − 1) = log λ`, so without clipping
/// this is `log(M_g) 1`, which the exact exponential inverts; where clipping acts the component
/// becomes `q'(ε)(λ − 1)` rather than `log ε`. This literal reading is the one whose circle
/// logs reproduce DESIGN §3's monotonicity limits (1.40 / 1.75 / 1.30 rad at n = 3 / 4 / 6);
/// the alternative `log(M̃_g) 1` gives 1.13 / 1.70 / 1.20.
pub fn log_eigen(tensor: &ShTensor, g: &[f64]) -> Vec<f64> {
    let c = tensor.len();
    let m = tensor.product_matrix(g);
    let (vals, vecs) = symmetric_eigen(&m, c);
    let eps = log_clip_threshold(&vals);
    let mut gm1 = g[..c].to_vec();
    gm1[0] -= SQRT_4PI;
    spectral_apply(&vals, &vecs, &gm1, |lam| q_prime(lam.max(eps)))
}

/// Zonal log-visibility coefficients `f_l(θ)` (of `y_l0`) of a circle of angular radius `θ`
/// about +z, by the eigen method. A zonal `g` commutes with rotations about z, so `M_g` is
/// block-diagonal in `m` (blocks `y_lm`, `l = |m|..n−1`, one per signed m): the clip threshold
/// uses the largest eigenvalue over all blocks, and the log needs only the `m = 0` block
/// (the constant 1 lives there). Equal to [`log_eigen`] of the rotated full vector.
pub fn circle_log_zonal(tensor: &ShTensor, theta: f64) -> Vec<f64> {
    let n = tensor.n;
    let c = tensor.len();
    let gz = circle_visibility_zonal(n, theta);
    let mut g = vec![0.0; c];
    for (l, v) in gz.iter().enumerate() {
        g[l * l + l] = *v;
    }
    let full = tensor.product_matrix(&g);
    let mut max_eig = f64::NEG_INFINITY;
    let mut block0 = (Vec::new(), Vec::new());
    // m ≥ 0 suffices: the m < 0 (sine) block has the same matrix as m > 0 for a zonal g.
    for m in 0..n {
        let idx: Vec<usize> = (m..n).map(|l| l * l + l + m).collect();
        let b = idx.len();
        let mut sub = vec![0.0; b * b];
        for (r, &ir) in idx.iter().enumerate() {
            for (s, &is) in idx.iter().enumerate() {
                sub[r * b + s] = full[ir * c + is];
            }
        }
        let (vals, vecs) = symmetric_eigen(&sub, b);
        max_eig = vals.iter().cloned().fold(max_eig, f64::max);
        if m == 0 {
            block0 = (vals, vecs);
        }
    }
    let eps = (LOG_CLIP_RELATIVE * max_eig).max(LOG_CLIP_ABSOLUTE);
    let (vals, vecs) = block0;
    let mut gm1 = gz.clone();
    gm1[0] -= SQRT_4PI;
    spectral_apply(&vals, &vecs, &gm1, |lam| q_prime(lam.max(eps)))
}

/// Number of θ samples of the circle log table (paper Sec. 8: "256 samples in θ").
pub const CIRCLE_TABLE_SAMPLES: usize = 256;

/// Tabulated scaled log-visibility `f*_l(θ)` of circles, `θ ∈ [0, π/2]` in
/// [`CIRCLE_TABLE_SAMPLES`] uniform samples, linearly interpolated (paper Sec. 6.1, 8).
/// A sphere seen from outside subtends `θ = asin(r/d) ≤ π/2`; a receiver inside a sphere is the
/// caller's case (SHEXP Sec. 6.2 rules remove or shrink such spheres); here `θ` is clamped to
/// `[0, π/2]`, i.e. treated as the half-space blocker.
#[derive(Clone, Debug)]
pub struct CircleLogTable {
    pub n: usize,
    /// `fstar[s * n + l]` = `f*_l(θ_s)`, `θ_s = s · (π/2) / (samples − 1)`.
    pub fstar: Vec<f64>,
}

impl CircleLogTable {
    pub fn new(tensor: &ShTensor) -> Self {
        let n = tensor.n;
        let mut fstar = Vec::with_capacity(CIRCLE_TABLE_SAMPLES * n);
        for s in 0..CIRCLE_TABLE_SAMPLES {
            let theta = Self::theta_of(s);
            fstar.extend(zonal_star(&circle_log_zonal(tensor, theta)));
        }
        Self { n, fstar }
    }

    /// θ of sample `s`.
    pub fn theta_of(s: usize) -> f64 {
        s as f64 * (0.5 * PI) / (CIRCLE_TABLE_SAMPLES - 1) as f64
    }

    /// Interpolated `f*_l(θ)`.
    pub fn lookup(&self, theta: f64) -> Vec<f64> {
        let n = self.n;
        let t = if theta.is_finite() { theta.clamp(0.0, 0.5 * PI) } else { 0.5 * PI };
        let x = t / (0.5 * PI) * (CIRCLE_TABLE_SAMPLES - 1) as f64;
        let s0 = (x.floor() as usize).min(CIRCLE_TABLE_SAMPLES - 2);
        let w = x - s0 as f64;
        (0..n).map(|l| self.fstar[s0 * n + l] * (1.0 - w) + self.fstar[(s0 + 1) * n + l] * w).collect()
    }

    /// Log-visibility vector of a circle of angular radius `θ` about `axis` (paper Eq. 34).
    pub fn log_visibility(&self, theta: f64, axis: [f64; 3]) -> Vec<f64> {
        let mut out = vec![0.0; self.n * self.n];
        zh_rotate_star_into(&self.lookup(theta), axis, &mut out);
        out
    }

    /// Log-visibility of a sphere blocker (center `p`, radius `r`) seen from receiver `x`
    /// (paper Eq. 34): `θ = asin(r/‖P−x‖)`, axis `(P−x)/‖P−x‖`. A receiver inside the sphere
    /// (or on it) gets the half-space blocker `θ = π/2`; a zero radius gives zero.
    pub fn sphere_log_visibility(&self, x: [f64; 3], p: [f64; 3], r: f64) -> Vec<f64> {
        let d = [p[0] - x[0], p[1] - x[1], p[2] - x[2]];
        let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if r <= 0.0 || !r.is_finite() {
            return vec![0.0; self.n * self.n];
        }
        let theta = if dist <= r { 0.5 * PI } else { (r / dist).asin() };
        self.log_visibility(theta, d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::{circle_visibility, zh_rotate};

    #[test]
    fn circle_log_eigen_method() {
        let n = 4;
        let t = ShTensor::new(n);
        // Zonal fast path equals the general eigen log of the full vector (rotated off-axis).
        let axis = [0.3, -0.5, 0.81];
        for &theta in &[0.05, 0.4, 0.9, 1.4, 0.5 * PI] {
            let fz = circle_log_zonal(&t, theta);
            let rotated = zh_rotate(&fz, axis);
            let general = log_eigen(&t, &circle_visibility(n, theta, axis));
            for i in 0..n * n {
                // Two Jacobi solves of different matrices; both converge to ~1e-14.
                assert!((rotated[i] - general[i]).abs() < 1e-10, "θ={theta} i={i}");
            }
        }
        // Hard cases: θ ≥ π/2 (receiver inside / on the blocker) and θ = π stay finite; θ = π
        // (all blocked, g = 0) gives the absolute floor: q'(1e-6)·(0 − 1) = log(1e-6)/(1 − 1e-6).
        for &theta in &[0.5 * PI, 2.5, PI] {
            let f = circle_log_zonal(&t, theta);
            assert!(f.iter().all(|v| v.is_finite()), "θ={theta}: {f:?}");
        }
        let f = circle_log_zonal(&t, PI);
        let want = LOG_CLIP_ABSOLUTE.ln() / (1.0 - LOG_CLIP_ABSOLUTE) * SQRT_4PI;
        assert!((f[0] - want).abs() < 1e-9, "{} vs {want}", f[0]);
        assert!(f[1..].iter().all(|v| v.abs() < 1e-9));
        // Zero radius: log of 1 is 0.
        assert!(circle_log_zonal(&t, 0.0).iter().all(|v| v.abs() < 1e-12));
        assert!((q_prime(1.0) - 1.0).abs() < 1e-15 && (q_prime(2.0) - 2f64.ln()).abs() < 1e-15);
    }

    #[test]
    fn circle_log_table_interpolates() {
        let t = ShTensor::new(3);
        let table = CircleLogTable::new(&t);
        // Midway between samples: linear interpolation error ≤ h²/8 · |f''|, h = π/510.
        let h = CircleLogTable::theta_of(1);
        for s in [3, 100, 200] {
            let theta = CircleLogTable::theta_of(s) + 0.5 * h;
            let got = table.lookup(theta);
            let want = zonal_star(&circle_log_zonal(&t, theta));
            for l in 0..3 {
                assert!((got[l] - want[l]).abs() < 1e-3 * (1.0 + want[l].abs()), "s={s} l={l}");
            }
        }
        // Receiver inside the sphere → half-space; zero radius → no blocking.
        let inside = table.sphere_log_visibility([0.0; 3], [0.1, 0.0, 0.0], 1.0);
        let half = table.log_visibility(0.5 * PI, [1.0, 0.0, 0.0]);
        assert_eq!(inside, half);
        assert!(table.sphere_log_visibility([0.0; 3], [1.0, 0.0, 0.0], 0.0).iter().all(|v| *v == 0.0));
        assert!(table.lookup(f64::NAN).iter().all(|v| v.is_finite()));
    }
}
