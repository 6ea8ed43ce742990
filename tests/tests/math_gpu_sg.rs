//! GPU (f32 GLSL, shaders-glsl/common/sg.glsl) vs CPU (f64, engine_math::sg) twins through
//! shaders-glsl/tests/sg_twin.comp (layout documented there: 16 floats in, 13 out per case).
//!
//! Tolerances are error bounds of the f32 arithmetic in units of EPS = 2⁻²⁴, with `exp` accurate
//! to (EXP_ULP + 2|x|) ulp and `log` to 2⁻²¹ absolute on [0.5, 2], else 3 ulp (twin/mod.rs; the
//! last test here checks those bounds on the device). The CPU twin sees exactly the f32 inputs,
//! so only the arithmetic differs.

mod twin;

use engine::gpu::testing::{run_f32_kernel, test_gpu};
use engine::math::rng::Pcg32;
use engine::math::sg::{self, Sg};
use twin::*;

const IN: usize = 16;
const OUT: usize = 13;

/// Relative error bound of the f32 `(1 − e^{−2λ})/λ` of sg.glsl: below 1e-3 a 3-term series
/// (truncation (4/3)λ³/2 relative, < 1e-9); above, `1 − exp(−2λ)` cancels: the exp error
/// (EXP_ULP + 4λ) ulp of e^{−2λ} is divided by 1 − e^{−2λ} (≈ 2λ for small λ: 4e-4 relative
/// allowed at λ = 1e-3; lavapipe measures 2e-5).
fn unit_integral_rel_tol(lambda: f64) -> f64 {
    if lambda < 1e-3 {
        8.0 * EPS + lambda.powi(3)
    } else {
        let e = (-2.0 * lambda).exp();
        8.0 * EPS + (EXP_ULP + 4.0 * lambda) * EPS * e / (1.0 - e)
    }
}

struct Case {
    a1: [f32; 3],
    l1: f32,
    mu1: f32,
    a2: [f32; 3],
    l2: f32,
    mu2: f32,
    v: [f32; 3],
    n: [f32; 3],
}

impl Case {
    fn pack(&self) -> [f32; IN] {
        let mut x = [0.0f32; IN];
        x[0..3].copy_from_slice(&self.a1);
        x[3] = self.l1;
        x[4] = self.mu1;
        x[5..8].copy_from_slice(&self.a2);
        x[8] = self.l2;
        x[9] = self.mu2;
        x[10..13].copy_from_slice(&self.v);
        x[13..16].copy_from_slice(&self.n);
        x
    }
}

fn cases() -> Vec<Case> {
    let mut rng = Pcg32::new(3141, 5);
    // Sharpness: 0, the series/exp switch at 1e-3, the range ends 1e-4 and 1e5.
    let special = [0.0, 1e-4, 9.99e-4, 1e-3, 1.001e-3, 0.01, 0.5, 1.0, 30.0, 1e3, 1e4, 1e5];
    let mut out = Vec::new();
    for c in 0..512 {
        let a1 = rng.unit_vector();
        let l1 = if c < special.len() * 4 { special[c % special.len()] } else { log_uniform(&mut rng, 1e-4, 1e5) };
        let l2 = match c % 5 {
            0 => l1, // equal sharpness: exactly antipodal axes give |p| = 0
            1 => special[(c / 5) % special.len()],
            _ => log_uniform(&mut rng, 1e-4, 1e5),
        };
        let a2 = match c % 7 {
            0 => a1.map(|x| -x),                                           // antipodal
            1 => normalize(madd(a1.map(|x| -x), 1e-3, rng.unit_vector())), // nearly antipodal
            2 => a1,                                                       // coincident
            3 => normalize(madd(a1, 1e-4, rng.unit_vector())),             // nearly coincident
            _ => rng.unit_vector(),
        };
        let v = match c % 4 {
            0 => a1,                                                             // peak
            1 => normalize(madd(a1, rng.uniform(1e-4, 0.1), rng.unit_vector())), // near the peak
            2 => a1.map(|x| -x),                                                 // opposite: e^{−2λ}
            _ => rng.unit_vector(),
        };
        let n = match c % 3 {
            0 => normalize(cross(v, rng.unit_vector())), // grazing: n ⟂ v, |n·v| → clamp 1e-6
            1 => normalize(madd(normalize(cross(v, rng.unit_vector())), rng.uniform(-1e-4, 1e-4), v)),
            _ => rng.unit_vector(),
        };
        let mu1 = log_uniform(&mut rng, 1e-3, 1e3);
        let mu2 = if c % 11 == 0 { 1e-30 } else { log_uniform(&mut rng, 1e-3, 1e3) };
        out.push(Case {
            a1: f32v(a1),
            l1: l1 as f32,
            mu1: mu1 as f32,
            a2: f32v(a2),
            l2: l2 as f32,
            mu2: mu2 as f32,
            v: f32v(v),
            n: f32v(n),
        });
    }
    out
}

#[test]
fn sg_twin_matches_cpu() {
    let gpu = test_gpu().expect("GPU");
    let cases = cases();
    let input: Vec<f32> = cases.iter().flat_map(|c| c.pack()).collect();
    let out =
        run_f32_kernel(&gpu, "tests/sg_twin.comp", &input, cases.len() * OUT, cases.len() as u32).expect("kernel");
    assert_all_finite(&out, OUT);
    let mut ck = Checker::default();
    for (ci, c) in cases.iter().enumerate() {
        let o = &out[ci * OUT..(ci + 1) * OUT];
        let (a1, a2, v, n) = (f64v(c.a1), f64v(c.a2), f64v(c.v), f64v(c.n));
        let (l1, l2, mu1, mu2) = (c.l1 as f64, c.l2 as f64, c.mu1 as f64, c.mu2 as f64);
        let g1 = Sg { axis: a1, lambda: l1, mu: mu1 };
        let g2 = Sg { axis: a2, lambda: l2, mu: mu2 };

        // sg_eval = μ e^{−x}, x = λ|v − a|²/2: x carries ~6 roundings (relative), the exp
        // EXP_ULP + 2x ulp, μ· one more; below the smallest normal f32 the GPU may flush to 0.
        let w = sg::sg_eval(a1, l1, mu1, v);
        let d = madd(v, -1.0, a1);
        let x = 0.5 * l1 * dot(d, d);
        ck.check("eval", ci, o[0], w, (EXP_ULP + 1.0 + 8.0 * x) * EPS * w + F32_MIN_NORMAL);

        // Sphere integral 2πμ(1 − e^{−2λ})/λ.
        let w = sg::sg_integral(l1, mu1);
        ck.check("integral", ci, o[1], w, (unit_integral_rel_tol(l1) + 4.0 * EPS) * w);

        let p = sg::sg_product_log(&g1, &g2);
        // λ = sqrt((λ1 − λ2)² + λ1λ2|a1 + a2|²): ~10 relative roundings (the sums of the
        // antipodal |a1 + a2| are exact by Sterbenz, so no cancellation).
        ck.check("product lambda", ci, o[5], p.lambda, 10.0 * EPS * p.lambda + 1e-30);
        // Axis p/|p|, p = λ1a1 + λ2a2: absolute rounding of p is ~3ε(λ1 + λ2), so the direction
        // error is that over |p| = λ (unbounded where antipodal equal lobes cancel: there any
        // axis is right, as the product is then constant).
        let tol_axis = 6.0 * EPS * (l1 + l2) / p.lambda.max(1e-300) + 6.0 * EPS;
        for k in 0..3 {
            ck.check("product axis", ci, o[2 + k], p.axis[k], tol_axis.min(2.5));
        }
        // ln μ = ln μ1 + ln μ2 + expo, expo = −λ1λ2|a1 − a2|²/(|p| + λ1 + λ2): each log within
        // 2⁻²¹ + 3 ulp, expo ~12 relative roundings, the sum one more per term.
        let expo = p.log_mu - mu1.ln() - mu2.ln();
        let tol_lm = 2.0 * LOG_ABS + 4.0 * EPS * (mu1.ln().abs() + mu2.ln().abs()) + 14.0 * EPS * expo.abs();
        ck.check("product ln mu", ci, o[6], p.log_mu, tol_lm);
        // μ = exp(ln μ): relative error of the argument, plus exp's (EXP_ULP + 2|x|) ulp.
        let w = p.log_mu.exp();
        let tol_mu = (tol_lm + (EXP_ULP + 2.0 * p.log_mu.abs()) * EPS) * w * 1.01 + F32_MIN_NORMAL;
        ck.check("product mu", ci, o[7], w, tol_mu);
        // Inner product exp(ln μ + ln(2π(1 − e^{−2λ})/λ)): as μ, plus the integral's relative
        // error (which becomes absolute through the log) and that log's own error.
        let w = sg::sg_inner_product(&g1, &g2);
        let li = sg::sg_integral(p.lambda, 1.0).ln().abs();
        let arg = (p.log_mu + li).abs();
        let tol_ip =
            (tol_lm + unit_integral_rel_tol(p.lambda) + LOG_ABS + 3.0 * EPS * li + (EXP_ULP + 2.0 * arg) * EPS)
                * w
                * 1.01
                + F32_MIN_NORMAL;
        ck.check("inner product", ci, o[8], w, tol_ip);

        // Half-vector warp: axis = reflect(v, n) normalized (|2(n·v)n − v| = 1, ~8 roundings per
        // component); λ = λ1/(4 max(|n·v|, 1e-6)): the f32 dot has absolute error ≤ 3ε, which
        // is relative 3ε/|n·v| (large at grazing, where the 1e-6 clamp bounds it).
        let wl = sg::warp_half_vector_lobe(n, v, l1, 1.0);
        for k in 0..3 {
            ck.check("warp axis", ci, o[9 + k], wl.axis[k], 10.0 * EPS);
        }
        let ndv = dot(n, v).abs().max(1e-6);
        ck.check("warp lambda", ci, o[12], wl.lambda, wl.lambda * (4.0 * EPS + 4.0 * EPS / ndv) + 1e-30);
    }
    ck.report("sg twin");
    gpu.shutdown().expect("clean teardown");
}

/// The accuracy of the GLSL built-ins that every twin tolerance assumes (twin/mod.rs: EXP_ULP,
/// LOG_ABS, ATAN_ABS), checked on this device with shaders-glsl/tests/transcendentals.comp.
#[test]
fn gpu_builtins_are_as_accurate_as_the_tolerances_assume() {
    let gpu = test_gpu().expect("GPU");
    let n = 4001;
    let xs: Vec<f32> = (0..n).map(|i| -1.0 + 2.0 * i as f32 / (n - 1) as f32).collect();
    let out = run_f32_kernel(&gpu, "tests/transcendentals.comp", &xs, n * 9, n as u32).expect("kernel");
    assert_all_finite(&out, 9);
    let mut worst = [0.0f64; 9];
    for (i, &xf) in xs.iter().enumerate() {
        let o = &out[i * 9..(i + 1) * 9];
        let x = xf as f64;
        // Arguments rounded as the shader rounds them (one f32 operation each).
        let a_exp = (40.0f32 * xf) as f64;
        let a_log1 = (1.0f32 + 0.5 * xf) as f64;
        let a_log2 = (1000.0f32 * (xf + 1.001)) as f64;
        let want = [
            a_exp.exp(),
            a_log1.ln(),
            a_log2.ln(),
            ((4.0f32 * xf) as f64).atan(),
            x.atan2(0.7),
            ((3.0f32 * xf) as f64).sin(),
            ((3.0f32 * xf) as f64).cos(),
            x.asin(),
            x.acos(),
        ];
        let err: Vec<f64> = o.iter().zip(&want).map(|(g, w)| (*g as f64 - w).abs()).collect();
        // exp: (EXP_ULP + 2|x|) ulp, relative.
        worst[0] = worst[0].max(err[0] / (want[0] * (EXP_ULP + 2.0 * a_exp.abs()) * EPS));
        // log: LOG_ABS absolute on [0.5, 2], 3 ulp relative outside.
        for k in [1, 2] {
            let arg = if k == 1 { a_log1 } else { a_log2 };
            let tol = if (0.5..=2.0).contains(&arg) { LOG_ABS } else { 3.0 * EPS * want[k].abs() };
            worst[k] = worst[k].max(err[k] / tol);
        }
        worst[3] = worst[3].max(err[3] / ATAN_ABS);
        worst[4] = worst[4].max(err[4] / ATAN_ABS);
        // sin, cos on [−3, 3]: a few ulp of 1 absolute.
        worst[5] = worst[5].max(err[5] / (4.0 * EPS));
        worst[6] = worst[6].max(err[6] / (4.0 * EPS));
        // asin, acos: recorded only (ratios against ATAN_ABS), the twins do not use them.
        worst[7] = worst[7].max(err[7] / ATAN_ABS);
        worst[8] = worst[8].max(err[8] / ATAN_ABS);
    }
    let names = ["exp", "log near 1", "log", "atan", "atan2", "sin", "cos", "asin (unused)", "acos (unused)"];
    for (name, w) in names.iter().zip(&worst) {
        eprintln!("  {name:<14} worst error / assumed bound {w:.3}");
    }
    for k in 0..7 {
        assert!(worst[k] <= 1.0, "{}: error {} × the bound the twin tolerances assume", names[k], worst[k]);
    }
    gpu.shutdown().expect("clean teardown");
}
