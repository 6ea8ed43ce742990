//! GPU (f32 GLSL) vs CPU (f64) twins of `engine_math::sh` and `engine_math::shexp`:
//! shaders-glsl/tests/sh_twin.comp and shaders-glsl/tests/shexp_twin.comp (layouts documented there).

use engine::gpu::testing::{run_f32_kernel, test_gpu};
use engine::math::rng::Pcg32;
use engine::math::sh::{self, ShTensor};
use engine::math::shexp::{self, ShExp, GLSL_OL_SAMPLES};

fn rel_err(g: &[f32], want: &[f64]) -> f64 {
    let d: f64 = g.iter().zip(want).map(|(a, b)| (*a as f64 - b).powi(2)).sum::<f64>().sqrt();
    d / sh::norm(want).max(1e-30)
}

#[test]
fn sh_twin_matches_cpu() {
    let gpu = test_gpu().expect("GPU");
    let mut rng = Pcg32::new(2024, 1);
    let mut cases: Vec<[f32; 16]> = Vec::new();
    for c in 0..256 {
        let mut x = [0.0f32; 16];
        let d = match c {
            0 => [0.0, 0.0, 0.0],  // degenerate: +z by convention
            1 => [0.0, 0.0, -3.0], // pole, unnormalized
            2 => [0.0, 0.0, 1.0],
            _ => rng.unit_vector().map(|v| v * rng.uniform(0.5, 2.0)),
        };
        x[..3].copy_from_slice(&d.map(|v| v as f32));
        x[3] = (1 + c % sh::MAX_ORDER) as f32;
        for l in 0..8 {
            x[4 + l] = rng.uniform(-2.0, 2.0) as f32;
        }
        let axis = rng.unit_vector();
        x[12..15].copy_from_slice(&axis.map(|v| v as f32));
        cases.push(x);
    }
    let input: Vec<f32> = cases.iter().flatten().copied().collect();
    let out =
        run_f32_kernel(&gpu, "tests/sh_twin.comp", &input, cases.len() * 130, cases.len() as u32).expect("kernel");
    for (c, x) in cases.iter().enumerate() {
        let o = &out[c * 130..(c + 1) * 130];
        let n = x[3] as usize;
        let d = [x[0] as f64, x[1] as f64, x[2] as f64];
        let axis = [x[12] as f64, x[13] as f64, x[14] as f64];
        let fstar: Vec<f64> = (0..n).map(|l| x[4 + l] as f64).collect();
        let y = sh::eval(n, d);
        let mut f = vec![0.0; n * n];
        sh::zh_rotate_star_into(&fstar, axis, &mut f);
        for i in 0..64 {
            let (wy, wf) = if i < n * n { (y[i], f[i]) } else { (0.0, 0.0) };
            // |y| ≤ 1.1 for l ≤ 7; an f32 recurrence of ≤ 8 steps loses ≲ 20 ulps: 1e-5 absolute.
            assert!((o[i] as f64 - wy).abs() < 1e-5, "case {c} n={n} y[{i}]: {} vs {wy}", o[i]);
            // f = f*_l y: scale by |f*| ≤ 2.
            assert!((o[64 + i] as f64 - wf).abs() < 3e-5, "case {c} f[{i}]: {} vs {wf}", o[64 + i]);
        }
        let dot = sh::dot(&y, &f);
        let mag: f64 = y.iter().zip(&f).map(|(a, b)| (a * b).abs()).sum();
        // Sum of ≤ 64 f32 products: relative 1e-5 of the sum of magnitudes.
        assert!((o[128] as f64 - dot).abs() < 1e-5 * (1.0 + mag), "case {c} dot");
        let y4 = sh::eval(4, d);
        let mut f4 = vec![0.0; 16];
        sh::zh_rotate_star_into(&(0..4).map(|l| x[4 + l] as f64).collect::<Vec<_>>(), axis, &mut f4);
        let mag4: f64 = y4.iter().zip(&f4).map(|(a, b)| (a * b).abs()).sum();
        assert!((o[129] as f64 - sh::dot(&y4, &f4)).abs() < 1e-5 * (1.0 + mag4), "case {c} dot4");
    }
    gpu.shutdown().expect("clean teardown");
}

#[test]
fn shexp_twin_matches_cpu() {
    let gpu = test_gpu().expect("GPU");
    let ctx = ShExp::new(4);
    let ol64 = ctx.ol.resampled(GLSL_OL_SAMPLES);
    let t: &ShTensor = &ctx.tensor;
    let mut rng = Pcg32::new(77, 3);
    let degrees = [0usize, 1, 2, 3, 4, 6, 8];
    let mut cases: Vec<[f32; 34]> = Vec::new();
    for c in 0..128 {
        let mut x = [0.0f32; 34];
        // 1..=40 overlapping blockers: ‖f̂‖ from ~0 to > 20.
        let f = ctx.random_blocker_log(&mut rng, 1 + c % 40);
        for i in 0..16 {
            x[i] = f[i] as f32;
            x[16 + i] = rng.uniform(-1.0, 1.0) as f32;
        }
        x[32] = shexp::HYB_DEFAULT_TARGET as f32;
        x[33] = degrees[c % degrees.len()] as f32;
        cases.push(x);
    }
    let input: Vec<f32> = cases.iter().flatten().copied().collect();
    let out =
        run_f32_kernel(&gpu, "tests/shexp_twin.comp", &input, cases.len() * 80, cases.len() as u32).expect("kernel");
    for (c, x) in cases.iter().enumerate() {
        let o = &out[c * 80..(c + 1) * 80];
        let f: Vec<f64> = x[..16].iter().map(|v| *v as f64).collect();
        let b: Vec<f64> = x[16..32].iter().map(|v| *v as f64).collect();
        let p = x[33] as usize;
        // Products: Γ ≤ 0.6, ≤ 194 terms; f32 error ≲ 1e-6 of ‖f‖‖b‖.
        let scale = sh::norm(&f) * sh::norm(&b) + 1e-30;
        let prod = t.product(&f, &b);
        let sq = t.square(&f);
        for i in 0..16 {
            assert!((o[i] as f64 - prod[i]).abs() < 1e-5 * scale, "case {c} product[{i}]");
            assert!((o[16 + i] as f64 - sq[i]).abs() < 1e-5 * sh::norm(&f).powi(2), "case {c} square[{i}]");
        }
        // OL: one interpolated lookup and a scaling: f32 rounding only.
        let e = rel_err(&o[32..48], &shexp::exp_ol(&ol64, &f));
        assert!(e < 1e-5, "case {c} OL rel err {e}");
        // HYB and PS*: up to 7 squarings each double the relative rounding error: 2^7 × 1e-7 ≈
        // 1e-5, plus the series; 1e-4 leaves room for the squaring count picked by f32 log2 at a
        // power-of-two boundary (measured far below on random inputs).
        let e = rel_err(&o[48..64], &shexp::exp_hyb(t, &ol64, &f, shexp::HYB_DEFAULT_TARGET));
        assert!(e < 1e-4, "case {c} HYB rel err {e}");
        let e = rel_err(&o[64..80], &shexp::exp_ps_star(t, &f, p));
        assert!(e < 1e-4, "case {c} PS*-{p} rel err {e}");
    }
    gpu.shutdown().expect("clean teardown");
}
