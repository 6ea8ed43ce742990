//! GPU (f32 GLSL, shaders-glsl/common/isg.glsl) vs CPU (f64, engine_math::isg) twins through
//! shaders-glsl/tests/isg_twin.comp: the input starts with the 55808 floats of
//! `IsgLut::generate_default()`, then cases of 5 floats (θ0, θ1, φ0, φ1, λ); 6 floats out per case.
//!
//! Tolerances: f32 arithmetic error bounds in units of EPS = 2⁻²⁴ with exp and log as in
//! twin/mod.rs (checked on the device by math_gpu_sg.rs). Both sides interpolate the same f32
//! table, so the table evaluator differs only through the table coordinates (the slice position is
//! exact: it is read from λ's bits); their f32 errors become value errors by the table's steepest slope.

mod twin;

use engine::gpu::testing::{run_f32_kernel, test_gpu};
use engine::math::isg::{self, IsgLut, ISG_LUT_K_MIN, ISG_LUT_K_SQ, PAPER_G, PAPER_H};
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

/// Error bound of the f32 table coordinate s = clamp(x k + c, 0, 1), k = max(√λ K_SQ, K_MIN),
/// c = ½ − k π/2 (isg_lut_warp): k's relative error (sqrt and a product, 4ε) enters as
/// (x − π/2) δk since c carries −(π/2) δk; the roundings of k π/2, c and x k (|x k|, |c| ≤ 1.5πk + ½)
/// add ~10εk, f32(π/2) adds k·4.4e-8; the clamp only shrinks the error.
fn warp_err(x: f64, lambda: f64) -> f64 {
    let k = (lambda.max(0.0).sqrt() * ISG_LUT_K_SQ).max(ISG_LUT_K_MIN);
    let u = (x - FRAC_PI_2).abs();
    k * (4.0 * EPS * u + 10.0 * EPS + HALF_PI_F32_ERR) + 4.0 * EPS
}

#[test]
fn isg_twin_matches_cpu() {
    let gpu = test_gpu().expect("GPU");
    let lut = IsgLut::generate_default();
    assert_eq!(lut.values.len(), 55808, "isg_twin.comp expects the default 109 × 2 × 64 × vec4 table");
    // Steepest change of a marginal per unit of table coordinate s (entries pack X[i], X[i+1]):
    // turns an error in s into a bound on the interpolated value.
    let slope_s =
        lut.values.chunks(4).map(|e| (e[1] as f64 - e[0] as f64).abs()).fold(0.0, f64::max) * (lut.n - 1) as f64;
    // Error of one interpolated marginal at angle x: the coordinate's error (plus the rounding of
    // s (n − 1), ~2ε in s) times the slope, and the 4 roundings of the two lerps.
    let axis_err = |x: f64, lambda: f64| slope_s * (warp_err(x, lambda) + 2.0 * EPS) + 4.0 * EPS;

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
        // [1] M(θ) N(φ), both ≤ 1: the two marginals' errors add, plus the product's rounding.
        // The slice position is exact on both sides (read from the same f32 λ's bits).
        let tol = axis_err(t1, lambda) + axis_err(p1, lambda) + EPS;
        ck.check("lut", ci, o[1], lut.eval(t1, p1, lambda), tol);
        // [3] (M1 − M0)(N1 − N0), differences ≤ 1: the four marginals' errors add.
        let tol = axis_err(t0, lambda) + axis_err(t1, lambda) + axis_err(p0, lambda) + axis_err(p1, lambda) + 3.0 * EPS;
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

/// Cost of the ISG evaluators on the device, f32 (shaders-glsl/tests/isg_cost.comp): 2²² seeded
/// queries per evaluator (λ log-uniform in [1e-2, 1e5], as the CPU benchmark
/// engine/math/benches/math.rs), timed by GPU timestamps, best of 11 dispatches, less the time of
/// generating the queries alone. Two diagnostics of ours: table reads replaced by arithmetic (the
/// cost of everything but the reads), and the vec4 entries read as 4 scalar floats. A measurement for docs/techniques/isg.md, not a check (no timing is
/// asserted): `cargo test -p engine-tests --test math_gpu_isg -- --ignored --nocapture`.
#[test]
#[ignore]
fn isg_gpu_cost() {
    use engine::gpu::{Binding, BufferDesc};
    const PER: u32 = 32;
    const ROUNDS: usize = 11;
    const QUERIES: u32 = 1 << 22;
    let gpu = test_gpu().expect("GPU");
    let lut = IsgLut::generate_default();
    let table = gpu.upload_buffer("isg-cost-table", BufferDesc::gpu_only(4), &lut.values).expect("table");
    let out = gpu.create_buffer("isg-cost-out", BufferDesc::gpu_only((QUERIES / PER * 4) as u64)).expect("out");
    let mut frame = gpu.create_frame().expect("frame");
    let names = [
        "queries only",
        "paper Ŝ",
        "ours Ŝ",
        "paper patch",
        "ours patch",
        "ours Ŝ, no reads",
        "ours patch, no reads",
        "ours Ŝ, scalar reads",
        "ours patch, scalar reads",
    ];
    let count = QUERIES / PER;
    let pipes: Vec<_> = (0..names.len())
        .map(|k| {
            // The last two: ours with the table reads replaced by arithmetic (what the reads cost).
            let eval = [0, 1, 2, 3, 4, 2, 4, 2, 4][k].to_string();
            let mut defines = vec![("ISG_COST_EVAL", eval.as_str()), ("ISG_COST_PER", "32")];
            if k == 5 || k == 6 {
                defines.push(("ISG_COST_NO_READS", "1"));
            }
            if k >= 7 {
                defines.push(("ISG_COST_SCALAR_READS", "1"));
            }
            gpu.create_compute_pipeline("tests/isg_cost.comp", &defines).expect("pipeline")
        })
        .collect();
    // Rounds over all evaluators, best of ROUNDS each: the machine may be shared, the minimum is the
    // least disturbed run.
    let mut ms = vec![f64::INFINITY; names.len()];
    for _ in 0..ROUNDS {
        for (k, pipe) in pipes.iter().enumerate() {
            let t = gpu
                .run_frame(&mut frame, None, None, |rec| {
                    rec.begin_pass("isg-cost");
                    rec.dispatch(
                        pipe,
                        &[Binding::buffer("Table", &table), Binding::buffer("Output", &out)],
                        bytemuck::bytes_of(&count),
                        [count, 1, 1],
                    )
                })
                .expect("dispatch");
            ms[k] = ms[k].min(t[0].ms);
            let sum: f32 = gpu.read_buffer::<f32>(&out).expect("read").iter().sum();
            assert!(sum.is_finite(), "{}: non-finite results", names[k]);
        }
    }
    for p in pipes {
        gpu.destroy_compute_pipeline(p);
    }
    gpu.destroy_frame(frame);
    gpu.destroy_buffer(table);
    gpu.destroy_buffer(out);
    let ns = |k: usize| (ms[k] - ms[0]) * 1e6 / QUERIES as f64;
    eprintln!("ISG cost on {} (f32, {QUERIES} queries, best of {ROUNDS}):", gpu.info.name);
    eprintln!("  {:<13} {:8.3} ms", names[0], ms[0]);
    for k in 1..names.len() {
        eprintln!("  {:<13} {:8.3} ms  {:6.2} ns per query net", names[k], ms[k], ns(k));
    }
    eprintln!("  ours / paper: Ŝ {:.2}×, patch {:.2}×", ns(2) / ns(1), ns(4) / ns(3));
    gpu.shutdown().expect("clean teardown");
}
