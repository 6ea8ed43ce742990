//! Small dense linear algebra shared by the SH modules (`sh`, `shexp`): the symmetric eigen
//! solver behind the SH exponential and logarithm (SHEXP paper Sec. 4.2, Eqs. 26–32), and applying
//! a function of a symmetric matrix through its eigendecomposition. Row-major `n × n` slices.

/// Eigendecomposition of a symmetric `n × n` row-major matrix by the cyclic Jacobi method.
/// Returns `(λ, V)` with `A = V diag(λ) Vᵀ`, `V` row-major (column p is eigenvector p, so
/// `V[i * n + p]` is its component i). Eigenvalues are not sorted.
///
/// Jacobi is slow for big matrices but unconditionally stable and accurate to a few ulps of
/// ‖A‖ for the ≤ 64 × 64 matrices of SH orders ≤ 8; sweeps stop when the off-diagonal mass falls
/// below 1e-30 of the total (or after 60 sweeps; ~8 are needed in practice).
pub fn symmetric_eigen(a: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    assert_eq!(a.len(), n * n);
    let mut a = a.to_vec();
    let mut v = vec![0.0; n * n];
    for i in 0..n {
        v[i * n + i] = 1.0;
    }
    let total: f64 = a.iter().map(|x| x * x).sum();
    for _sweep in 0..60 {
        let mut off = 0.0;
        for p in 0..n {
            for q in p + 1..n {
                off += a[p * n + q] * a[p * n + q];
            }
        }
        if off <= 1e-30 * total || off == 0.0 || !off.is_finite() {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[p * n + q];
                if apq == 0.0 {
                    continue;
                }
                let (app, aqq) = (a[p * n + p], a[q * n + q]);
                // Rotation angle zeroing a_pq (Rutishauser): cot 2φ = (a_qq − a_pp) / (2 a_pq),
                // t = tan φ the smaller root, stable for any ratio.
                let theta = (aqq - app) / (2.0 * apq);
                let t = if theta.abs() > 1e150 {
                    0.5 / theta
                } else {
                    theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt())
                };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (akp, akq) = (a[k * n + p], a[k * n + q]);
                    a[k * n + p] = c * akp - s * akq;
                    a[k * n + q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[p * n + k], a[q * n + k]);
                    a[p * n + k] = c * apk - s * aqk;
                    a[q * n + k] = s * apk + c * aqk;
                }
                for k in 0..n {
                    let (vkp, vkq) = (v[k * n + p], v[k * n + q]);
                    v[k * n + p] = c * vkp - s * vkq;
                    v[k * n + q] = s * vkp + c * vkq;
                }
            }
        }
    }
    ((0..n).map(|i| a[i * n + i]).collect(), v)
}

/// `V f(D) Vᵀ x` for an eigendecomposition `(D, V)` from [`symmetric_eigen`] (`V` row-major, column
/// p the eigenvector of `vals[p]`): the action of the matrix function `f(A)` on `x`.
pub fn spectral_apply(vals: &[f64], vecs: &[f64], x: &[f64], f: impl Fn(f64) -> f64) -> Vec<f64> {
    let n = vals.len();
    assert_eq!(vecs.len(), n * n);
    let mut out = vec![0.0; n];
    for (p, &lam) in vals.iter().enumerate() {
        let proj: f64 = (0..n).map(|i| vecs[i * n + p] * x[i]).sum();
        let coef = f(lam) * proj;
        for (i, o) in out.iter_mut().enumerate() {
            *o += vecs[i * n + p] * coef;
        }
    }
    out
}

/// x with A x = y by Gaussian elimination with partial pivoting (small dense systems, e.g. normal equations).
#[allow(clippy::needless_range_loop)]
pub fn solve<const N: usize>(mut a: [[f64; N]; N], mut y: [f64; N]) -> [f64; N] {
    for c in 0..N {
        let p = (c..N).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs())).unwrap_or(c);
        a.swap(c, p);
        y.swap(c, p);
        for r in c + 1..N {
            let f = a[r][c] / a[c][c];
            for k in c..N {
                a[r][k] -= f * a[c][k];
            }
            y[r] -= f * y[c];
        }
    }
    let mut x = [0.0; N];
    for r in (0..N).rev() {
        let s: f64 = (r + 1..N).map(|k| a[r][k] * x[k]).sum();
        x[r] = (y[r] - s) / a[r][r];
    }
    x
}

/// sqrt(num / den): 0 for 0/0 and ∞ for x/0 (the relative-RMSE quotient of sums of squares).
pub fn sqrt_ratio(num: f64, den: f64) -> f64 {
    if den > 0.0 {
        (num / den).sqrt()
    } else if num > 0.0 {
        f64::INFINITY
    } else {
        0.0
    }
}

#[cfg(test)]
mod solve_tests {
    #[test]
    fn solves_a_small_system() {
        // Needs pivoting: a[0][0] = 0.
        let a = [[0.0, 2.0, 1.0], [1.0, 1.0, 0.0], [2.0, 0.0, 3.0]];
        let x = super::solve(a, [7.0, 3.0, 11.0]);
        for (got, want) in x.iter().zip([1.0, 2.0, 3.0]) {
            assert!((got - want).abs() < 1e-12, "{x:?}");
        }
    }
}
#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    #[test]
    fn jacobi_reconstructs_and_is_orthogonal() {
        let mut rng = Pcg32::new(3, 9);
        for &n in &[1usize, 2, 7, 36] {
            let mut a = vec![0.0; n * n];
            for i in 0..n {
                for j in i..n {
                    let v = rng.uniform(-1.0, 1.0);
                    a[i * n + j] = v;
                    a[j * n + i] = v;
                }
            }
            let (vals, v) = symmetric_eigen(&a, n);
            for i in 0..n {
                for j in 0..n {
                    let rec: f64 = (0..n).map(|p| v[i * n + p] * vals[p] * v[j * n + p]).sum();
                    let vtv: f64 = (0..n).map(|p| v[p * n + i] * v[p * n + j]).sum();
                    // Backward-stable: ~n ulps of ‖A‖ ≈ n.
                    assert!((rec - a[i * n + j]).abs() < 1e-12, "n={n}");
                    assert!((vtv - if i == j { 1.0 } else { 0.0 }).abs() < 1e-12);
                }
            }
        }
        // Repeated eigenvalues, diagonal and zero matrices.
        let (vals, _) = symmetric_eigen(&[2.0, 0.0, 0.0, 2.0], 2);
        assert_eq!(vals, vec![2.0, 2.0]);
        let (vals, _) = symmetric_eigen(&[0.0; 9], 3);
        assert!(vals.iter().all(|v| *v == 0.0));
    }

    #[test]
    fn spectral_apply_of_identity_and_square() {
        let a = [2.0, 1.0, 0.0, 1.0, 3.0, 1.0, 0.0, 1.0, 4.0];
        let (vals, vecs) = symmetric_eigen(&a, 3);
        let x = [0.3, -1.0, 2.0];
        // f(λ) = 1 gives x; f(λ) = λ² gives A(Ax).
        let id = spectral_apply(&vals, &vecs, &x, |_| 1.0);
        let ax: Vec<f64> = (0..3).map(|i| (0..3).map(|j| a[i * 3 + j] * x[j]).sum()).collect();
        let aax: Vec<f64> = (0..3).map(|i| (0..3).map(|j| a[i * 3 + j] * ax[j]).sum()).collect();
        let sq = spectral_apply(&vals, &vecs, &x, |l| l * l);
        for i in 0..3 {
            assert!((id[i] - x[i]).abs() < 1e-14);
            assert!((sq[i] - aax[i]).abs() < 1e-12);
        }
    }
}
