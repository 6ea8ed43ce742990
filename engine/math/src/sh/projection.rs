//! Windowing (ringing reduction) and projection of functions and lat-long maps onto the basis, by
//! quadrature.

use super::{eval_basis, sh_lm};
use crate::envmap::{texel_solid_angle, LatLongMap};
use crate::quadrature::gauss_legendre;
use std::f64::consts::PI;

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::envmap::LatLongMap;
    use crate::sh::{reconstruct, SQRT_4PI};

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
}
