//! Zonal harmonics: rotation to an axis (paper Eq. 34), circle (sphere-blocker) visibility and the
//! irradiance (clamped-cosine) weighting.

use super::{eval_basis, factorial, legendre_p, sh_lm, zonal_norm, ShTensor, SQRT_4PI};
use std::f64::consts::PI;

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::integrate_gl;
    use crate::rng::Pcg32;
    use crate::sh::{dot, one, project_function, MAX_ORDER};

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
}
