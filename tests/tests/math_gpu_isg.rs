//! GPU (f32 GLSL, shaders-glsl/common/isg.glsl) vs CPU (f64, engine_math::isg) twins through
//! shaders-glsl/tests/isg_twin.comp: the input starts with the 8448 floats of
//! `IsgLut::generate_default()`, then cases of 5 floats (θ0, θ1, φ0, φ1, λ); 6 floats out per case.
//!
//! Tolerances: f32 arithmetic error bounds in units of EPS = 2⁻²⁴ with exp and log as in
//! twin/mod.rs (checked on the device by math_gpu_sg.rs). Both sides interpolate the same f32
//! table, so the table evaluator differs only through the warped coordinates and the slice
//! position; their f32 errors are turned into value errors by the table's steepest slope.

mod twin;

use engine::gpu::testing::{run_f32_kernel, test_gpu};
use engine::math::isg::{self, IsgLut, ISG_LUT_C1, ISG_LUT_C3, ISG_LUT_SQ_MIN, PAPER_G, PAPER_H};
use engine::math::rng::Pcg32;
use std::f64::consts::{FRAC_PI_2, PI};
use twin::*;

const IN: usize = 5;
const OUT: usize = 6;
/// |π/2 − f32(π/2)|: the GLSL's ISG_HALF_PI is off by this much.
const HALF_PI_F32_ERR: f64 = 4.371139e-8;

/// The paper's quartic and the sum of its terms' magnitudes (its f32 rounding is ~4ε of that).
fn quartic(c: &[f64; 5], lambda: f64) -> (f64, f64) {
    let t = lambda / 100.0;
    let (mut v, mut mag, mut p) = (0.0, 0.0, 1.0);
    for ck in c {
        v += ck * p;
        mag += (ck * p).abs();
        p *= t;
    }
    (v, mag)
}

/// Error bound of the f32 σ(g (x − π/2)): the argument's error (g's rounding, f32 π/2, the
/// product) through σ' ≤ ¼, and exp's (EXP_ULP + 2|a|) ulp of e^{−|a|} (so at most ~EXP_ULP + 1 ulp).
fn sigmoid_err(c: &[f64; 5], lambda: f64, x: f64) -> f64 {
    let (g, mag) = quartic(c, lambda);
    let u = (x.clamp(-10.0, 10.0) - FRAC_PI_2).abs();
    0.25 * (4.0 * EPS * mag * u + g.abs() * (HALF_PI_F32_ERR + 2.0 * EPS * u)) + (EXP_ULP + 4.0) * EPS
}

/// Error bound of the f32 warped coordinate s = ½ + ½ tanh(A/2)·inv_edge (isg_lut_warp): the
/// angle's error (f32 π/2, and the rounding of x − π/2 carried through A = t(C1 + C3 t²)) times
/// ds/dx; tanh(A/2) through one exp, where 1 − e^{−|A|} makes exp's error absolute (EXP_ULP ε)
/// rather than relative, times inv_edge = 1/tanh(edge), itself relative (EXP_ULP ε)/tanh(edge).
fn warp_err(x: f64, lambda: f64) -> f64 {
    let sq = lambda.max(0.0).sqrt().max(ISG_LUT_SQ_MIN);
    let arg = |u: f64| {
        let t = sq * u;
        t * (ISG_LUT_C1 + ISG_LUT_C3 * t * t)
    };
    let edge = arg(FRAC_PI_2);
    let th_edge = (0.5 * edge).tanh();
    let inv_edge = 1.0 / th_edge;
    let u = x.clamp(0.0, PI) - FRAC_PI_2;
    let t = sq * u;
    // ds/dx = ½ inv_edge · ½ sech²(A/2) · A'(x), A' = sq (C1 + 3 C3 t²).
    let a = arg(u);
    let ds_dx = 0.25 * inv_edge * (1.0 - (0.5 * a).tanh().powi(2)) * sq * (ISG_LUT_C1 + 3.0 * ISG_LUT_C3 * t * t);
    let dx = HALF_PI_F32_ERR + 4.0 * EPS * u.abs() * (1.0 + 3.0 * ISG_LUT_C3 * t * t / ISG_LUT_C1);
    let th = (0.5 * a).tanh().abs();
    ds_dx * dx
        + 0.5 * inv_edge * ((EXP_ULP + 4.0) * EPS * (1.0 + th) + th * (EXP_ULP + 4.0) * EPS / th_edge)
        + 2.0 * EPS
}

#[test]
fn isg_twin_matches_cpu() {
    let gpu = test_gpu().expect("GPU");
    let lut = IsgLut::generate_default();
    assert_eq!(lut.values.len(), 8448, "isg_twin.comp expects the default 16 × 16 × 33 table");
    // Steepest change of the table per unit of warped coordinate, over all slices and both axes:
    // turns an error in s into a bound on the interpolated value.
    let n = lut.n;
    let mut slope_s = 0.0f64;
    let mut slope_l = 0.0f64;
    for l in 0..lut.slices {
        for i in 0..n {
            for j in 0..n {
                let v = lut.values[(l * n + i) * n + j] as f64;
                if i + 1 < n {
                    slope_s = slope_s.max((lut.values[(l * n + i + 1) * n + j] as f64 - v).abs());
                }
                if j + 1 < n {
                    slope_s = slope_s.max((lut.values[(l * n + i) * n + j + 1] as f64 - v).abs());
                }
                if l + 1 < lut.slices {
                    slope_l = slope_l.max((lut.values[((l + 1) * n + i) * n + j] as f64 - v).abs());
                }
            }
        }
    }
    let slope_s = slope_s * (n - 1) as f64;

    let mut rng = Pcg32::new(8, 13);
    let special = [0.0, 1e-4, 9.99e-4, 1e-3, 1.001e-3, 1e-2, 1.0, 3.0, 100.0, 1e4, 1e5, 2e5];
    let mut cases: Vec<[f32; IN]> = Vec::new();
    for c in 0..600 {
        let lambda = if c < 2 * special.len() { special[c % special.len()] } else { log_uniform(&mut rng, 1e-4, 1e5) };
        let w = 1.0 / lambda.max(1e-4).sqrt();
        let angle = |rng: &mut Pcg32, k: usize| match (c + k) % 6 {
            0 => rng.uniform(0.0, PI),
            1 => (FRAC_PI_2 + w * rng.uniform(-4.0, 4.0)).clamp(0.0, PI), // the transition
            2 => [0.0, PI, FRAC_PI_2][(c / 6) % 3],                       // ends and centre
            3 => [-0.1, PI + 0.2][(c / 6) % 2],                           // outside: clamped
            _ => (FRAC_PI_2 + w * rng.uniform(-1.0, 1.0)).clamp(0.0, PI),
        };
        let (mut t0, mut t1) = (angle(&mut rng, 0), angle(&mut rng, 1));
        let (mut p0, mut p1) = (angle(&mut rng, 2), angle(&mut rng, 3));
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        if p0 > p1 {
            std::mem::swap(&mut p0, &mut p1);
        }
        cases.push([t0 as f32, t1 as f32, p0 as f32, p1 as f32, lambda as f32]);
    }
    let mut input = lut.values.clone();
    input.extend(cases.iter().flatten());
    let out =
        run_f32_kernel(&gpu, "tests/isg_twin.comp", &input, cases.len() * OUT, cases.len() as u32).expect("kernel");
    assert_all_finite(&out, OUT);
    let mut ck = Checker::default();
    for (ci, x) in cases.iter().enumerate() {
        let o = &out[ci * OUT..(ci + 1) * OUT];
        let [t0, t1, p0, p1, lambda] = x.map(|v| v as f64);

        // [0] σ_θ σ_φ: each factor ≤ 1, so the errors add.
        let tol = sigmoid_err(&PAPER_G, lambda, t1) + sigmoid_err(&PAPER_H, lambda, p1) + 2.0 * EPS;
        ck.check("paper", ci, o[0], isg::isg_paper(t1, p1, lambda), tol);
        // [2] (σθ1 − σθ0)(σφ1 − σφ0): four sigmoids, factors ≤ 1.
        let tol = sigmoid_err(&PAPER_G, lambda, t0)
            + sigmoid_err(&PAPER_G, lambda, t1)
            + sigmoid_err(&PAPER_H, lambda, p0)
            + sigmoid_err(&PAPER_H, lambda, p1)
            + 4.0 * EPS;
        ck.check("paper patch", ci, o[2], isg::isg_paper_patch(t0, t1, p0, p1, lambda), tol);

        // [5] the warp itself.
        ck.check("lut warp", ci, o[5], isg::isg_lut_warp(t1, lambda), warp_err(t1, lambda));
        // [1] trilinear lookup: the warps' errors times the steepest table slope per unit s, the
        // slice position's error (f32 log: LOG_ABS + 3 ulp of ln λ, over Δ ln λ) times the
        // steepest slice-to-slice change, and ~8 roundings of the interpolation.
        let dl = (LOG_ABS + 3.0 * EPS * lambda.max(1e-30).ln().abs()) / lut.d_ln_lambda;
        let corner = |t: f64, p: f64| slope_s * (warp_err(t, lambda) + warp_err(p, lambda)) + slope_l * dl + 8.0 * EPS;
        ck.check("lut", ci, o[1], lut.eval(t1, p1, lambda), corner(t1, p1));
        // [3] four corners.
        let tol = corner(t0, p0) + corner(t0, p1) + corner(t1, p0) + corner(t1, p1);
        ck.check("lut patch", ci, o[3], lut.patch(t0, t1, p0, p1, lambda), tol);
        // [4] 2π(1 − e^{−λ})/λ: a 3-term series below 1e-3 (truncation λ³/24), else the
        // cancellation of 1 − e^{−λ} turns exp's error relative: (EXP_ULP + λ) ε e^{−λ}/(1 − e^{−λ}).
        let norm = isg::isg_normalization(lambda);
        let rel = if lambda < 1e-3 {
            lambda.powi(3) / 24.0 + 6.0 * EPS
        } else {
            let e = (-lambda).exp();
            (EXP_ULP + 2.0 * lambda) * EPS * e / (1.0 - e) + 6.0 * EPS
        };
        ck.check("normalization", ci, o[4], norm, rel * norm);
    }
    ck.report("isg twin");
    gpu.shutdown().expect("clean teardown");
}
