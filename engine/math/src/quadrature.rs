//! Numerical integration in f64: the independent references every closed form is tested against.

use std::f64::consts::PI;

/// Gauss–Legendre nodes and weights on [-1, 1] (Newton iteration on P_n; exact for degree 2n−1).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    assert!(n >= 1, "Gauss-Legendre needs at least one node");
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        // Initial guess (Tricomi), then Newton on the Legendre recurrence.
        let mut z = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, z);
            if n == 1 {
                p1 = z;
                p0 = 1.0;
            } else {
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
            }
            // p1 = P_n(z), p0 = P_{n-1}(z)
            dp = n as f64 * (z * p1 - p0) / (z * z - 1.0);
            if n == 1 {
                dp = 1.0;
            }
            let dz = p1 / dp;
            z -= dz;
            if dz.abs() < 1e-15 {
                break;
            }
        }
        x[i] = -z;
        x[n - 1 - i] = z;
        let wi = 2.0 / ((1.0 - z * z) * dp * dp);
        w[i] = wi;
        w[n - 1 - i] = wi;
    }
    (x, w)
}

/// ∫_a^b f with `panels` equal panels of `n`-point Gauss–Legendre each.
pub fn integrate_gl(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize, panels: usize) -> f64 {
    let (x, w) = gauss_legendre(n);
    let h = (b - a) / panels as f64;
    let mut sum = 0.0;
    for p in 0..panels {
        let lo = a + p as f64 * h;
        for (xi, wi) in x.iter().zip(&w) {
            sum += wi * f(lo + 0.5 * h * (xi + 1.0));
        }
    }
    sum * 0.5 * h
}

/// Adaptive Simpson integration of f over [a, b] to absolute tolerance `tol`.
pub fn adaptive_simpson(f: &impl Fn(f64) -> f64, a: f64, b: f64, tol: f64) -> f64 {
    #[allow(clippy::too_many_arguments)] // the recursion carries its interval, samples and tolerance
    fn step(
        f: &impl Fn(f64) -> f64,
        a: f64,
        b: f64,
        fa: f64,
        fm: f64,
        fb: f64,
        whole: f64,
        tol: f64,
        depth: u32,
    ) -> f64 {
        let m = 0.5 * (a + b);
        let (lm, rm) = (0.5 * (a + m), 0.5 * (m + b));
        let (flm, frm) = (f(lm), f(rm));
        let left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
        let right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
        let delta = left + right - whole;
        if depth == 0 || delta.abs() <= 15.0 * tol {
            left + right + delta / 15.0
        } else {
            step(f, a, m, fa, flm, fm, left, 0.5 * tol, depth - 1)
                + step(f, m, b, fm, frm, fb, right, 0.5 * tol, depth - 1)
        }
    }
    let (fa, fb, fm) = (f(a), f(b), f(0.5 * (a + b)));
    let whole = (b - a) / 6.0 * (fa + 4.0 * fm + fb);
    step(f, a, b, fa, fm, fb, whole, tol, 48)
}

/// ∫ over the unit sphere of f(direction), by Gauss–Legendre in cos θ (`n_theta` nodes in each of
/// `panels` panels) and the trapezoid rule in φ (`n_phi` points; spectrally accurate for periodic f).
/// For peaked integrands, rotate f so the peak sits at a pole and raise `panels`.
pub fn integrate_sphere(f: impl Fn([f64; 3]) -> f64, n_theta: usize, panels: usize, n_phi: usize) -> f64 {
    let dphi = 2.0 * PI / n_phi as f64;
    integrate_gl(
        |z| {
            let r = (1.0 - z * z).max(0.0).sqrt();
            let mut s = 0.0;
            for k in 0..n_phi {
                let phi = (k as f64 + 0.5) * dphi;
                s += f([r * phi.cos(), r * phi.sin(), z]);
            }
            s * dphi
        },
        -1.0,
        1.0,
        n_theta,
        panels,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_is_exact_for_polynomials() {
        for n in 1..=12 {
            let (x, w) = gauss_legendre(n);
            assert!((w.iter().sum::<f64>() - 2.0).abs() < 1e-13);
            // ∫ x^(2n-2) over [-1,1] = 2/(2n-1), exact for n nodes (degree ≤ 2n-1).
            let deg = 2 * n - 2;
            let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(deg as i32)).sum();
            assert!((q - 2.0 / (deg as f64 + 1.0)).abs() < 1e-13, "n={n}: {q}");
        }
    }

    #[test]
    fn adaptive_simpson_and_sphere() {
        let v = adaptive_simpson(&|x: f64| x.sin(), 0.0, PI, 1e-12);
        assert!((v - 2.0).abs() < 1e-10);
        let area = integrate_sphere(|_| 1.0, 16, 1, 8);
        assert!((area - 4.0 * PI).abs() < 1e-12);
        // ∫ max(z, 0) dω = π.
        let cos = integrate_sphere(|d| d[2].max(0.0), 16, 2, 8);
        assert!((cos - PI).abs() < 1e-12, "{cos}");
    }
}
