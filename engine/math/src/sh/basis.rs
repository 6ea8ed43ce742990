//! The real SH basis (conventions in the `sh` module docs): indexing, evaluation by the recurrence
//! `sh.glsl` shares, reconstruction, Legendre polynomials and the zonal normalization.

use std::f64::consts::PI;

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::integrate_sphere;
    use crate::rng::Pcg32;
    use crate::sh::{factorial, project_function};

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
}
