//! Real spherical harmonics: basis, projection, triple-product tensor, products, zonal rotation,
//! circle (sphere-blocker) visibility and its log (SHEXP paper, Ren et al. 2006, Sec. 3, 5, 6.1, 7).
//!
//! Conventions (DESIGN.md §3):
//! - Real, orthonormal basis; order `n` means bands `l = 0..n-1`, `n²` coefficients, index
//!   `i = l² + l + m`. The polar axis of the basis is +z (`cos θ = z`, `φ = atan2(y, x)`); this is a
//!   choice of basis only: every operation here is rotation-covariant, and directions follow the
//!   engine's Y-up convention through `engine_math::envmap`.
//! - No Condon–Shortley phase: `y_1,-1 = K y`, `y_10 = K z`, `y_11 = K x` with `K = √(3/4π)`
//!   (Ramamoorthi & Hanrahan 2001). `y_l,m>0 ∝ cos(mφ)`, `y_l,m<0 ∝ sin(|m|φ)`.
//! - The constant function 1 is `(√(4π), 0, …)` (paper Eq. 12).
//! - Orders up to [`MAX_ORDER`] = 8.
//!
//! `shaders-glsl/common/sh.glsl` is the f32 GLSL twin of the evaluation, ZH rotation and dot product.

use crate::envmap::{texel_solid_angle, LatLongMap};
use crate::linalg::{spectral_apply, symmetric_eigen};
use crate::quadrature::gauss_legendre;
use std::f64::consts::PI;

/// Highest supported SH order (bands 0..7, 64 coefficients): the DESIGN §3 counts go to n = 8.
pub const MAX_ORDER: usize = 8;

/// √(4π): the DC coefficient of the constant function 1.
pub const SQRT_4PI: f64 = 3.544_907_701_811_032;

/// Number of coefficients of an order-`n` SH vector.
pub const fn num_coeffs(n: usize) -> usize {
    n * n
}

/// Flat index of (l, m), `|m| ≤ l`.
pub fn sh_index(l: usize, m: i32) -> usize {
    debug_assert!(m.unsigned_abs() as usize <= l);
    ((l * l + l) as i64 + m as i64) as usize
}

/// Band `l` and order `m` of flat index `i`.
pub fn sh_lm(i: usize) -> (usize, i32) {
    let l = (i as f64).sqrt().floor() as usize;
    // Guard against sqrt rounding for perfect squares.
    let l = if (l + 1) * (l + 1) <= i {
        l + 1
    } else if l * l > i {
        l - 1
    } else {
        l
    };
    (l, i as i32 - (l * l + l) as i32)
}

/// The constant function 1 as an order-`n` vector: `(√(4π), 0, …)`.
pub fn one(n: usize) -> Vec<f64> {
    let mut v = vec![0.0; n * n];
    v[0] = SQRT_4PI;
    v
}

/// Euclidean dot product of two SH vectors: `∫ f̃ g̃` over the sphere (orthonormal basis).
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Euclidean norm `‖f‖`.
pub fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// Evaluate the order-`n` basis at direction `d` (normalized here; a zero vector gives +z) into
/// `out[..n²]`.
///
/// Uses the normalized associated-Legendre recurrences on `Q_l^m = K_lm P_l^m(z) / sin^m θ`
/// together with `C_m + i S_m = (x + i y)^m = sin^m θ e^{imφ}`, so there are no factorials (no
/// overflow at any order) and no trigonometric calls:
/// `Q_m^m = Q_{m-1}^{m-1} √((2m+1)/(2m))`, `Q_{m+1}^m = z √(2m+3) Q_m^m`,
/// `Q_l^m = a_lm (z Q_{l-1}^m − b_lm Q_{l-2}^m)`, `a_lm = √((4l²−1)/(l²−m²))`,
/// `b_lm = √(((l−1)²−m²)/(4(l−1)²−1))`.
pub fn eval_basis(n: usize, d: [f64; 3], out: &mut [f64]) {
    assert!((1..=MAX_ORDER).contains(&n), "SH order {n} outside 1..={MAX_ORDER}");
    assert!(out.len() >= n * n);
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let (x, y, z) = if len > 0.0 && len.is_finite() { (d[0] / len, d[1] / len, d[2] / len) } else { (0.0, 0.0, 1.0) };
    let mut qmm = 1.0 / SQRT_4PI; // Q_0^0
    let (mut cm, mut sm) = (1.0, 0.0); // (x + i y)^0
    for m in 0..n {
        if m > 0 {
            qmm *= ((2 * m + 1) as f64 / (2 * m) as f64).sqrt();
            let (c, s) = (cm * x - sm * y, cm * y + sm * x);
            cm = c;
            sm = s;
        }
        let mf = m as f64;
        let mut q_lm2 = 0.0;
        let mut q_lm1 = qmm;
        for l in m..n {
            let q = if l == m {
                qmm
            } else if l == m + 1 {
                z * (2.0 * mf + 3.0).sqrt() * qmm
            } else {
                let lf = l as f64;
                let a = ((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf)).sqrt();
                let b = (((lf - 1.0) * (lf - 1.0) - mf * mf) / (4.0 * (lf - 1.0) * (lf - 1.0) - 1.0)).sqrt();
                a * (z * q_lm1 - b * q_lm2)
            };
            if l > m {
                q_lm2 = q_lm1;
                q_lm1 = q;
            }
            let base = l * l + l;
            if m == 0 {
                out[base] = q;
            } else {
                out[base + m] = std::f64::consts::SQRT_2 * q * cm;
                out[base - m] = std::f64::consts::SQRT_2 * q * sm;
            }
        }
    }
}

/// [`eval_basis`] into a new vector.
pub fn eval(n: usize, d: [f64; 3]) -> Vec<f64> {
    let mut y = vec![0.0; n * n];
    eval_basis(n, d, &mut y);
    y
}

/// Reconstruct `f̃(d) = f · y(d)` (paper Eq. 2).
pub fn reconstruct(n: usize, f: &[f64], d: [f64; 3]) -> f64 {
    dot(&f[..n * n], &eval(n, d))
}

/// Legendre polynomial `P_l(x)` by the three-term recurrence.
pub fn legendre_p(l: usize, x: f64) -> f64 {
    let (mut p0, mut p1) = (1.0, x);
    if l == 0 {
        return 1.0;
    }
    for k in 2..=l {
        let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
        p0 = p1;
        p1 = p2;
    }
    p1
}

/// Zonal normalization `K_l = √((2l+1)/(4π))`, so `y_l0 = K_l P_l(z)`.
pub fn zonal_norm(l: usize) -> f64 {
    ((2 * l + 1) as f64 / (4.0 * PI)).sqrt()
}

// ---------------------------------------------------------------------------------------------
// Windowing and projection
// ---------------------------------------------------------------------------------------------

/// Frequency-space window against ringing (paper Sec. 7).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Window {
    /// No attenuation.
    None,
    /// `α_l = cos(π/2 · l/h)`; the paper uses `h = 2n` for order n, smaller `h` for harsher HDR maps.
    Cosine { h: f64 },
    /// Lanczos σ factors `α_l = sinc(l/n)` (`sin(πx)/(πx)`), a common alternative.
    Lanczos,
}

impl Window {
    /// The paper's default cosine window for order `n` (`h = 2n`).
    pub fn cosine_default(n: usize) -> Self {
        Window::Cosine { h: 2.0 * n as f64 }
    }

    /// Per-band factors `α_l`, `l = 0..n-1`.
    pub fn band_factors(&self, n: usize) -> Vec<f64> {
        (0..n)
            .map(|l| match *self {
                Window::None => 1.0,
                Window::Cosine { h } => {
                    let t = (l as f64 / h).min(1.0);
                    (0.5 * PI * t).cos().max(0.0)
                }
                Window::Lanczos => {
                    let x = l as f64 / n as f64;
                    if x == 0.0 {
                        1.0
                    } else {
                        (PI * x).sin() / (PI * x)
                    }
                }
            })
            .collect()
    }

    /// Scale band `l` of `coeffs` (an order-`n` vector) by `α_l`.
    pub fn apply(&self, n: usize, coeffs: &mut [f64]) {
        let a = self.band_factors(n);
        for (i, c) in coeffs.iter_mut().enumerate().take(n * n) {
            *c *= a[sh_lm(i).0];
        }
    }
}

/// Project a lat-long radiance map onto order-`n` SH (paper Eq. 1), one vector per RGB channel,
/// each texel weighted by its exact solid angle and evaluated at its centre (midpoint rule), then
/// windowed.
pub fn project_latlong(map: &LatLongMap, n: usize, window: Window) -> [Vec<f64>; 3] {
    let mut out = [vec![0.0; n * n], vec![0.0; n * n], vec![0.0; n * n]];
    let mut y = vec![0.0; n * n];
    for row in 0..map.height {
        let sa = texel_solid_angle(row, map.width, map.height);
        for col in 0..map.width {
            eval_basis(n, map.texel_direction(col, row), &mut y);
            let t = map.texel(col, row);
            for (c, o) in out.iter_mut().enumerate() {
                let w = t[c] as f64 * sa;
                for (oi, yi) in o.iter_mut().zip(&y) {
                    *oi += w * yi;
                }
            }
        }
    }
    for o in &mut out {
        window.apply(n, o);
    }
    out
}

/// Project a function onto order-`n` SH with a product rule: `n_theta` Gauss–Legendre nodes in
/// `z` and `n_phi` equispaced angles. Exact for polynomials of degree `< min(2 n_theta, n_phi)`
/// restricted to the sphere; for discontinuous `f` it converges slowly (use the closed forms).
pub fn project_function(n: usize, f: impl Fn([f64; 3]) -> f64, n_theta: usize, n_phi: usize) -> Vec<f64> {
    let (zs, ws) = gauss_legendre(n_theta);
    let mut out = vec![0.0; n * n];
    let mut y = vec![0.0; n * n];
    let dphi = 2.0 * PI / n_phi as f64;
    for (z, wz) in zs.iter().zip(&ws) {
        let r = (1.0 - z * z).max(0.0).sqrt();
        for k in 0..n_phi {
            let phi = (k as f64 + 0.5) * dphi;
            let d = [r * phi.cos(), r * phi.sin(), *z];
            eval_basis(n, d, &mut y);
            let w = wz * dphi * f(d);
            for (o, yi) in out.iter_mut().zip(&y) {
                *o += w * yi;
            }
        }
    }
    out
}

// ---------------------------------------------------------------------------------------------
// Triple-product tensor (paper Eq. 4) via Gaunt coefficients
// ---------------------------------------------------------------------------------------------

fn factorial(k: i64) -> f64 {
    debug_assert!(k >= 0);
    (1..=k).fold(1.0, |acc, x| acc * x as f64)
}

/// Wigner 3j symbol `(j1 j2 j3; m1 m2 m3)` for integer arguments by Racah's formula.
/// For `j ≤ 7` (order 8) every factorial is below 23! ≈ 2.6e22 and the alternating sum has at
/// most 8 terms, so f64 keeps ~1e-15 relative accuracy.
pub fn wigner_3j(j1: i64, j2: i64, j3: i64, m1: i64, m2: i64, m3: i64) -> f64 {
    if m1 + m2 + m3 != 0 || j3 < (j1 - j2).abs() || j3 > j1 + j2 || m1.abs() > j1 || m2.abs() > j2 || m3.abs() > j3 {
        return 0.0;
    }
    let delta =
        factorial(j1 + j2 - j3) * factorial(j1 - j2 + j3) * factorial(-j1 + j2 + j3) / factorial(j1 + j2 + j3 + 1);
    let pre = (delta
        * factorial(j1 + m1)
        * factorial(j1 - m1)
        * factorial(j2 + m2)
        * factorial(j2 - m2)
        * factorial(j3 + m3)
        * factorial(j3 - m3))
    .sqrt();
    let kmin = 0.max(j2 - j3 - m1).max(j1 - j3 + m2);
    let kmax = (j1 + j2 - j3).min(j1 - m1).min(j2 + m2);
    let mut sum = 0.0;
    for k in kmin..=kmax {
        let den = factorial(k)
            * factorial(j3 - j2 + k + m1)
            * factorial(j3 - j1 + k - m2)
            * factorial(j1 + j2 - j3 - k)
            * factorial(j1 - k - m1)
            * factorial(j2 - k + m2);
        sum += if k % 2 == 0 { 1.0 } else { -1.0 } / den;
    }
    let sign = if (j1 - j2 - m3).rem_euclid(2) == 0 { 1.0 } else { -1.0 };
    sign * pre * sum
}

/// Gaunt coefficient of complex SH with the Condon–Shortley phase:
/// `∫ Y_l1m1 Y_l2m2 Y_l3m3 dω = √((2l1+1)(2l2+1)(2l3+1)/(4π)) (l1 l2 l3; 0 0 0)(l1 l2 l3; m1 m2 m3)`.
pub fn gaunt_complex(l1: i64, m1: i64, l2: i64, m2: i64, l3: i64, m3: i64) -> f64 {
    let w0 = wigner_3j(l1, l2, l3, 0, 0, 0);
    if w0 == 0.0 {
        return 0.0;
    }
    (((2 * l1 + 1) * (2 * l2 + 1) * (2 * l3 + 1)) as f64 / (4.0 * PI)).sqrt() * w0 * wigner_3j(l1, l2, l3, m1, m2, m3)
}

/// The real basis function (l, m) as a combination of complex `Y_lμ` (with Condon–Shortley phase):
/// returns up to two terms `(μ, re, im)`.
fn real_to_complex(m: i64) -> [(i64, f64, f64); 2] {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let parity = if m.rem_euclid(2) == 0 { 1.0 } else { -1.0 };
    if m == 0 {
        [(0, 1.0, 0.0), (0, 0.0, 0.0)]
    } else if m > 0 {
        // y_lm = (Y_l,-m + (-1)^m Y_lm) / √2
        [(-m, s, 0.0), (m, parity * s, 0.0)]
    } else {
        // y_l,-μ = i (Y_l,-μ − (-1)^μ Y_lμ) / √2
        [(m, 0.0, s), (-m, 0.0, -parity * s)]
    }
}

/// Real Gaunt coefficient `Γ_ijk = ∫ y_i y_j y_k` (paper Eq. 4) by conversion from complex Gaunt
/// coefficients. Returns `(re, im)`; `im` is zero up to rounding (a test checks it).
pub fn gaunt_real_parts(i: usize, j: usize, k: usize) -> (f64, f64) {
    let (l1, m1) = sh_lm(i);
    let (l2, m2) = sh_lm(j);
    let (l3, m3) = sh_lm(k);
    let (l1, l2, l3) = (l1 as i64, l2 as i64, l3 as i64);
    let (c1, c2, c3) = (real_to_complex(m1 as i64), real_to_complex(m2 as i64), real_to_complex(m3 as i64));
    let (mut re, mut im) = (0.0, 0.0);
    for &(mu1, r1, i1) in &c1 {
        for &(mu2, r2, i2) in &c2 {
            for &(mu3, r3, i3) in &c3 {
                // Product of three complex weights.
                let (ar, ai) = (r1 * r2 - i1 * i2, r1 * i2 + i1 * r2);
                let (br, bi) = (ar * r3 - ai * i3, ar * i3 + ai * r3);
                if br == 0.0 && bi == 0.0 {
                    continue;
                }
                let g = gaunt_complex(l1, mu1, l2, mu2, l3, mu3);
                re += br * g;
                im += bi * g;
            }
        }
    }
    (re, im)
}

/// Real Gaunt coefficient `Γ_ijk`.
pub fn gaunt_real(i: usize, j: usize, k: usize) -> f64 {
    gaunt_real_parts(i, j, k).0
}

/// Selection rules for `Γ_ijk` of the real basis: triangle `|l1−l2| ≤ l3 ≤ l1+l2`, even
/// `l1+l2+l3` (parity), `|m|` of one equal to the sum of the other two (the φ integral of
/// cos/sin products), and an even number of sine-type (`m < 0`) factors.
pub fn selection_rule_allows(i: usize, j: usize, k: usize) -> bool {
    let (l1, m1) = sh_lm(i);
    let (l2, m2) = sh_lm(j);
    let (l3, m3) = sh_lm(k);
    let (l1, l2, l3) = (l1 as i64, l2 as i64, l3 as i64);
    if l3 < (l1 - l2).abs() || l3 > l1 + l2 || (l1 + l2 + l3) % 2 != 0 {
        return false;
    }
    let (a, b, c) = (m1.abs(), m2.abs(), m3.abs());
    if !(a == b + c || b == a + c || c == a + b) {
        return false;
    }
    [m1, m2, m3].iter().filter(|&&m| m < 0).count() % 2 == 0
}

/// Count of ordered triples `(i, j, k)` of order `n` allowed by [`selection_rule_allows`]
/// (DESIGN §3: 1, 10, 83, 359, 1164, 2961, 6586, 13018 for n = 1..8).
pub fn selection_rule_count(n: usize) -> usize {
    let c = n * n;
    let mut count = 0;
    for i in 0..c {
        for j in 0..c {
            for k in 0..c {
                count += selection_rule_allows(i, j, k) as usize;
            }
        }
    }
    count
}

/// Below this magnitude a Gaunt coefficient is an accidental zero (true values are ≥ 1e-3 for
/// n ≤ 8; rounding leaves ≤ 1e-15).
pub const GAUNT_ZERO: f64 = 1e-10;

/// One stored entry of the sparse tensor: `Γ_ijk` for `j ≤ k`, with `v = Γ_ijk` when `j < k`
/// and `v = Γ_ijj / 2` when `j == k`, so that every product is `c_i += v (a_j b_k + a_k b_j)`
/// with no branch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TensorEntry {
    pub i: u16,
    pub j: u16,
    pub k: u16,
    pub v: f64,
}

/// The order-`n` SH triple-product tensor Γ (paper Eq. 4), sparse: entries with `j ≤ k` only.
#[derive(Clone, Debug)]
pub struct ShTensor {
    pub n: usize,
    pub entries: Vec<TensorEntry>,
}

impl ShTensor {
    /// Build from Gaunt coefficients, keeping the entries allowed by the selection rules whose
    /// value is not an accidental zero.
    pub fn new(n: usize) -> Self {
        assert!((1..=MAX_ORDER).contains(&n), "SH order {n} outside 1..={MAX_ORDER}");
        let c = n * n;
        let mut entries = Vec::new();
        for i in 0..c {
            for j in 0..c {
                for k in j..c {
                    if !selection_rule_allows(i, j, k) {
                        continue;
                    }
                    let g = gaunt_real(i, j, k);
                    if g.abs() > GAUNT_ZERO {
                        let v = if j == k { 0.5 * g } else { g };
                        entries.push(TensorEntry { i: i as u16, j: j as u16, k: k as u16, v });
                    }
                }
            }
        }
        Self { n, entries }
    }

    /// Number of coefficients `n²`.
    pub fn len(&self) -> usize {
        self.n * self.n
    }

    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Number of nonzero ordered triples `(i, j, k)` (DESIGN §3: 1, 10, 83, 353, 1158, 2907,
    /// 6460, 12868 for n = 1..8).
    pub fn ordered_nonzero_count(&self) -> usize {
        self.entries.iter().map(|e| if e.j == e.k { 1 } else { 2 }).sum()
    }

    /// `Γ_ijk` (any order of indices), by search; for tests and tools, not inner loops.
    pub fn get(&self, i: usize, j: usize, k: usize) -> f64 {
        let (j, k) = if j <= k { (j, k) } else { (k, j) };
        self.entries.iter().find(|e| e.i as usize == i && e.j as usize == j && e.k as usize == k).map_or(0.0, |e| {
            if j == k {
                2.0 * e.v
            } else {
                e.v
            }
        })
    }

    /// SH product `(a * b)_i = Σ_jk Γ_ijk a_j b_k` (paper Eq. 3), written into `out[..n²]`.
    pub fn product_into(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
        let c = self.len();
        out[..c].iter_mut().for_each(|o| *o = 0.0);
        for e in &self.entries {
            let (i, j, k) = (e.i as usize, e.j as usize, e.k as usize);
            out[i] += e.v * (a[j] * b[k] + a[k] * b[j]);
        }
    }

    /// SH product `a * b`.
    pub fn product(&self, a: &[f64], b: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.len()];
        self.product_into(a, b, &mut out);
        out
    }

    /// SH square `a * a` (half the multiplications of a general product).
    pub fn square_into(&self, a: &[f64], out: &mut [f64]) {
        let c = self.len();
        out[..c].iter_mut().for_each(|o| *o = 0.0);
        for e in &self.entries {
            let (i, j, k) = (e.i as usize, e.j as usize, e.k as usize);
            out[i] += 2.0 * e.v * a[j] * a[k];
        }
    }

    /// SH square `a * a`.
    pub fn square(&self, a: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.len()];
        self.square_into(a, &mut out);
        out
    }

    /// Product matrix `(M_f)_ij = Σ_k Γ_ijk f_k` (paper Eq. 5), row-major `n² × n²`, symmetric.
    pub fn product_matrix(&self, f: &[f64]) -> Vec<f64> {
        let c = self.len();
        let mut m = vec![0.0; c * c];
        for e in &self.entries {
            let (i, j, k) = (e.i as usize, e.j as usize, e.k as usize);
            m[i * c + j] += e.v * f[k];
            m[i * c + k] += e.v * f[j];
        }
        m
    }

    /// `(a, b, c) = Σ Γ_ijk a_i b_j c_k`: the integral of the product of three reconstructions.
    pub fn triple(&self, a: &[f64], b: &[f64], c: &[f64]) -> f64 {
        dot(&self.product(a, b), c)
    }
}

// ---------------------------------------------------------------------------------------------
// Zonal harmonics: rotation, circles, irradiance weighting
// ---------------------------------------------------------------------------------------------

/// Scaled zonal coefficients `f*_l = f_l √(4π/(2l+1))` (paper Sec. 6.1), where `f_l` is the
/// coefficient of `y_l0` of a function symmetric about +z.
pub fn zonal_star(zonal: &[f64]) -> Vec<f64> {
    zonal.iter().enumerate().map(|(l, f)| f / zonal_norm(l)).collect()
}

/// Rotate a zonal function with scaled coefficients `f*_l` from +z to `axis`:
/// `f_lm = f*_l y_lm(axis)` (Sloan et al. 2005 rotation rule; SHEXP Eq. 34). Order = `fstar.len()`.
pub fn zh_rotate_star_into(fstar: &[f64], axis: [f64; 3], out: &mut [f64]) {
    let n = fstar.len();
    eval_basis(n, axis, out);
    for (i, o) in out.iter_mut().enumerate().take(n * n) {
        *o *= fstar[sh_lm(i).0];
    }
}

/// Rotate a zonal function given by its plain coefficients `f_l` (of `y_l0`) to `axis`.
pub fn zh_rotate(zonal: &[f64], axis: [f64; 3]) -> Vec<f64> {
    let n = zonal.len();
    let mut out = vec![0.0; n * n];
    zh_rotate_star_into(&zonal_star(zonal), axis, &mut out);
    out
}

/// Zonal coefficients `g_l(θ)` of the visibility of a circular blocker of angular radius `θ`
/// about +z (paper Eq. 33: 0 inside the cap `z ≥ cos θ`, 1 outside), in closed form:
/// `∫_c^1 P_0 = 1 − c`, `∫_c^1 P_l = (P_{l−1}(c) − P_{l+1}(c))/(2l+1)` for `l ≥ 1`, so
/// `g_0 = √(4π) − 2π K_0 (1 − c)` and `g_l = −2π K_l (P_{l−1}(c) − P_{l+1}(c))/(2l+1)`.
/// `θ` is clamped to `[0, π]`: `θ = π/2` is a half-space blocker (receiver on the sphere's
/// surface) and `θ = π` blocks everything (`g = 0`).
pub fn circle_visibility_zonal(n: usize, theta: f64) -> Vec<f64> {
    let c = theta.clamp(0.0, PI).cos();
    (0..n)
        .map(|l| {
            let cap = if l == 0 { 1.0 - c } else { (legendre_p(l - 1, c) - legendre_p(l + 1, c)) / (2 * l + 1) as f64 };
            let full = if l == 0 { SQRT_4PI } else { 0.0 };
            full - 2.0 * PI * zonal_norm(l) * cap
        })
        .collect()
}

/// Visibility of a circular blocker of angular radius `θ` about `axis`, order `n`.
pub fn circle_visibility(n: usize, theta: f64, axis: [f64; 3]) -> Vec<f64> {
    zh_rotate(&circle_visibility_zonal(n, theta), axis)
}

/// Zonal coefficients `Â_l / π` scaled as `h*_l` for the irradiance weighting
/// `H(N) = (1/π) ∫ max(s·N, 0) y(s) ds` (paper Eq. 9): `H_lm(N) = (Â_l/π) y_lm(N)` with
/// Ramamoorthi–Hanrahan's `Â_0 = π`, `Â_1 = 2π/3`, `Â_l = 0` for odd `l > 1` and
/// `Â_l = 2π (−1)^{l/2−1} / ((l+2)(l−1)) · l! / (2^l ((l/2)!)²)` for even `l ≥ 2`.
pub fn irradiance_weighting_star(n: usize) -> Vec<f64> {
    (0..n)
        .map(|l| {
            let a_hat = match l {
                0 => PI,
                1 => 2.0 * PI / 3.0,
                _ if l % 2 == 1 => 0.0,
                _ => {
                    let h = (l / 2) as i64;
                    let sign = if (h - 1) % 2 == 0 { 1.0 } else { -1.0 };
                    2.0 * PI * sign / ((l as f64 + 2.0) * (l as f64 - 1.0)) * factorial(l as i64)
                        / (2f64.powi(l as i32) * factorial(h) * factorial(h))
                }
            };
            a_hat / PI
        })
        .collect()
}

/// `H(N)` (paper Eq. 9) for a unit normal `N`, order `n`.
pub fn irradiance_weighting(n: usize, normal: [f64; 3]) -> Vec<f64> {
    let mut out = vec![0.0; n * n];
    zh_rotate_star_into(&irradiance_weighting_star(n), normal, &mut out);
    out
}

/// Cosine-weighted incident radiance `L_H(N) = L * H(N)` (paper Sec. 7); the shadowed diffuse
/// result is then `L_H(N) · g` for a visibility vector `g`.
pub fn light_weighted(tensor: &ShTensor, light: &[f64], normal: [f64; 3]) -> Vec<f64> {
    tensor.product(light, &irradiance_weighting(tensor.n, normal))
}

// ---------------------------------------------------------------------------------------------
// SH log by the eigen method (paper Sec. 5)
// ---------------------------------------------------------------------------------------------

/// Relative eigenvalue clip of the log (paper Sec. 5: "0.02 times the largest eigenvalue").
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
    use crate::quadrature::{integrate_gl, integrate_sphere};
    use crate::rng::Pcg32;

    /// Explicit polynomials for bands 0..2 (Ramamoorthi–Hanrahan 2001, no Condon–Shortley phase).
    fn explicit_l2(d: [f64; 3]) -> [f64; 9] {
        let [x, y, z] = d;
        let c0 = 0.5 * (1.0 / PI).sqrt();
        let c1 = (3.0 / (4.0 * PI)).sqrt();
        let c2 = 0.5 * (15.0 / PI).sqrt();
        let c20 = 0.25 * (5.0 / PI).sqrt();
        [
            c0,
            c1 * y,
            c1 * z,
            c1 * x,
            c2 * x * y,
            c2 * y * z,
            c20 * (3.0 * z * z - 1.0),
            c2 * x * z,
            0.5 * c2 * (x * x - y * y),
        ]
    }

    /// Associated Legendre with factorials (Rodrigues-free explicit sum), no CS phase: an
    /// independent check of the recurrence for all orders up to 8.
    fn assoc_legendre_explicit(l: usize, m: usize, x: f64) -> f64 {
        // P_l^m(x) = (1−x²)^{m/2} d^m/dx^m P_l(x), P_l(x) = 2^{-l} Σ_k (−1)^k C(l,k) C(2l−2k,l) x^{l−2k}
        let mut s = 0.0;
        for k in 0..=l / 2 {
            let p = l - 2 * k;
            if p < m {
                continue;
            }
            let c = factorial(l as i64) / (factorial(k as i64) * factorial((l - k) as i64))
                * factorial((2 * l - 2 * k) as i64)
                / (factorial(l as i64) * factorial((l - 2 * k) as i64));
            let deriv = factorial(p as i64) / factorial((p - m) as i64);
            s += if k % 2 == 0 { 1.0 } else { -1.0 } * c * deriv * x.powi((p - m) as i32);
        }
        s / 2f64.powi(l as i32) * (1.0 - x * x).max(0.0).powf(m as f64 / 2.0)
    }

    #[test]
    fn basis_matches_explicit_forms() {
        let mut rng = Pcg32::new(1, 1);
        for _ in 0..50 {
            let d = rng.unit_vector();
            let y = eval(MAX_ORDER, d);
            let e = explicit_l2(d);
            for i in 0..9 {
                // Two independent f64 formulas: agreement to rounding (values are O(1)).
                assert!((y[i] - e[i]).abs() < 1e-14, "i={i}: {} vs {}", y[i], e[i]);
            }
            let (theta, phi) = (d[2].acos(), d[1].atan2(d[0]));
            for l in 0..MAX_ORDER {
                for m in -(l as i32)..=(l as i32) {
                    let am = m.unsigned_abs() as usize;
                    let k = ((2 * l + 1) as f64 / (4.0 * PI) * factorial((l - am) as i64) / factorial((l + am) as i64))
                        .sqrt();
                    let p = assoc_legendre_explicit(l, am, theta.cos());
                    let v = match m.cmp(&0) {
                        std::cmp::Ordering::Equal => k * p,
                        std::cmp::Ordering::Greater => 2f64.sqrt() * k * p * (am as f64 * phi).cos(),
                        std::cmp::Ordering::Less => 2f64.sqrt() * k * p * (am as f64 * phi).sin(),
                    };
                    // The explicit sum cancels terms up to ~C(14,7)·2^-7 ≈ 27: allow 1e-12.
                    assert!((y[sh_index(l, m)] - v).abs() < 1e-12, "l={l} m={m}");
                }
            }
        }
        // Index helpers round-trip.
        for i in 0..64 {
            let (l, m) = sh_lm(i);
            assert_eq!(sh_index(l, m), i);
        }
    }

    #[test]
    fn basis_is_orthonormal() {
        // Products of two order-8 functions have degree ≤ 14: 8 GL nodes × 16 angles is exact.
        let n = MAX_ORDER;
        let c = n * n;
        let mut gram = vec![0.0; c * c];
        for i in 0..c {
            let p = project_function(n, |d| eval(n, d)[i], 8, 16);
            gram[i * c..(i + 1) * c].copy_from_slice(&p);
        }
        for i in 0..c {
            for j in 0..c {
                let want = if i == j { 1.0 } else { 0.0 };
                // Exact quadrature: only rounding remains.
                assert!((gram[i * c + j] - want).abs() < 1e-12, "({i},{j}) {}", gram[i * c + j]);
            }
        }
        // And with the module's independent sphere integrator, for a few pairs.
        let v = integrate_sphere(|d| eval(4, d)[5] * eval(4, d)[5], 12, 1, 16);
        assert!((v - 1.0).abs() < 1e-12);
        // The constant 1 is (√(4π), 0, ...).
        let p1 = project_function(3, |_| 1.0, 4, 8);
        for (a, b) in p1.iter().zip(one(3)) {
            assert!((a - b).abs() < 1e-13);
        }
        // Degenerate direction: no NaN.
        assert!(eval(6, [0.0, 0.0, 0.0]).iter().all(|v| v.is_finite()));
    }

    #[test]
    fn wigner_3j_known_values() {
        // (1 1 0; 0 0 0) = −1/√3, (1 1 2; 1 −1 0) = 1/√30, (2 2 2; 0 0 0) = −√(2/35)
        assert!((wigner_3j(1, 1, 0, 0, 0, 0) + 1.0 / 3f64.sqrt()).abs() < 1e-15);
        assert!((wigner_3j(1, 1, 2, 1, -1, 0) - 1.0 / 30f64.sqrt()).abs() < 1e-15);
        assert!((wigner_3j(2, 2, 2, 0, 0, 0) + (2.0f64 / 35.0).sqrt()).abs() < 1e-15);
        // Orthogonality Σ_{m1,m2} (j1 j2 j3; m1 m2 m3)² = 1/(2j3+1) for fixed m3.
        for (j1, j2, j3) in [(3, 4, 5), (7, 7, 6), (5, 2, 7)] {
            let mut s = 0.0;
            let m3 = 1;
            for m1 in -j1..=j1 {
                s += wigner_3j(j1, j2, j3, m1, -m1 - m3, m3).powi(2);
            }
            assert!((s - 1.0 / (2 * j3 + 1) as f64).abs() < 1e-14, "{j1} {j2} {j3}: {s}");
        }
    }

    /// Γ by exact quadrature for order 8: degree ≤ 21 in z needs 11 GL nodes, trigonometric degree
    /// ≤ 21 in φ needs > 21 equispaced angles. Returns Γ for i ≤ j ≤ k in a dense cube.
    fn gamma_by_quadrature(n: usize) -> Vec<f64> {
        let c = n * n;
        let (zs, ws) = gauss_legendre(12);
        let nphi = 24;
        let mut pts = Vec::new();
        for (z, w) in zs.iter().zip(&ws) {
            let r = (1.0 - z * z).sqrt();
            for k in 0..nphi {
                let phi = (k as f64 + 0.5) * 2.0 * PI / nphi as f64;
                pts.push((w * 2.0 * PI / nphi as f64, eval(n, [r * phi.cos(), r * phi.sin(), *z])));
            }
        }
        let mut g = vec![0.0; c * c * c];
        for i in 0..c {
            for j in i..c {
                for k in j..c {
                    let v: f64 = pts.iter().map(|(w, y)| w * y[i] * y[j] * y[k]).sum();
                    for (a, b, d) in [(i, j, k), (i, k, j), (j, i, k), (j, k, i), (k, i, j), (k, j, i)] {
                        g[(a * c + b) * c + d] = v;
                    }
                }
            }
        }
        g
    }

    #[test]
    fn tensor_counts_and_values_match_quadrature() {
        let want_allowed = [1, 10, 83, 359, 1164, 2961, 6586, 13018];
        let want_nonzero = [1, 10, 83, 353, 1158, 2907, 6460, 12868];
        let quad = gamma_by_quadrature(MAX_ORDER);
        let cmax = MAX_ORDER * MAX_ORDER;
        for n in 1..=MAX_ORDER {
            assert_eq!(selection_rule_count(n), want_allowed[n - 1], "allowed, n={n}");
            let t = ShTensor::new(n);
            assert_eq!(t.ordered_nonzero_count(), want_nonzero[n - 1], "nonzero (Gaunt), n={n}");
            // Independent count from quadrature alone: |Γ| above 1e-10 (rounding is ~1e-16,
            // the smallest true value at n = 8 is > 1e-3).
            let c = n * n;
            let mut quad_nonzero = 0;
            for i in 0..c {
                for j in 0..c {
                    for k in 0..c {
                        let q = quad[(i * cmax + j) * cmax + k];
                        if q.abs() > GAUNT_ZERO {
                            quad_nonzero += 1;
                            // Quadrature values outside the selection rules would mean the rules are wrong.
                            assert!(selection_rule_allows(i, j, k), "({i},{j},{k}) = {q}");
                        }
                    }
                }
            }
            assert_eq!(quad_nonzero, want_nonzero[n - 1], "nonzero (quadrature), n={n}");
        }
        // Values: every stored entry, and the imaginary part of the real conversion, at n = 8.
        let t = ShTensor::new(MAX_ORDER);
        let mut max_err: f64 = 0.0;
        for e in &t.entries {
            let (i, j, k) = (e.i as usize, e.j as usize, e.k as usize);
            let g = if j == k { 2.0 * e.v } else { e.v };
            max_err = max_err.max((g - quad[(i * cmax + j) * cmax + k]).abs());
            assert!(gaunt_real_parts(i, j, k).1.abs() < 1e-14);
        }
        // Both sides are exact up to rounding of O(1) sums of ~300 terms.
        assert!(max_err < 1e-13, "max |Γ_gaunt − Γ_quad| = {max_err}");
    }

    #[test]
    fn product_square_and_matrix_match_quadrature() {
        let mut rng = Pcg32::new(7, 3);
        for n in [2, 4, 6] {
            let t = ShTensor::new(n);
            let c = n * n;
            let a: Vec<f64> = (0..c).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let b: Vec<f64> = (0..c).map(|_| rng.uniform(-1.0, 1.0)).collect();
            // Independent: project the pointwise product of reconstructions (degree 2n−2, exact).
            let want = project_function(n, |d| reconstruct(n, &a, d) * reconstruct(n, &b, d), 2 * n, 4 * n);
            let got = t.product(&a, &b);
            let sq = t.square(&a);
            let want_sq = project_function(n, |d| reconstruct(n, &a, d).powi(2), 2 * n, 4 * n);
            let m = t.product_matrix(&a);
            for i in 0..c {
                // Exact quadrature vs exact tensor: rounding only (values O(10)).
                assert!((got[i] - want[i]).abs() < 1e-12, "n={n} i={i}");
                assert!((sq[i] - want_sq[i]).abs() < 1e-12);
                let mb: f64 = (0..c).map(|j| m[i * c + j] * b[j]).sum();
                assert!((mb - want[i]).abs() < 1e-12);
                for j in 0..c {
                    // Symmetric up to the summation order of the two halves.
                    assert!((m[i * c + j] - m[j * c + i]).abs() < 1e-14, "M_f symmetric");
                }
            }
            // 1 is the identity of the product; M_1 = I.
            let p1 = t.product(&one(n), &a);
            for i in 0..c {
                assert!((p1[i] - a[i]).abs() < 1e-14);
            }
            // Triple product is symmetric.
            let tr = t.triple(&a, &b, &sq);
            assert!((tr - t.triple(&sq, &a, &b)).abs() < 1e-12);
        }
    }

    #[test]
    fn zh_rotation_matches_projection() {
        // A smooth zonal function f(z) = exp(z) about an arbitrary axis: rotate its zonal
        // coefficients and compare to projecting the rotated function.
        let n = 6;
        let mut rng = Pcg32::new(11, 2);
        let zonal: Vec<f64> = (0..n)
            .map(|l| 2.0 * PI * zonal_norm(l) * integrate_gl(|z| z.exp() * legendre_p(l, z), -1.0, 1.0, 20, 1))
            .collect();
        for _ in 0..4 {
            let axis = rng.unit_vector();
            let got = zh_rotate(&zonal, axis);
            let f = |d: [f64; 3]| (d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2]).exp();
            let want = project_function(n, f, 24, 48);
            for i in 0..n * n {
                // exp is entire: 24 GL nodes × 48 angles converge to ~1e-15.
                assert!((got[i] - want[i]).abs() < 1e-12, "i={i}: {} vs {}", got[i], want[i]);
            }
        }
    }

    #[test]
    fn circle_visibility_matches_quadrature() {
        let n = MAX_ORDER;
        for &theta in &[0.0, 1e-4, 0.3, 1.0, 0.5 * PI, 2.0, PI, 4.0] {
            let g = circle_visibility_zonal(n, theta);
            let c = theta.clamp(0.0, PI).cos();
            for (l, &gl) in g.iter().enumerate() {
                // Visible part z < cos θ: piecewise Gauss–Legendre of a degree-l polynomial is exact.
                let want = if c > -1.0 {
                    2.0 * PI * zonal_norm(l) * integrate_gl(|z| legendre_p(l, z), -1.0, c, 8, 1)
                } else {
                    0.0
                };
                assert!((gl - want).abs() < 1e-13, "θ={theta} l={l}: {gl} vs {want}");
            }
        }
        // Tiny blocker: the DC deficit is the cap's solid angle times y_00 = 1/√(4π).
        let g = circle_visibility_zonal(4, 1e-3);
        let cap = 2.0 * PI * (1.0 - (1e-3f64).cos());
        assert!((g[0] - (SQRT_4PI - cap / SQRT_4PI)).abs() < 1e-15);
    }

    #[test]
    fn irradiance_weighting_matches_quadrature() {
        let n = MAX_ORDER;
        let mut rng = Pcg32::new(5, 5);
        let nrm = rng.unit_vector();
        let h = irradiance_weighting(n, nrm);
        // max(s·N, 0) has a kink: rotate so N = +z and integrate z ∈ [0, 1] exactly.
        let zonal: Vec<f64> = (0..n)
            .map(|l| 2.0 * PI * zonal_norm(l) * integrate_gl(|z| z * legendre_p(l, z), 0.0, 1.0, 8, 1) / PI)
            .collect();
        let want = zh_rotate(&zonal, nrm);
        for i in 0..n * n {
            assert!((h[i] - want[i]).abs() < 1e-13, "i={i}");
        }
        // Furnace: constant light c, no shadow: L_H · 1 = (1/π) ∫ c max(s·N,0) = c.
        let t = ShTensor::new(4);
        let mut l = one(4);
        l.iter_mut().for_each(|v| *v *= 2.5);
        let lh = light_weighted(&t, &l, nrm);
        assert!((dot(&lh, &one(4)) - 2.5).abs() < 1e-13);
    }

    #[test]
    fn projection_of_latlong_map() {
        // A map holding a known band-limited function; midpoint rule on 256×128 texels has
        // O(h²) error ≈ (π/128)²/24 × |f''| ~ 1e-4 relative: tolerance 1e-3.
        let n = 4;
        let (w, h) = (256, 128);
        let coeffs: Vec<f64> = (0..16).map(|i| 0.2 + 0.05 * i as f64 * if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
        let mut map = LatLongMap::constant(w, h, [0.0; 3]);
        for row in 0..h {
            for col in 0..w {
                let d = map.texel_direction(col, row);
                let v = reconstruct(n, &coeffs, d) as f32;
                map.texels[row * w + col] = [v, 2.0 * v, 1.0];
            }
        }
        let p = project_latlong(&map, n, Window::None);
        for i in 0..16 {
            assert!((p[0][i] - coeffs[i]).abs() < 1e-3, "i={i}: {} vs {}", p[0][i], coeffs[i]);
            assert!((p[1][i] - 2.0 * coeffs[i]).abs() < 2e-3);
            let want = if i == 0 { SQRT_4PI } else { 0.0 };
            assert!((p[2][i] - want).abs() < 1e-3);
        }
        // The cosine window: α_0 = 1, α_l = cos(π l / 4n).
        let pw = project_latlong(&map, n, Window::cosine_default(n));
        let a3 = (PI * 3.0 / 16.0).cos();
        assert!((pw[0][9] - a3 * p[0][9]).abs() < 1e-12);
        assert!((pw[0][0] - p[0][0]).abs() < 1e-15);
        assert!(Window::Lanczos.band_factors(4).iter().all(|a| (0.0..=1.0).contains(a)));
    }

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
