//! GPU (f32 GLSL, shaders-glsl/common/tonemap.glsl, the tonemap pass's function) vs CPU (f64,
//! engine_math::tonemap) through shaders-glsl/tests/tonemap_twin.comp (4 floats in, 3 out per case). The CPU twin
//! sees exactly the f32 inputs.
//!
//! A light of radiance 1e38 must render white: the ACES fit's x² overflows f32 from exposed radiance ≈ 1.8e19
//! (inf / inf = NaN), so the fit is clamped before it, and +inf is white. The cases here span
//! ordinary radiance, the fit's shoulder (7.25, where it reaches white, and the clamp at 16), and radiance far
//! above it up to f32::MAX and +inf: every bright case must come out white (≥ 0.999) on the GPU, NaN black.
//!
//! Tolerance per channel: 1e-6 absolute (GLSL `pow` as exp2 · log2 and the fit's dozen roundings on a value in
//! [0, 1]: lavapipe measures 2.3e-7, a quarter of it) plus the conditioning of the f64 result under the f32
//! rounding of the exposed radiance (±4 EPS relative: the product and the fit's first operations).

mod twin;

use engine::gpu::testing::{run_f32_kernel, test_gpu};
use engine::math::rng::Pcg32;
use engine::math::tonemap::tonemap;
use twin::*;

fn cases() -> Vec<[f32; 4]> {
    let mut rng = Pcg32::new(4848, 3);
    let mut out = Vec::new();
    // Ordinary radiance and exposures.
    for _ in 0..2048 {
        let r = [0, 1, 2].map(|_| log_uniform(&mut rng, 1e-8, 1e3) as f32);
        out.push([r[0], r[1], r[2], log_uniform(&mut rng, 1e-3, 1e3) as f32]);
    }
    // The shoulder: exposed radiance 1 .. 32 (white from ≈ 7.25, the clamp at 16).
    for _ in 0..512 {
        let x = log_uniform(&mut rng, 1.0, 32.0) as f32;
        out.push([x, x * 0.5, x * 2.0, 1.0]);
    }
    // Far above: up to f32::MAX and +inf, at the exposures `--exposure` takes (1e-6 .. 1e6).
    for x in [1e10f32, 1.8e19, 2e19, 1e20, 1e30, 1.1e36, 1e38, f32::MAX, f32::INFINITY] {
        for e in [1e-6f32, 1.0, 1e6] {
            if (x as f64) * (e as f64) >= 16.0 {
                out.push([x, x, x, e]);
            }
        }
    }
    // Black: NaN, negative, -inf, zero.
    out.push([f32::NAN, -1.0, f32::NEG_INFINITY, 1.0]);
    out.push([0.0, -0.0, -1e38, 1e6]);
    out
}

#[test]
fn tonemap_gpu_matches_cpu_and_bright_is_white() {
    let cases = cases();
    let input: Vec<f32> = cases.iter().flatten().copied().collect();
    let gpu = test_gpu().expect("GPU");
    let out =
        run_f32_kernel(&gpu, "tests/tonemap_twin.comp", &input, cases.len() * 3, cases.len() as u32).expect("kernel");
    gpu.shutdown().expect("clean teardown");
    assert_all_finite(&out, 3);
    let names = ["r", "g", "b"];
    let mut checker = Checker::default();
    let (mut white, mut black) = (0, 0);
    for (i, c) in cases.iter().enumerate() {
        let radiance = [c[0] as f64, c[1] as f64, c[2] as f64];
        let exposure = c[3] as f64;
        let want = tonemap(radiance, exposure);
        for j in 0..3 {
            let got = out[i * 3 + j];
            let exposed = radiance[j] * exposure;
            let f = |s: f64| tonemap([radiance[j] * s; 3], exposure)[0];
            let cond = (f(1.0 + 4.0 * EPS) - want[j]).abs().max((f(1.0 - 4.0 * EPS) - want[j]).abs());
            checker.check(names[j], i, got, want[j], 1e-6 + cond);
            if exposed >= 16.0 {
                assert!(got >= 0.999, "case {i}: exposed radiance {exposed:e} gave {got}, not white");
                white += 1;
            }
            if exposed.is_nan() || exposed <= 0.0 {
                assert_eq!(got, 0.0, "case {i}: exposed radiance {exposed} gave {got}, not black");
                black += 1;
            }
        }
    }
    checker.report("tonemap");
    eprintln!("{white} channels white, {black} black of {}", cases.len() * 3);
    assert!(white > 100 && black >= 6, "the cases reach both ends ({white} white, {black} black)");
}
