//! SH exponentiation (SHEXP paper, Ren et al. 2006, Sec. 4): the visibility vector of many
//! blockers is `g = exp*(f)` of the summed log-visibility `f` (Eq. 8).
//!
//! Methods (paper Sec. 4.3):
//! - **exact**: `exp*(f) = exp(M_f) 1`, the limit of the product series (Eqs. 17, 26–28), by a Jacobi
//!   eigendecomposition of the symmetric product matrix. The reference for every other method.
//! - **PS-p**: the plain product series of degree p (Eq. 17). Diverges in practice for ‖f‖ ≳ 3.
//! - **PS\*-p**: DC isolation (Eq. 20, `exp*(f) = exp(f_0/√(4π)) exp*(f̂)`, note √(4π)), scaling and
//!   squaring (Eq. 21, `s = max(0, ⌊log2 ‖f̂‖⌋ + 3)`) and the even/odd factored series (Eq. 22).
//! - **OL**: optimal linear `exp(f_0/√(4π)) (a(‖f̂‖) 1 + b(‖f̂‖) f̂)` (Eqs. 23–24), with a, b fitted on
//!   circles. DESIGN §3: ‖f̂‖ of one circle grows with its radius only up to ~1.75 rad at n = 4
//!   (1.40 at n = 3, 1.30 at n = 6); the table stops at that radius ([`OlTable`]).
//! - **HYB**: scale f̂ by 2^-s into the accurate range of OL, apply OL, square s times.
//!
//! Judge a method against the exact exponential of the same log vector (DESIGN §3): the exact one
//! still carries the order-n truncation floor with respect to the true visibility.
//!
//! `shaders-glsl/common/shexp.glsl` is the f32 GLSL twin of OL, HYB and PS*-p at order 4.

use crate::linalg::symmetric_eigen;
use crate::rng::Pcg32;
use crate::sh::{circle_log_zonal, norm, one, CircleLogTable, ShTensor, SQRT_4PI};
use std::f64::consts::PI;

/// `f̂`: `f` with its DC coefficient zeroed (paper Eq. 19).
pub fn without_dc(f: &[f64]) -> Vec<f64> {
    let mut h = f.to_vec();
    h[0] = 0.0;
    h
}

/// The DC factor `exp(f_0 / √(4π))` of DC isolation (paper Eq. 20; √(4π), not √(4/π)).
pub fn dc_factor(f: &[f64]) -> f64 {
    (f[0] / SQRT_4PI).exp()
}

/// Exact SH exponential `exp*(f) = exp(M_f) 1 = 1 + V q(D) Vᵀ f` (paper Eqs. 26–29), with the DC
/// factor isolated analytically (`M_1 = I`) so that large `|f_0|` cannot overflow.
pub fn exp_exact(tensor: &ShTensor, f: &[f64]) -> Vec<f64> {
    let c = tensor.len();
    let fh = without_dc(f);
    let m = tensor.product_matrix(&fh);
    let (vals, vecs) = symmetric_eigen(&m, c);
    let dc = dc_factor(f);
    let mut g = vec![0.0; c];
    for (p, &lam) in vals.iter().enumerate() {
        // Vᵀ 1 = √(4π) × row 0 of V.
        let w = lam.exp() * SQRT_4PI * vecs[p] * dc;
        for (i, gi) in g.iter_mut().enumerate() {
            *gi += vecs[i * c + p] * w;
        }
    }
    g
}

/// PS-p: the plain product series of degree `p` (paper Eq. 17), powers amassed left to right.
pub fn exp_ps(tensor: &ShTensor, f: &[f64], p: usize) -> Vec<f64> {
    let c = tensor.len();
    let mut sum = one(tensor.n);
    let mut term = f[..c].to_vec();
    let mut next = vec![0.0; c];
    for k in 1..=p {
        if k > 1 {
            tensor.product_into(&term, f, &mut next);
            let inv = 1.0 / k as f64;
            for (t, x) in term.iter_mut().zip(&next) {
                *t = x * inv;
            }
        }
        for (s, t) in sum.iter_mut().zip(&term) {
            *s += t;
        }
    }
    sum
}

/// Number of squarings of PS*-p (paper Sec. 4.1): `max(0, ⌊log2 ‖f̂‖⌋ + 3)`.
pub fn ps_star_squarings(norm_fhat: f64) -> u32 {
    if norm_fhat.is_nan() || norm_fhat <= 0.0 || !norm_fhat.is_finite() {
        return 0;
    }
    (norm_fhat.log2().floor() + 3.0).max(0.0) as u32
}

/// Even/odd factored product series of degree `p` (paper Eq. 22) of a DC-free vector `x`:
/// `(1 + x²/2! + x⁴/4! + …) + x/1! + x * (x²/3! + x⁴/5! + …)` with `x^{2j}` built as
/// `x² = x*x`, `x⁴ = x²*x²`, `x^{2j} = x^{2j−2} * x²`.
fn factored_series(tensor: &ShTensor, x: &[f64], p: usize) -> Vec<f64> {
    let c = tensor.len();
    let mut even = one(tensor.n);
    if p == 0 {
        return even;
    }
    let mut odd_rest = vec![0.0; c];
    let mut fact = 1.0;
    let x2 = if p >= 2 { tensor.square(x) } else { vec![0.0; c] };
    let mut pow = x2.clone(); // x^{2j}, j = 1
    for k in 2..=p {
        fact *= k as f64;
        if k % 2 == 0 {
            if k > 2 {
                pow = if k == 4 { tensor.square(&x2) } else { tensor.product(&pow, &x2) };
            }
            for (e, v) in even.iter_mut().zip(&pow) {
                *e += v / fact;
            }
        } else {
            // Odd k uses x^{k−1}, the even power built at step k − 1.
            for (o, v) in odd_rest.iter_mut().zip(&pow) {
                *o += v / fact;
            }
        }
    }
    let mut out = even;
    for (o, v) in out.iter_mut().zip(x) {
        *o += v;
    }
    if p >= 3 {
        let xo = tensor.product(x, &odd_rest);
        for (o, v) in out.iter_mut().zip(&xo) {
            *o += v;
        }
    }
    out
}

/// Square `g` in place `s` times (paper Eq. 21, `f^{2^p*} = f^{2^{p−1}*} * f^{2^{p−1}*}`).
fn square_repeatedly(tensor: &ShTensor, g: &mut Vec<f64>, s: u32) {
    let mut tmp = vec![0.0; g.len()];
    for _ in 0..s {
        tensor.square_into(g, &mut tmp);
        std::mem::swap(g, &mut tmp);
    }
}

/// PS*-p: DC isolation + scaling/squaring + even/odd factored series of degree `p`
/// (paper Sec. 4.3).
pub fn exp_ps_star(tensor: &ShTensor, f: &[f64], p: usize) -> Vec<f64> {
    let fh = without_dc(f);
    let s = ps_star_squarings(norm(&fh));
    let scale = 0.5f64.powi(s as i32);
    let x: Vec<f64> = fh.iter().map(|v| v * scale).collect();
    let mut g = factored_series(tensor, &x, p);
    square_repeatedly(tensor, &mut g, s);
    let dc = dc_factor(f);
    g.iter_mut().for_each(|v| *v *= dc);
    g
}

/// Radius (rad) up to which ‖f̂‖ of a single circle's log grows with the radius, found on a grid
/// of step `step` over (0, π]: the first sample where it decreases ends the range (DESIGN §3:
/// ~1.75 at n = 4, 1.40 at n = 3, 1.30 at n = 6). Past it, eigenvalue clipping in the log makes
/// the map from radius to ‖f̂‖ non-invertible.
pub fn circle_norm_monotone_limit(tensor: &ShTensor, step: f64) -> f64 {
    let fhat_norm = |theta: f64| {
        let z = circle_log_zonal(tensor, theta);
        z[1..].iter().map(|v| v * v).sum::<f64>().sqrt()
    };
    let mut prev = 0.0;
    let mut theta = step;
    while theta <= PI {
        let v = fhat_norm(theta);
        if v < prev {
            return theta - step;
        }
        prev = v;
        theta += step;
    }
    PI
}

/// Number of θ samples of the OL fit.
pub const OL_TABLE_SAMPLES: usize = 256;

/// The OL coefficients `a(‖f̂‖)`, `b(‖f̂‖)` (paper Eq. 24) fitted on circles of radius
/// `θ ∈ [0, θ_stop]`, `θ_stop` = [`circle_norm_monotone_limit`]. For each circle, `f` is its log
/// (eigen method) and the target is the exact exponential `ĝ = exp*(f̂)`: the fit then measures
/// only the linear model's error, and OL is judged against the exact exponential of the same log
/// (the paper fits the projected visibility instead, which mixes in the log/exp round trip).
#[derive(Clone, Debug)]
pub struct OlTable {
    pub n: usize,
    /// Largest radius of the fit.
    pub theta_stop: f64,
    /// Increasing ‖f̂‖ of the fitted circles, starting at 0.
    pub norms: Vec<f64>,
    pub a: Vec<f64>,
    pub b: Vec<f64>,
}

impl OlTable {
    pub fn new(tensor: &ShTensor) -> Self {
        let n = tensor.n;
        let c = tensor.len();
        // Coarse step is enough for the limit (the table need only stay in the monotone part).
        let theta_stop = circle_norm_monotone_limit(tensor, 0.01);
        let (mut norms, mut a, mut b) = (vec![0.0], vec![1.0], vec![1.0]);
        for s in 1..OL_TABLE_SAMPLES {
            let theta = theta_stop * s as f64 / (OL_TABLE_SAMPLES - 1) as f64;
            let z = circle_log_zonal(tensor, theta);
            let mut fh = vec![0.0; c];
            for l in 1..n {
                fh[l * l + l] = z[l];
            }
            let nf = norm(&fh);
            if nf <= *norms.last().unwrap_or(&0.0) {
                continue;
            }
            let g = exp_exact(tensor, &fh);
            a.push(g[0] / SQRT_4PI);
            b.push(crate::sh::dot(&g, &fh) / (nf * nf));
            norms.push(nf);
        }
        Self { n, theta_stop, norms, a, b }
    }

    /// Largest tabulated ‖f̂‖.
    pub fn norm_max(&self) -> f64 {
        *self.norms.last().unwrap_or(&0.0)
    }

    /// `(a, b)` at ‖f̂‖ by linear interpolation; clamped to the last entry beyond the table
    /// (OL is not accurate there: use HYB).
    pub fn lookup(&self, norm_fhat: f64) -> (f64, f64) {
        let x = if norm_fhat.is_finite() { norm_fhat.max(0.0) } else { self.norm_max() };
        let k = self.norms.partition_point(|&v| v <= x);
        if k >= self.norms.len() {
            return (*self.a.last().unwrap_or(&1.0), *self.b.last().unwrap_or(&1.0));
        }
        let k0 = k.max(1) - 1;
        let k1 = k0 + 1;
        let w = (x - self.norms[k0]) / (self.norms[k1] - self.norms[k0]);
        (self.a[k0] + w * (self.a[k1] - self.a[k0]), self.b[k0] + w * (self.b[k1] - self.b[k0]))
    }

    /// The table resampled at `count ≥ 2` points uniform in ‖f̂‖ over `[0, norm_max]`: the layout
    /// of the GPU table (`shaders-glsl/common/shexp.glsl`), so that [`exp_ol`] with the result is
    /// the exact f64 twin of the shader's OL.
    pub fn resampled(&self, count: usize) -> OlTable {
        let count = count.max(2);
        let nm = self.norm_max();
        let norms: Vec<f64> = (0..count).map(|s| nm * s as f64 / (count - 1) as f64).collect();
        let (a, b) = norms.iter().map(|&x| self.lookup(x)).unzip();
        OlTable { n: self.n, theta_stop: self.theta_stop, norms, a, b }
    }
}

/// OL (paper Eq. 23): `exp(f_0/√(4π)) (a(‖f̂‖) 1 + b(‖f̂‖) f̂)`.
pub fn exp_ol(table: &OlTable, f: &[f64]) -> Vec<f64> {
    let fh = without_dc(f);
    let (a, b) = table.lookup(norm(&fh));
    let dc = dc_factor(f);
    let mut g: Vec<f64> = fh.iter().map(|v| dc * b * v).collect();
    g[0] = dc * a * SQRT_4PI;
    g
}

/// Number of squarings of HYB: the least `s` with `‖f̂‖ / 2^s ≤ target`.
pub fn hyb_squarings(norm_fhat: f64, target: f64) -> u32 {
    if norm_fhat.is_nan() || norm_fhat <= target || !norm_fhat.is_finite() {
        return 0;
    }
    (norm_fhat / target).log2().ceil().max(0.0) as u32
}

/// HYB (paper Sec. 4.3): scale f̂ by 2^-s so that its norm is at most `target`, OL, square s times.
pub fn exp_hyb(tensor: &ShTensor, table: &OlTable, f: &[f64], target: f64) -> Vec<f64> {
    let fh = without_dc(f);
    let s = hyb_squarings(norm(&fh), target);
    let scale = 0.5f64.powi(s as i32);
    let x: Vec<f64> = fh.iter().map(|v| v * scale).collect();
    let mut g = exp_ol(table, &x);
    square_repeatedly(tensor, &mut g, s);
    let dc = dc_factor(f);
    g.iter_mut().for_each(|v| *v *= dc);
    g
}

/// Default HYB target norm: OL's error grows quickly with ‖f̂‖ while each squaring adds a
/// truncation error. Measured with [`exp_error_table`] (3000 random blocker sets, ‖f̂‖ up to 34)
/// over targets {0.25, 0.5, 1, 2}: 0.25 had the lowest mean error in every ‖f̂‖ bin at n = 6 and in
/// all but the bins above 8 at n = 4 (where 0.5 is ~20 % better). 0.25 is also PS*'s scaled range.
pub const HYB_DEFAULT_TARGET: f64 = 0.25;

/// An SH exponentiation method (paper Sec. 4.3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ExpMethod {
    Exact,
    /// Plain product series of this degree.
    Ps(usize),
    /// DC isolation + scaling/squaring + factored series of this degree.
    PsStar(usize),
    Ol,
    /// HYB with this target ‖f̂‖ after scaling.
    Hyb(f64),
}

impl ExpMethod {
    pub fn label(&self) -> String {
        match self {
            ExpMethod::Exact => "exact".into(),
            ExpMethod::Ps(p) => format!("PS-{p}"),
            ExpMethod::PsStar(p) => format!("PS*-{p}"),
            ExpMethod::Ol => "OL".into(),
            ExpMethod::Hyb(t) => format!("HYB(t={t})"),
        }
    }
}

/// Everything the SH exponential of order `n` needs: Γ, the circle log table, the OL table.
#[derive(Clone, Debug)]
pub struct ShExp {
    pub tensor: ShTensor,
    pub circles: CircleLogTable,
    pub ol: OlTable,
}

impl ShExp {
    pub fn new(n: usize) -> Self {
        let tensor = ShTensor::new(n);
        let circles = CircleLogTable::new(&tensor);
        let ol = OlTable::new(&tensor);
        Self { tensor, circles, ol }
    }

    pub fn n(&self) -> usize {
        self.tensor.n
    }

    /// `exp*(f)` by `method`.
    pub fn exp(&self, f: &[f64], method: ExpMethod) -> Vec<f64> {
        match method {
            ExpMethod::Exact => exp_exact(&self.tensor, f),
            ExpMethod::Ps(p) => exp_ps(&self.tensor, f, p),
            ExpMethod::PsStar(p) => exp_ps_star(&self.tensor, f, p),
            ExpMethod::Ol => exp_ol(&self.ol, f),
            ExpMethod::Hyb(t) => exp_hyb(&self.tensor, &self.ol, f, t),
        }
    }

    /// Log-visibility of a random cluster of `k` circular blockers: axes within 0.7 rad of +z
    /// (so they overlap), radii uniform in [0.05, 0.6] rad, summed in log space (paper Eq. 8).
    pub fn random_blocker_log(&self, rng: &mut Pcg32, k: usize) -> Vec<f64> {
        let c = self.tensor.len();
        let mut f = vec![0.0; c];
        for _ in 0..k {
            let cz = rng.uniform(0.7f64.cos(), 1.0);
            let phi = rng.uniform(0.0, 2.0 * PI);
            let r = (1.0 - cz * cz).sqrt();
            let axis = [r * phi.cos(), r * phi.sin(), cz];
            let theta = rng.uniform(0.05, 0.6);
            for (a, b) in f.iter_mut().zip(self.circles.log_visibility(theta, axis)) {
                *a += b;
            }
        }
        f
    }
}

/// Relative L2 error `‖g − g_ref‖ / ‖g_ref‖` (0 when both vanish).
pub fn relative_error(g: &[f64], g_ref: &[f64]) -> f64 {
    let d: f64 = g.iter().zip(g_ref).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
    let r = norm(g_ref);
    if r > 0.0 {
        d / r
    } else {
        d
    }
}

/// Error statistics of one method in one ‖f̂‖ bin.
#[derive(Clone, Debug, PartialEq)]
pub struct ExpErrorStats {
    pub method: ExpMethod,
    /// Bin `[norm_lo, norm_hi)` of ‖f̂‖.
    pub norm_lo: f64,
    pub norm_hi: f64,
    pub count: usize,
    /// Mean and max of the relative L2 error against [`exp_exact`].
    pub mean_rel: f64,
    pub max_rel: f64,
}

/// Error of each method against the exact exponential as a function of ‖f̂‖: `scenes` random
/// log vectors (1..=`max_blockers` overlapping circles each, [`ShExp::random_blocker_log`],
/// seeded), binned by ‖f̂‖ into bins of width `bin_width` (bins with no sample are omitted).
/// Returns one row per (bin, method), bins ascending, methods in the given order.
pub fn exp_error_table(
    ctx: &ShExp,
    methods: &[ExpMethod],
    scenes: usize,
    max_blockers: usize,
    bin_width: f64,
    seed: u64,
) -> Vec<ExpErrorStats> {
    let mut rng = Pcg32::new(seed, 0x5e);
    // (bin, method) → (count, sum, max)
    let mut acc: std::collections::BTreeMap<(usize, usize), (usize, f64, f64)> = std::collections::BTreeMap::new();
    for _ in 0..scenes {
        let k = 1 + (rng.next_u32() as usize) % max_blockers.max(1);
        let f = ctx.random_blocker_log(&mut rng, k);
        let nf = norm(&without_dc(&f));
        let bin = (nf / bin_width).floor() as usize;
        let exact = ctx.exp(&f, ExpMethod::Exact);
        for (mi, &m) in methods.iter().enumerate() {
            let e = relative_error(&ctx.exp(&f, m), &exact);
            let entry = acc.entry((bin, mi)).or_insert((0, 0.0, 0.0));
            entry.0 += 1;
            entry.1 += e;
            entry.2 = if e.is_nan() { f64::NAN } else { entry.2.max(e) };
        }
    }
    acc.into_iter()
        .map(|((bin, mi), (count, sum, max))| ExpErrorStats {
            method: methods[mi],
            norm_lo: bin as f64 * bin_width,
            norm_hi: (bin + 1) as f64 * bin_width,
            count,
            mean_rel: sum / count as f64,
            max_rel: max,
        })
        .collect()
}

/// [`exp_error_table`] as a Markdown table (rows: ‖f̂‖ bins; columns: mean / max relative error
/// per method), for reports.
pub fn exp_error_markdown(rows: &[ExpErrorStats], methods: &[ExpMethod]) -> String {
    let mut s = String::from("| ‖f̂‖ | n |");
    for m in methods {
        s += &format!(" {} mean / max |", m.label());
    }
    s += "\n|---|---|";
    for _ in methods {
        s += "---|";
    }
    s += "\n";
    for chunk in rows.chunks(methods.len()) {
        s += &format!("| {:.0}–{:.0} | {} |", chunk[0].norm_lo, chunk[0].norm_hi, chunk[0].count);
        for r in chunk {
            s += &format!(" {:.1e} / {:.1e} |", r.mean_rel, r.max_rel);
        }
        s += "\n";
    }
    s
}

/// Number of OL samples in the GPU table of `shaders-glsl/common/shexp.glsl`.
pub const GLSL_OL_SAMPLES: usize = 64;

/// The generated block of `shaders-glsl/common/shexp.glsl` for order 4: the sparse Γ (entries
/// `j ≤ k`, packed `i | j << 8 | k << 16`, values halved on `j == k` as in [`ShTensor`]) and the OL
/// table resampled uniformly in ‖f̂‖ ([`OlTable::resampled`]). A test checks that the shader holds
/// exactly this text (drift check); regenerate with the ignored test `print_glsl_tables`.
pub fn glsl_order4_tables(ctx: &ShExp) -> String {
    assert_eq!(ctx.n(), 4, "the GLSL twin is order 4");
    let t = &ctx.tensor;
    let f32s = |v: f64| format!("{:.8e}", v as f32);
    let mut s = String::from("// BEGIN GENERATED (engine-math shexp::glsl_order4_tables)\n");
    s += &format!("const int SH4_GAMMA_COUNT = {};\n", t.entries.len());
    s += &format!("const uint SH4_GAMMA_IJK[{}] = uint[](", t.entries.len());
    for (q, e) in t.entries.iter().enumerate() {
        if q % 8 == 0 {
            s += "\n   ";
        }
        let packed = e.i as u32 | (e.j as u32) << 8 | (e.k as u32) << 16;
        s += &format!(" {packed}u{}", if q + 1 < t.entries.len() { "," } else { "" });
    }
    s += ");\n";
    s += &format!("const float SH4_GAMMA_V[{}] = float[](", t.entries.len());
    for (q, e) in t.entries.iter().enumerate() {
        if q % 6 == 0 {
            s += "\n   ";
        }
        s += &format!(" {}{}", f32s(e.v), if q + 1 < t.entries.len() { "," } else { "" });
    }
    s += ");\n";
    let ol = ctx.ol.resampled(GLSL_OL_SAMPLES);
    s += &format!("const int SH4_OL_COUNT = {GLSL_OL_SAMPLES};\n");
    s += &format!("const float SH4_OL_NORM_MAX = {};\n", f32s(ol.norm_max()));
    for (name, v) in [("SH4_OL_A", &ol.a), ("SH4_OL_B", &ol.b)] {
        s += &format!("const float {name}[{GLSL_OL_SAMPLES}] = float[](");
        for (q, x) in v.iter().enumerate() {
            if q % 6 == 0 {
                s += "\n   ";
            }
            s += &format!(" {}{}", f32s(*x), if q + 1 < v.len() { "," } else { "" });
        }
        s += ");\n";
    }
    s += "// END GENERATED\n";
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::{project_function, reconstruct, zh_rotate};

    fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
    }

    /// The circle log (sh/log.rs, eigen method) round-trips through the exact exponential. No clipping
    /// for a small circle: the log is exactly log(M_g)·1, so M_f = log(M_g) and the exact
    /// exponential gives back g up to the non-commutation of truncated products.
    #[test]
    fn circle_log_round_trips_through_exact_exp() {
        let n = 4;
        let t = ShTensor::new(n);
        let theta = 0.3;
        let g = crate::sh::circle_visibility(n, theta, [0.0, 0.0, 1.0]);
        let f = zh_rotate(&circle_log_zonal(&t, theta), [0.0, 0.0, 1.0]);
        let back = exp_exact(&t, &f);
        let err = norm(&back.iter().zip(&g).map(|(a, b)| a - b).collect::<Vec<_>>()) / norm(&g);
        // Measured ~1e-3: M_{log g} ≠ log(M_g) because products are truncated at order n.
        assert!(err < 5e-3, "round trip {err}");
    }

    #[test]
    fn exact_exp_matches_series_and_limits() {
        let t = ShTensor::new(4);
        let mut rng = Pcg32::new(21, 1);
        let f: Vec<f64> = (0..16).map(|_| rng.uniform(-0.3, 0.3)).collect();
        // Small ‖f‖ ≈ 0.7: PS-30 converges to exp(M_f) 1 to rounding (terms < 0.7^30/30!).
        let ex = exp_exact(&t, &f);
        assert!(max_abs_diff(&ex, &exp_ps(&t, &f, 30)) < 1e-13);
        // exp(0) = 1; a DC-only f is exp(c)·1 exactly.
        assert!(max_abs_diff(&exp_exact(&t, &[0.0; 16]), &one(4)) < 1e-15);
        let mut dc = vec![0.0; 16];
        dc[0] = -3.0 * SQRT_4PI;
        let want: Vec<f64> = one(4).iter().map(|v| v * (-3.0f64).exp()).collect();
        assert!(max_abs_diff(&exp_exact(&t, &dc), &want) < 1e-15);
        // Order 1 is scalar: exp*(f) = exp(f_0/√(4π)) √(4π).
        let t1 = ShTensor::new(1);
        assert!((exp_exact(&t1, &[0.7])[0] - (0.7 / SQRT_4PI).exp() * SQRT_4PI).abs() < 1e-14);
    }

    #[test]
    fn exact_exp_of_band_one_matches_pointwise_exp_at_high_order() {
        // Independent of Γ: for f = c·y_10 (a linear function), exp(f(s)) projected by quadrature
        // onto low bands vs the exact exp* at order 8 restricted to bands < 3. The truncation
        // at order 8 of exp(M_f) affects low bands only through high powers: with ‖f‖ = 1 the
        // difference is ~1e-6 (measured 2e-7).
        let n = crate::sh::MAX_ORDER;
        let t = ShTensor::new(n);
        let mut f = vec![0.0; n * n];
        f[2] = 1.0;
        let ex = exp_exact(&t, &f);
        let want = project_function(3, |d| reconstruct(n, &f, d).exp(), 24, 8);
        for i in 0..9 {
            assert!((ex[i] - want[i]).abs() < 5e-6, "i={i}: {} vs {}", ex[i], want[i]);
        }
    }

    #[test]
    fn approximations_agree_with_exact_where_they_should() {
        let ctx = ShExp::new(4);
        let mut rng = Pcg32::new(99, 4);
        // Small blocker sets: ‖f̂‖ within the OL domain.
        for _ in 0..20 {
            let f = ctx.random_blocker_log(&mut rng, 2);
            let nf = norm(&without_dc(&f));
            let ex = exp_exact(&ctx.tensor, &f);
            // PS*-8: scaled input norm ≤ 1/4, series truncation (1/4)^9/9! ≈ 1e-11, then ≤ 3
            // squarings each truncating at order n: measured ≤ 1e-2 relative; bound 5e-2.
            let e_ps = relative_error(&exp_ps_star(&ctx.tensor, &f, 8), &ex);
            assert!(e_ps < 5e-2, "PS*-8 {e_ps} at ‖f̂‖={nf}");
            // HYB and OL within the OL domain: measured ≤ 2e-2; bound 5e-2.
            let e_h = relative_error(&exp_hyb(&ctx.tensor, &ctx.ol, &f, HYB_DEFAULT_TARGET), &ex);
            assert!(e_h < 5e-2, "HYB {e_h} at ‖f̂‖={nf}");
            if nf < ctx.ol.norm_max() {
                let e_ol = relative_error(&exp_ol(&ctx.ol, &f), &ex);
                assert!(e_ol < 5e-2, "OL {e_ol} at ‖f̂‖={nf}");
            }
        }
        // On the circles it was fitted on, OL leaves only the linear model's residual. Within the
        // paper's accurate domain (‖f̂‖ < 4.8 at n = 4, θ ≲ 0.9) that is small; near the end of the
        // table (θ = 1.64, ‖f̂‖ ≈ 6.6) it grows to 15 % (measured), which is why HYB scales first.
        for &theta in &[0.2, 0.5, 0.8] {
            let z = circle_log_zonal(&ctx.tensor, theta);
            let f = zh_rotate(&z, [0.6, 0.0, 0.8]);
            let ex = exp_exact(&ctx.tensor, &f);
            let g = exp_ol(&ctx.ol, &f);
            // The fitted residual ĝ − (a 1 + b f̂) is what remains (the linear model's floor):
            // measured 3.2e-2 at θ = 0.8, n = 4; bound 5e-2.
            assert!(relative_error(&g, &ex) < 5e-2, "θ={theta}: {}", relative_error(&g, &ex));
        }
        // Very small ‖f̂‖: all methods agree to second order.
        let f: Vec<f64> = (0..16).map(|i| if i == 0 { -0.1 } else { 1e-4 * i as f64 }).collect();
        let ex = exp_exact(&ctx.tensor, &f);
        for m in [ExpMethod::Ps(4), ExpMethod::PsStar(2), ExpMethod::Ol, ExpMethod::Hyb(1.0)] {
            // Errors O(‖f̂‖²) ≈ 1e-6 relative.
            assert!(relative_error(&ctx.exp(&f, m), &ex) < 1e-5, "{m:?}");
        }
    }

    #[test]
    fn monotone_limit_and_ol_table() {
        // DESIGN §3: about 1.40 rad at n = 3, 1.75 at n = 4, 1.30 at n = 6 (rounded values; we
        // measure 1.40, 1.73, 1.28 on a 0.01 rad grid): ±0.03.
        for (n, want) in [(3, 1.40), (4, 1.75), (6, 1.30)] {
            let t = ShTensor::new(n);
            let lim = circle_norm_monotone_limit(&t, 0.01);
            assert!((lim - want).abs() <= 0.03 + 1e-9, "n={n}: {lim}");
        }
        let ctx = ShExp::new(4);
        let tab = &ctx.ol;
        assert!(tab.norms.windows(2).all(|w| w[1] > w[0]));
        assert_eq!(tab.lookup(0.0), (1.0, 1.0));
        let (a, b) = tab.lookup(1e9);
        assert!(a.is_finite() && b.is_finite());
        // a ≥ 1: the mean of exp(f̂) over the sphere is at least exp(mean f̂) = 1 (Jensen, for the
        // spectrum of M_f̂ too); b > 0 along the whole table.
        assert!(tab.a.iter().all(|&a| a >= 1.0 - 1e-12 && a.is_finite()));
        assert!(tab.b.iter().all(|&b| b > 0.0));
    }

    #[test]
    fn hard_cases_large_norm_tiny_blockers_inside() {
        let ctx = ShExp::new(4);
        let mut rng = Pcg32::new(1234, 8);
        // Many overlapping blockers: ‖f̂‖ well past 20.
        let f = ctx.random_blocker_log(&mut rng, 100);
        let nf = norm(&without_dc(&f));
        assert!(nf > 20.0, "‖f̂‖ = {nf}");
        let ex = exp_exact(&ctx.tensor, &f);
        assert!(ex.iter().all(|v| v.is_finite()));
        for m in [ExpMethod::Ps(10), ExpMethod::PsStar(2), ExpMethod::PsStar(6), ExpMethod::Ol, ExpMethod::Hyb(1.0)] {
            let g = ctx.exp(&f, m);
            assert!(g.iter().all(|v| v.is_finite()), "{m:?} not finite at ‖f̂‖={nf}");
        }
        // Scaled methods remain usable relative to the DC of the unblocked part: the visibility
        // averaged over the sphere (g_0/√(4π)) is within 0.05 of the exact one. Measured ≤ 0.02.
        let avg = |g: &[f64]| g[0] / SQRT_4PI;
        for m in [ExpMethod::PsStar(6), ExpMethod::Hyb(1.0)] {
            let g = ctx.exp(&f, m);
            assert!((avg(&g) - avg(&ex)).abs() < 0.05, "{m:?}: {} vs {}", avg(&g), avg(&ex));
        }
        // PS-p (no scaling) diverges at large norm: its error is huge (DESIGN §3: ‖f̂‖ ≳ 3).
        assert!(relative_error(&exp_ps(&ctx.tensor, &f, 10), &ex) > 10.0);
        // Tiny blockers: θ = 1e-4 gives f ≈ 0 and every method returns ≈ 1.
        let f = ctx.circles.log_visibility(1e-4, [0.0, 1.0, 0.0]);
        for m in [ExpMethod::Exact, ExpMethod::PsStar(2), ExpMethod::Ol, ExpMethod::Hyb(1.0)] {
            let g = ctx.exp(&f, m);
            assert!(relative_error(&g, &one(4)) < 1e-6, "{m:?}");
        }
        // Receiver inside a blocker: half-space log, θ beyond π/2 clamped to it by the table;
        // the exact exp gives about half visibility on average (measured 0.5 ± 0.05).
        let f = ctx.circles.sphere_log_visibility([0.0; 3], [0.0, 0.0, 0.5], 1.0);
        let g = exp_exact(&ctx.tensor, &f);
        assert!((avg(&g) - 0.5).abs() < 0.1, "inside: {}", avg(&g));
        for m in [ExpMethod::PsStar(2), ExpMethod::Hyb(1.0), ExpMethod::Ol] {
            assert!(ctx.exp(&f, m).iter().all(|v| v.is_finite()));
        }
        // Non-finite input stays non-panicking.
        let mut bad = vec![0.0; 16];
        bad[3] = f64::NAN;
        let _ = ctx.exp(&bad, ExpMethod::Hyb(1.0));
        let _ = ctx.exp(&bad, ExpMethod::PsStar(2));
    }

    #[test]
    fn error_table_shape() {
        let ctx = ShExp::new(3);
        let methods = [ExpMethod::PsStar(2), ExpMethod::Ol];
        let rows = exp_error_table(&ctx, &methods, 30, 8, 2.0, 5);
        assert!(!rows.is_empty() && rows.len().is_multiple_of(2));
        assert!(rows.iter().all(|r| r.count > 0 && r.mean_rel <= r.max_rel && r.mean_rel.is_finite()));
        let md = exp_error_markdown(&rows, &methods);
        assert!(md.contains("PS*-2") && md.lines().count() == 2 + rows.len() / 2);
    }

    #[test]
    fn glsl_tables_match_generated() {
        let ctx = ShExp::new(4);
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shaders-glsl/common/shexp.glsl");
        let text = std::fs::read_to_string(path).expect("shaders-glsl/common/shexp.glsl");
        assert!(
            text.contains(&glsl_order4_tables(&ctx)),
            "shexp.glsl tables drifted from sh/ and shexp.rs: regenerate with print_glsl_tables"
        );
        // The resampled OL table is the one the shader interpolates: uniform grid, same ends.
        let r = ctx.ol.resampled(GLSL_OL_SAMPLES);
        assert_eq!(r.norms.len(), GLSL_OL_SAMPLES);
        assert!((r.norm_max() - ctx.ol.norm_max()).abs() < 1e-12);
        assert_eq!((r.a[0], r.b[0]), (1.0, 1.0));
    }

    #[test]
    #[ignore]
    fn print_glsl_tables() {
        print!("{}", glsl_order4_tables(&ShExp::new(4)));
    }

    /// Measurements for the report (run with
    /// `cargo test --release -p engine-math shexp::tests::report -- --ignored --nocapture`).
    #[test]
    #[ignore]
    fn report() {
        for n in [4, 6] {
            let ctx = ShExp::new(n);
            println!("n={n}: OL table θ_stop={:.3}, ‖f̂‖max={:.3}", ctx.ol.theta_stop, ctx.ol.norm_max());
            let methods = [
                ExpMethod::Ps(4),
                ExpMethod::Ps(10),
                ExpMethod::PsStar(2),
                ExpMethod::PsStar(4),
                ExpMethod::Ol,
                ExpMethod::Hyb(0.5),
                ExpMethod::Hyb(1.0),
                ExpMethod::Hyb(0.25),
                ExpMethod::Hyb(2.0),
            ];
            let rows = exp_error_table(&ctx, &methods, 3000, 40, 2.0, 77);
            println!("{}", exp_error_markdown(&rows, &methods));
            // Timings of product and square.
            let mut rng = Pcg32::new(1, 1);
            let a: Vec<f64> = (0..n * n).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let b: Vec<f64> = (0..n * n).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let mut out = vec![0.0; n * n];
            let iters = 200_000;
            let t0 = std::time::Instant::now();
            for _ in 0..iters {
                ctx.tensor.product_into(std::hint::black_box(&a), &b, &mut out);
                std::hint::black_box(&out);
            }
            let tp = t0.elapsed().as_secs_f64() / iters as f64;
            let t0 = std::time::Instant::now();
            for _ in 0..iters {
                ctx.tensor.square_into(std::hint::black_box(&a), &mut out);
                std::hint::black_box(&out);
            }
            let ts = t0.elapsed().as_secs_f64() / iters as f64;
            let f = ctx.random_blocker_log(&mut rng, 10);
            let mut times = Vec::new();
            for m in [ExpMethod::Exact, ExpMethod::PsStar(2), ExpMethod::Ol, ExpMethod::Hyb(1.0)] {
                let it = if m == ExpMethod::Exact { 200 } else { 20_000 };
                let t0 = std::time::Instant::now();
                for _ in 0..it {
                    std::hint::black_box(ctx.exp(std::hint::black_box(&f), m));
                }
                times.push(format!("{} {:.2} µs", m.label(), t0.elapsed().as_secs_f64() / it as f64 * 1e6));
            }
            println!(
                "n={n}: {} stored entries, product {:.1} ns, square {:.1} ns; exp: {}",
                ctx.tensor.entries.len(),
                tp * 1e9,
                ts * 1e9,
                times.join(", ")
            );
        }
    }
}
