//! Integral spherical Gaussian (ISG): Iwasaki et al. 2012, Sec. 4, with the frame of docs/design.md §3.
//!
//! Local frame with the SG axis z: `Ω(θ, φ) = (sin θ cos φ, cos θ, sin θ sin φ)`; θ from +y, φ the
//! rotation about y from the xy plane. The axis is Ω(π/2, π/2), the centre of the domain [0, π]²,
//! which covers the hemisphere around the axis. (Paper Eq. 11–13; the text lost λ.)
//!
//! `S(θ, φ) = ∫₀^θ ∫₀^φ exp(λ(sin θ' sin φ' − 1)) sin θ' dφ' dθ'`, `Ŝ = S / (2π(1 − e^{−λ})/λ)`.
//!
//! Three evaluators of Ŝ:
//! - [`isg_exact`] / [`isg_exact_grid`]: tensor Gauss–Legendre on segments matched to the lobe width
//!   `1/√λ` (accurate to ~1e-12, the f64 reference);
//! - [`isg_paper`]: the paper's product of two sigmoids (Eq. 14) with the appendix quartics;
//! - [`isg_lut`]: ours, the product of Ŝ's two marginals, each tabulated per λ (see [`IsgLut`]): Ŝ is
//!   separable to 0.004, and a separable evaluator makes a patch as cheap as the paper's.
//!
//! Patch integrals use the paper's four-corner (summed-area-table) rule.

use crate::quadrature::gauss_legendre;
use std::f64::consts::{FRAC_PI_2, PI};

/// Hemisphere integral of `exp(λ(v·a − 1))` around its own axis: `2π(1 − e^{−λ})/λ`
/// (the ISG normalization, paper Eq. 13). `expm1` keeps it exact for small λ; λ → 0 gives 2π.
pub fn isg_normalization(lambda: f64) -> f64 {
    if lambda < 1e-300 {
        return 2.0 * PI;
    }
    2.0 * PI * (-(-lambda).exp_m1()) / lambda
}

/// `1 − cos x = 2 sin²(x/2)`, without cancellation for small x.
fn one_minus_cos(x: f64) -> f64 {
    let s = (0.5 * x).sin();
    2.0 * s * s
}

/// Gauss–Legendre nodes (x, w) of `n` points on each segment of [lo, hi] cut at `breaks`.
fn segment_nodes(lo: f64, hi: f64, breaks: &[f64], n: usize) -> Vec<(f64, f64)> {
    let (gx, gw) = gauss_legendre(n);
    let mut cuts: Vec<f64> = vec![lo];
    cuts.extend(breaks.iter().copied().filter(|&b| b > lo && b < hi));
    cuts.push(hi);
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    let mut out = Vec::with_capacity(n * cuts.len());
    for seg in cuts.windows(2) {
        let (a, b) = (seg[0], seg[1]);
        let h = 0.5 * (b - a);
        if h <= 0.0 {
            continue;
        }
        for (xi, wi) in gx.iter().zip(&gw) {
            out.push((a + h * (xi + 1.0), wi * h));
        }
    }
    out
}

/// Breakpoints at π/2 ± 2^j/√λ: segments no wider than the local scale of the Gaussian, so that
/// 16-point Gauss–Legendre resolves exp(−λx²/2) to machine precision on each.
fn scale_breaks(lambda: f64) -> Vec<f64> {
    let mut b = vec![FRAC_PI_2];
    let w = 1.0 / lambda.max(1e-12).sqrt();
    let mut d = 0.25 * w;
    while d < FRAC_PI_2 {
        b.push(FRAC_PI_2 - d);
        b.push(FRAC_PI_2 + d);
        d *= 2.0;
    }
    b
}

/// Exact Ŝ on a grid: `out[i * phis.len() + j] = Ŝ(thetas[i], phis[j]; λ)`.
///
/// `thetas` and `phis` must be ascending in [0, π]. The integrand is written with
/// `a = 1 − cos(θ − π/2)`, `b = 1 − cos(φ − π/2)`: `sin θ sin φ − 1 = −(a + b − ab)`, which does
/// not cancel at the peak (λ up to 1e5 needs it). Cells between grid lines are integrated by tensor
/// Gauss–Legendre, then summed as a 2D prefix sum. Accurate to ~1e-12 (tested against nested
/// adaptive Simpson and against the exact total Ŝ(π, π) = 1).
pub fn isg_exact_grid(lambda: f64, thetas: &[f64], phis: &[f64]) -> Vec<f64> {
    assert!(lambda >= 0.0 && lambda.is_finite(), "ISG sharpness must be finite and >= 0");
    let breaks = scale_breaks(lambda);
    let axis_nodes = |grid: &[f64]| -> Vec<(usize, f64, f64)> {
        // (cell index, a = 1 − cos(x − π/2), weight × (optional sin factor applied by caller))
        let mut all: Vec<f64> = breaks.clone();
        all.extend_from_slice(grid);
        let hi = grid.iter().copied().fold(0.0f64, f64::max).min(PI);
        segment_nodes(0.0, hi, &all, 16)
            .into_iter()
            .map(|(x, w)| {
                let cell = grid.partition_point(|&g| g <= x);
                (cell, x, w)
            })
            .collect()
    };
    let tn = axis_nodes(thetas);
    let pn = axis_nodes(phis);
    let (nt, np) = (thetas.len(), phis.len());
    // Cell sums, cells indexed 0..=len (cell i lies between grid[i-1] and grid[i]).
    let mut cells = vec![0.0f64; (nt + 1) * (np + 1)];
    // Beyond λa > 745, exp(−λ(a + b − ab)) ≤ exp(−λa) underflows: skip (a + b − ab ≥ max(a, b)).
    let cut = 745.0;
    let pre: Vec<(usize, f64, f64)> = pn
        .iter()
        .map(|&(c, y, w)| (c, one_minus_cos(y - FRAC_PI_2), w))
        .filter(|&(_, b, _)| lambda * b <= cut)
        .collect();
    for &(ci, x, wx) in &tn {
        let a = one_minus_cos(x - FRAC_PI_2);
        if lambda * a > cut {
            continue;
        }
        let sin_t = x.sin();
        let row = ci * (np + 1);
        for &(cj, b, wy) in &pre {
            cells[row + cj] += wx * wy * sin_t * (-lambda * (a + b - a * b)).exp();
        }
    }
    let norm = isg_normalization(lambda);
    let mut out = vec![0.0; nt * np];
    // Prefix sums: S(thetas[i], phis[j]) = Σ cells (0..=i, 0..=j).
    let mut acc = vec![0.0f64; np + 1];
    for i in 0..nt {
        let mut run = 0.0;
        for j in 0..=np {
            run += cells[i * (np + 1) + j];
            acc[j] += run;
        }
        for j in 0..np {
            out[i * np + j] = acc[j] / norm;
        }
    }
    out
}

/// Exact normalized ISG Ŝ(θ, φ; λ) (see [`isg_exact_grid`]).
pub fn isg_exact(theta: f64, phi: f64, lambda: f64) -> f64 {
    isg_exact_grid(lambda, &[theta.clamp(0.0, PI)], &[phi.clamp(0.0, PI)])[0]
}

/// The paper's appendix quartics in λ/100 for the sigmoid steepness in θ (g) and φ (h).
pub const PAPER_G: [f64; 5] = [17.6028, 3.9529, -0.0571, 7e-4, -2.6856e-6];
pub const PAPER_H: [f64; 5] = [17.5003, 3.9900, -0.0592, 7e-4, -2.6875e-6];

fn quartic(c: &[f64; 5], t: f64) -> f64 {
    (((c[4] * t + c[3]) * t + c[2]) * t + c[1]) * t + c[0]
}

/// Logistic sigmoid, written so that neither branch overflows.
fn sigmoid(x: f64) -> f64 {
    if x >= 0.0 {
        1.0 / (1.0 + (-x).exp())
    } else {
        let e = x.exp();
        e / (1.0 + e)
    }
}

/// The paper's fit (Eq. 14): `Ŝ ≈ σ(g(λ)(θ − π/2)) σ(h(λ)(φ − π/2))`, g, h from the appendix.
/// Fitted for λ ∈ [1, 10000] by the authors; measured good only near λ ∈ [200, 2000] (DESIGN §3).
pub fn isg_paper(theta: f64, phi: f64, lambda: f64) -> f64 {
    let t = lambda / 100.0;
    sigmoid(quartic(&PAPER_G, t) * (theta - FRAC_PI_2)) * sigmoid(quartic(&PAPER_H, t) * (phi - FRAC_PI_2))
}

/// Our evaluator: Ŝ ≈ M(θ; λ) N(φ; λ), the product of Ŝ's own marginals `M(θ) = Ŝ(θ, π)` and
/// `N(φ) = Ŝ(π, φ)`, each tabulated in a linear angle coordinate and interpolated linearly.
///
/// Ŝ is nearly separable: the product of its exact marginals errs by at most 0.0039 (at λ ≈ 3; 0.0016
/// at λ = 10, < 2e-4 above λ = 100 and below 0.1), so the paper's error floor of ~0.018 for a
/// product of two sigmoids comes from the sigmoid's shape, not from separability. Tabulating the two
/// marginals (1-D per λ, so they can be sampled finely) gives max error 0.005 over λ ∈ [1e-2, 1e5],
/// and a patch is `(M(θ1) − M(θ0)) (N(φ1) − N(φ0))` like the paper's fit: 4 interpolations.
///
/// Coordinates: `s = ½ + (x − π/2) k(λ)` clamped to [0, 1], `k = max(√λ / (2U), 1/π)` with
/// `U = π√6/2 ≈ 3.85` lobe widths: the table spans ±U/√λ around the axis (outside it a marginal is
/// within Φ(−3.85) = 6e-5 of 0 or 1), or all of [0, π] for λ ≤ 6 (a slice sits on that kink).
/// λ slices: `2^e (1 + r/R)` for e ∈ [−10, 17) and r < R = 2, then 2^17 (λ ∈ [9.8e-4, 1.3e5]); the
/// slice position is read from λ's exponent and mantissa bits (`e R + (m − 1) R`, m ∈ [1, 2)), so
/// the interpolation is linear in λ within each half-octave and needs no logarithm. λ beyond the
/// table clamps the slice but not k: in u = √λ (x − π/2) units the marginals converge to Φ(u).
///
/// Storage, packed for one 4-float read per marginal: entry (l, a, i) of axis a (0 = θ, 1 = φ) is
/// `(X_l[i], X_l[i+1], X_{l+1}[i], X_{l+1}[i+1])` (indices clamped at the last sample/slice);
/// 55 slices × 2 axes × 64 samples × 4 = 28160 f32 = 110 KiB.
#[derive(Clone, Debug, PartialEq)]
pub struct IsgLut {
    /// Samples per axis (s = 0, 1/(n−1), …, 1).
    pub n: usize,
    /// log2 of the first slice's λ, and slices per octave.
    pub octave0: i32,
    pub per_octave: usize,
    pub slices: usize,
    /// Packed entries, see the type's documentation: `values[((l * 2 + a) * n + i) * 4 + c]`.
    pub values: Vec<f32>,
}

/// Half-width of the table in lobe widths 1/√λ: U = π√6/2, so that the kink of k(λ) falls on the
/// slice λ = 6. `ISG_LUT_K_SQ = 1/(2U)` and `ISG_LUT_K_MIN = 1/π` (see [`IsgLut`]).
pub const ISG_LUT_K_SQ: f64 = 0.129_949_466_872_279_37; // 1/(π√6)
pub const ISG_LUT_K_MIN: f64 = std::f64::consts::FRAC_1_PI;

/// (k, ½ − k π/2): s = clamp(x k + ½ − k π/2, 0, 1) (one multiply-add per angle).
fn lut_warp_consts(lambda: f64) -> (f64, f64) {
    let k = (lambda.max(0.0).sqrt() * ISG_LUT_K_SQ).max(ISG_LUT_K_MIN);
    (k, 0.5 - k * FRAC_PI_2)
}

fn lut_warp(x: f64, wc: (f64, f64)) -> f64 {
    (x * wc.0 + wc.1).clamp(0.0, 1.0)
}

/// The table coordinate s ∈ [0, 1] of angle `x` for sharpness λ (twin of
/// `isg_lut_warp(x, isg_lut_warp_consts(λ))` in isg.glsl).
pub fn isg_lut_warp(x: f64, lambda: f64) -> f64 {
    lut_warp(x, lut_warp_consts(lambda))
}

/// Default table shape: samples per axis, first octave, octaves, slices per octave.
pub const ISG_LUT_N: usize = 64;
pub const ISG_LUT_OCTAVE0: i32 = -10;
pub const ISG_LUT_OCTAVES: usize = 27;
pub const ISG_LUT_PER_OCTAVE: usize = 4;

/// λ of slice `l`: `2^(octave0 + l / R) (1 + (l mod R) / R)`.
pub fn isg_lut_slice_lambda(octave0: i32, per_octave: usize, l: usize) -> f64 {
    let e = octave0 + (l / per_octave) as i32;
    2f64.powi(e) * (1.0 + (l % per_octave) as f64 / per_octave as f64)
}

/// The two marginals of exact Ŝ at the n table samples of slice λ: (M(θ_i), N(φ_i)).
pub fn isg_lut_marginals(n: usize, lambda: f64) -> (Vec<f64>, Vec<f64>) {
    let (k, _) = lut_warp_consts(lambda);
    let grid: Vec<f64> = (0..n).map(|i| (FRAC_PI_2 + (i as f64 / (n - 1) as f64 - 0.5) / k).clamp(0.0, PI)).collect();
    (isg_exact_grid(lambda, &grid, &[PI]), isg_exact_grid(lambda, &[PI], &grid))
}

impl IsgLut {
    /// The default table (deterministic; regenerating it must reproduce a stored copy bit for bit).
    pub fn generate_default() -> Self {
        Self::generate(ISG_LUT_N, ISG_LUT_OCTAVE0, ISG_LUT_OCTAVES, ISG_LUT_PER_OCTAVE)
    }

    /// A table with `n` samples per marginal and `per_octave` slices per octave over
    /// λ ∈ [2^octave0, 2^(octave0 + octaves)], filled with the marginals of exact Ŝ.
    pub fn generate(n: usize, octave0: i32, octaves: usize, per_octave: usize) -> Self {
        assert!(n >= 2 && octaves >= 1 && per_octave >= 1);
        let slices = octaves * per_octave + 1;
        let marg: Vec<[Vec<f64>; 2]> = (0..slices)
            .map(|l| {
                let (m, nn) = isg_lut_marginals(n, isg_lut_slice_lambda(octave0, per_octave, l));
                [m, nn]
            })
            .collect();
        let mut values = Vec::with_capacity(slices * 2 * n * 4);
        for (l, lo) in marg.iter().enumerate() {
            let hi = &marg[(l + 1).min(slices - 1)];
            for (a, axis) in lo.iter().enumerate() {
                for i in 0..n {
                    values.extend(Self::pack(axis, &hi[a], i).map(|v| v as f32));
                }
            }
        }
        Self { n, octave0, per_octave, slices, values }
    }

    /// Entry i of a packed axis from the marginals of slices l and l + 1.
    pub fn pack(lo: &[f64], hi: &[f64], i: usize) -> [f64; 4] {
        let j = (i + 1).min(lo.len() - 1);
        [lo[i], lo[j], hi[i], hi[j]]
    }

    /// Ŝ(θ, φ; λ) ≈ M(θ) N(φ).
    pub fn eval(&self, theta: f64, phi: f64, lambda: f64) -> f64 {
        let wc = lut_warp_consts(lambda);
        self.at(lut_warp(theta, wc), lut_warp(phi, wc), self.slice(lambda))
    }

    /// Normalized patch integral: the four corners of a separable Ŝ reduce to
    /// `(M(θ1) − M(θ0)) (N(φ1) − N(φ0))` (the twin of `isg_lut_patch` in isg.glsl).
    pub fn patch(&self, theta0: f64, theta1: f64, phi0: f64, phi1: f64, lambda: f64) -> f64 {
        let wc = lut_warp_consts(lambda);
        let fl = self.slice(lambda);
        let (l, tl) = self.split_slice(fl);
        let m = |x: f64, a: usize| self.marginal(lut_warp(x, wc), l, tl, a);
        (m(theta1, 0) - m(theta0, 0)) * (m(phi1, 1) - m(phi0, 1))
    }

    /// Fractional slice position of λ from its exponent and mantissa bits (clamped to the table).
    pub fn slice(&self, lambda: f64) -> f64 {
        let r = self.per_octave;
        let top = self.octave0 + ((self.slices - 1) / r) as i32;
        let pow2 = |e: i32| f64::from_bits(((e + 1023) as u64) << 52);
        let lc = lambda.max(pow2(self.octave0)).min(pow2(top));
        let bits = lc.to_bits();
        let e = ((bits >> 52) & 0x7ff) as i32 - 1023;
        let m = f64::from_bits((bits & ((1u64 << 52) - 1)) | (1023u64 << 52));
        (((e - self.octave0) as usize * r) as f64 + (m - 1.0) * r as f64).min((self.slices - 1) as f64)
    }

    fn split_slice(&self, fl: f64) -> (usize, f64) {
        let l = (fl as usize).min(self.slices - 2);
        (l, fl - l as f64)
    }

    /// Marginal of axis `a` at coordinate s, between slices l and l + 1 at weight tl.
    fn marginal(&self, s: f64, l: usize, tl: f64, a: usize) -> f64 {
        let f = s * (self.n - 1) as f64;
        let i = (f as usize).min(self.n - 2);
        let t = f - i as f64;
        let o = ((l * 2 + a) * self.n + i) * 4;
        let e = &self.values[o..o + 4];
        let (x0, x1) = (e[0] as f64 + (e[1] as f64 - e[0] as f64) * t, e[2] as f64 + (e[3] as f64 - e[2] as f64) * t);
        x0 + (x1 - x0) * tl
    }

    /// Ŝ at table coordinates (s_θ, s_φ) ∈ [0, 1]² and fractional slice `fl`: M(s_θ) N(s_φ).
    pub fn at(&self, st: f64, sp: f64, fl: f64) -> f64 {
        let (l, tl) = self.split_slice(fl);
        self.marginal(st, l, tl, 0) * self.marginal(sp, l, tl, 1)
    }
}

/// Ŝ by our table (see [`IsgLut`]).
pub fn isg_lut(lut: &IsgLut, theta: f64, phi: f64, lambda: f64) -> f64 {
    lut.eval(theta, phi, lambda)
}

/// The paper's fit over a patch: separable, so the four corners reduce to
/// `(σ_θ1 − σ_θ0)(σ_φ1 − σ_φ0)` (4 exponentials; twin of `isg_paper_patch` in isg.glsl).
pub fn isg_paper_patch(theta0: f64, theta1: f64, phi0: f64, phi1: f64, lambda: f64) -> f64 {
    let t = lambda / 100.0;
    let (g, h) = (quartic(&PAPER_G, t), quartic(&PAPER_H, t));
    (sigmoid(g * (theta1 - FRAC_PI_2)) - sigmoid(g * (theta0 - FRAC_PI_2)))
        * (sigmoid(h * (phi1 - FRAC_PI_2)) - sigmoid(h * (phi0 - FRAC_PI_2)))
}

/// Normalized integral over the patch [θ0, θ1] × [φ0, φ1] by the four-corner rule
/// (paper Sec. 4: `S(1,1) − S(0,1) − S(1,0) + S(0,0)`), for any evaluator of Ŝ.
pub fn isg_patch(s_hat: impl Fn(f64, f64) -> f64, theta0: f64, theta1: f64, phi0: f64, phi1: f64) -> f64 {
    s_hat(theta1, phi1) - s_hat(theta0, phi1) - s_hat(theta1, phi0) + s_hat(theta0, phi0)
}

/// Unnormalized patch integral of `exp(λ(v·z − 1))` (multiply by μ for an SG of amplitude μ).
pub fn isg_patch_integral(
    s_hat: impl Fn(f64, f64) -> f64,
    lambda: f64,
    theta0: f64,
    theta1: f64,
    phi0: f64,
    phi1: f64,
) -> f64 {
    isg_normalization(lambda) * isg_patch(s_hat, theta0, theta1, phi0, phi1)
}

/// Max and RMS error of one evaluator against exact Ŝ at one λ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IsgErrorRow {
    pub lambda: f64,
    pub paper_max: f64,
    pub paper_rms: f64,
    pub lut_max: f64,
    pub lut_rms: f64,
}

/// The measurement grid for one λ: 41 uniform angles on [0, π] plus 41 across the transition
/// π/2 ± 4/√λ (without them, a uniform grid would step over the whole lobe for large λ).
pub fn isg_error_grid(lambda: f64) -> Vec<f64> {
    let mut g: Vec<f64> = (0..41).map(|i| PI * i as f64 / 40.0).collect();
    let w = 4.0 / lambda.max(1e-12).sqrt();
    if w < FRAC_PI_2 {
        g.extend((0..41).map(|i| FRAC_PI_2 + w * (i as f64 / 20.0 - 1.0)));
    }
    g.sort_by(f64::total_cmp);
    g.dedup();
    g
}

/// Errors of the paper's fit and of `lut` against exact Ŝ, over [`isg_error_grid`]² for each λ.
pub fn isg_error_table(lut: &IsgLut, lambdas: &[f64]) -> Vec<IsgErrorRow> {
    lambdas
        .iter()
        .map(|&lambda| {
            let g = isg_error_grid(lambda);
            let exact = isg_exact_grid(lambda, &g, &g);
            let (mut pm, mut ps, mut lm, mut ls) = (0.0f64, 0.0, 0.0f64, 0.0);
            for (i, &t) in g.iter().enumerate() {
                for (j, &p) in g.iter().enumerate() {
                    let e = exact[i * g.len() + j];
                    let dp = (isg_paper(t, p, lambda) - e).abs();
                    let dl = (lut.eval(t, p, lambda) - e).abs();
                    pm = pm.max(dp);
                    lm = lm.max(dl);
                    ps += dp * dp;
                    ls += dl * dl;
                }
            }
            let cnt = (g.len() * g.len()) as f64;
            IsgErrorRow { lambda, paper_max: pm, paper_rms: (ps / cnt).sqrt(), lut_max: lm, lut_rms: (ls / cnt).sqrt() }
        })
        .collect()
}

/// The λ values of the report: 0.01, 0.1, …, 1e5.
pub const ISG_REPORT_LAMBDAS: [f64; 8] = [1e-2, 1e-1, 1.0, 1e1, 1e2, 1e3, 1e4, 1e5];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::adaptive_simpson;

    /// Ŝ by nested adaptive Simpson on the raw definition (independent of the GL grid code).
    fn s_hat_simpson(theta: f64, phi: f64, lambda: f64) -> f64 {
        let inner =
            |t: f64| adaptive_simpson(&|p: f64| (lambda * (t.sin() * p.sin() - 1.0)).exp() * t.sin(), 0.0, phi, 1e-13);
        adaptive_simpson(&inner, 0.0, theta, 1e-12) / isg_normalization(lambda)
    }

    #[test]
    fn exact_matches_simpson_and_symmetries() {
        for &lambda in &[0.5, 5.0, 60.0] {
            for &(t, p) in &[(0.7, 2.0), (1.5, 1.7), (2.9, 0.4), (PI, 1.2)] {
                let e = isg_exact(t, p, lambda);
                let r = s_hat_simpson(t, p, lambda);
                // Both are converged quadratures; 1e-9 is the accuracy the brief asks of exact Ŝ.
                assert!((e - r).abs() < 1e-9, "λ={lambda} θ={t} φ={p}: {e} vs {r}");
            }
        }
        for &lambda in &[0.0, 1e-4, 1e-2, 1.0, 100.0, 1e5] {
            let g = [FRAC_PI_2, PI];
            let s = isg_exact_grid(lambda, &g, &g);
            // Ŝ(π, π) = 1 by the normalization; the halves by the mirror symmetries θ → π − θ
            // and φ → π − φ of the integrand. Tolerance: f64 rounding of ~1e5 summed terms.
            assert!((s[3] - 1.0).abs() < 1e-11, "λ={lambda}: total {}", s[3]);
            assert!((s[1] - 0.5).abs() < 1e-11 && (s[2] - 0.5).abs() < 1e-11, "{s:?}");
            assert!((s[0] - 0.25).abs() < 0.25 && s.iter().all(|v| v.is_finite()));
        }
    }

    #[test]
    fn paper_fit_reproduces_figure_3() {
        let lut = IsgLut::generate(4, 0, 1, 1); // unused columns; only the paper fit matters
        let rows = isg_error_table(&lut, &[100.0, 1000.0]);
        // Paper Fig. 3 reports max errors 0.0966 (λ = 100) and 0.0251 (λ = 1000); our grid and
        // the reconstructed frame give 0.098 and 0.0251 (DESIGN §3), so 3e-3 separates a correct
        // frame from a wrong one (a swapped or shifted frame gives errors > 0.2).
        assert!((rows[0].paper_max - 0.0966).abs() < 3e-3, "{:?}", rows[0]);
        assert!((rows[1].paper_max - 0.0251).abs() < 1e-3, "{:?}", rows[1]);
    }

    #[test]
    fn lut_is_accurate_everywhere() {
        let lut = IsgLut::generate_default();
        assert_eq!(lut.values.len(), 109 * 2 * 64 * 4);
        assert_eq!(lut, IsgLut::generate_default(), "generation must be deterministic");
        let rows = isg_error_table(&lut, &[1e-4, 1e-2, 0.3, 3.0, 30.0, 1e3, 1e5, 1e6]);
        for r in &rows {
            // Target of the issue: max |Ŝ_lut − Ŝ| ≤ 0.01 for λ ∈ [1e-2, 1e5]; measured worst
            // 0.005 near λ ≈ 3 (where Ŝ is least separable). The clamped ends (1e-4, 1e6) too.
            assert!(r.lut_max <= 0.01, "{r:?}");
            assert!(r.lut_rms <= 0.003, "{r:?}");
        }
    }

    #[test]
    fn patch_integrals_by_four_corners() {
        let lut = IsgLut::generate_default();
        for &(lambda, t0, t1, p0, p1) in
            &[(2.0, 0.3, 1.2, 1.0, 2.5), (50.0, 1.4, 1.6, 1.5, 1.9), (800.0, 1.55, 1.6, 1.5, 1.58)]
        {
            let direct = adaptive_simpson(
                &|t: f64| {
                    adaptive_simpson(&|p: f64| (lambda * (t.sin() * p.sin() - 1.0)).exp() * t.sin(), p0, p1, 1e-14)
                },
                t0,
                t1,
                1e-13,
            );
            let exact = isg_patch_integral(|t, p| isg_exact(t, p, lambda), lambda, t0, t1, p0, p1);
            // Four-corner rule is exact for the exact Ŝ: agreement to quadrature accuracy.
            assert!((exact - direct).abs() < 1e-9 * isg_normalization(lambda), "{exact} {direct}");
            let approx = isg_patch_integral(|t, p| lut.eval(t, p, lambda), lambda, t0, t1, p0, p1);
            let shared = lut.patch(t0, t1, p0, p1, lambda) * isg_normalization(lambda);
            // Same arithmetic with shared warps: equal to rounding.
            assert!((shared - approx).abs() < 1e-12 * isg_normalization(lambda));
            let paper = isg_paper_patch(t0, t1, p0, p1, lambda);
            let paper4 = isg_patch(|t, p| isg_paper(t, p, lambda), t0, t1, p0, p1);
            assert!((paper - paper4).abs() < 1e-12, "{paper} {paper4}");
            // Four corners each within 0.0087 of Ŝ (0.005 measured): the patch is within 4 × 0.0087.
            assert!((approx - exact).abs() < 0.035 * isg_normalization(lambda), "{approx} {exact}");
        }
    }

    #[test]
    fn hard_cases_are_finite() {
        let lut = IsgLut::generate(8, -10, 27, 1);
        for &lambda in &[0.0, 1e-300, 1e-4, 1e5, 1e7, 1e12] {
            for &(t, p) in &[(0.0, 0.0), (PI, PI), (FRAC_PI_2, FRAC_PI_2), (-1.0, 4.0)] {
                let a = isg_paper(t, p, lambda);
                let b = lut.eval(t, p, lambda);
                assert!(a.is_finite() && b.is_finite(), "λ={lambda}: {a} {b}");
                assert!((-1e-6..=1.0 + 1e-6).contains(&b), "λ={lambda}: {b}");
            }
            assert!(isg_normalization(lambda).is_finite());
        }
        assert!((isg_exact(PI, PI, 1e7) - 1.0).abs() < 1e-9);
    }
}
