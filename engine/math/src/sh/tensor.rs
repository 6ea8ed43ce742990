//! The triple-product tensor (paper Eq. 4) from Gaunt coefficients (Wigner 3j symbols), and the
//! SH products, squares and product matrices it defines.

use super::{dot, sh_lm, MAX_ORDER};
use std::f64::consts::PI;

pub(super) fn factorial(k: i64) -> f64 {
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

/// Orders whose SH product is generated as straight-line GLSL ([`glsl_products`]): up to 6 (1,450 terms at
/// n = 6; n = 7 and 8 would take 3,300 and 6,500 and keep the table loop).
pub const GLSL_PRODUCT_MAX_ORDER: usize = 6;

/// The GLSL of `shn_product` (`c = a * b`, SHEXP Eq. 3) for the orders 3..=[`GLSL_PRODUCT_MAX_ORDER`] as
/// straight-line code, one selected by `SHEXP_N` (shaders-glsl/common/sh_product_gen.glsl, written by `cargo
/// xtask tables` and checked by a drift test). The table loop reads Γ from a buffer and indexes the vectors by
/// its entries, so llvmpipe keeps them in memory and gathers every operand; with constant indices they stay in
/// registers. Each coefficient sums the same f32-rounded values the table holds.
pub fn glsl_products() -> String {
    use std::fmt::Write as _;
    let mut out = String::from(
        "// GENERATED by `cargo xtask tables` from engine_math::sh::glsl_products (Γ = engine_math::sh::ShTensor): do\n\
         // not edit. The SH product c = a * b (SHEXP Eq. 3) as straight-line code for the compile-time order\n\
         // SHEXP_N; shexp_n.glsl falls back to its table loop for the other orders.\n\
         #ifndef SH_PRODUCT_GEN_GLSL\n#define SH_PRODUCT_GEN_GLSL\n",
    );
    let lit = |x: f64| {
        let s = format!("{:e}", x as f32);
        if s.contains('.') || s.contains('e') {
            s
        } else {
            format!("{s}.0")
        }
    };
    for n in 3..=GLSL_PRODUCT_MAX_ORDER {
        let t = ShTensor::new(n);
        let c = n * n;
        let _ = writeln!(out, "#{}if SHEXP_N == {n}", if n == 3 { "" } else { "el" });
        out.push_str("#define SHN_PRODUCT_GENERATED\n");
        let _ = writeln!(out, "void shn_product(float a[{c}], float b[{c}], out float c[{c}]) {{");
        for i in 0..c {
            let terms: Vec<String> = t
                .entries
                .iter()
                .filter(|e| e.i as usize == i)
                .map(|e| {
                    let (j, k) = (e.j, e.k);
                    // The table's f32 value, as the loop reads it.
                    let v = e.v as f32 as f64;
                    if j == k {
                        format!("{} * (a[{j}] * b[{j}])", lit(2.0 * v))
                    } else {
                        format!("{} * (a[{j}] * b[{k}] + a[{k}] * b[{j}])", lit(v))
                    }
                })
                .collect();
            if terms.is_empty() {
                let _ = writeln!(out, "    c[{i}] = 0.0;");
            } else {
                let _ = writeln!(out, "    c[{i}] = {};", terms.join("\n        + "));
            }
        }
        out.push_str("}\n");
    }
    out.push_str("#endif\n#endif\n");
    out
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::gauss_legendre;
    use crate::rng::Pcg32;
    use crate::sh::{eval, one, project_function, reconstruct};

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
}
