//! Criterion benchmarks of the f64 mathematics (issue 3): SH product and square at n = 4 and 6,
//! the OL, HYB and PS*-2 exponentials, and the ISG per patch (the paper's sigmoid fit against our
//! table evaluator). Run with `cargo bench -p engine-math --bench math`; `cargo test` does not run
//! them. Numbers are recorded in the math README (notes/twins-readme.md).

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use engine_math::isg::{self, IsgLut};
use engine_math::rng::Pcg32;
use engine_math::shexp::{self, ShExp, HYB_DEFAULT_TARGET};
use std::f64::consts::{FRAC_PI_2, PI};
use std::time::Duration;

fn sh(c: &mut Criterion) {
    for n in [4usize, 6] {
        let ctx = ShExp::new(n);
        let t = &ctx.tensor;
        let mut rng = Pcg32::new(7, n as u64);
        let a: Vec<f64> = (0..n * n).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let b: Vec<f64> = (0..n * n).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let mut out = vec![0.0; n * n];
        c.bench_function(&format!("sh product n={n}"), |bch| {
            bch.iter(|| t.product_into(black_box(&a), black_box(&b), &mut out))
        });
        c.bench_function(&format!("sh square n={n}"), |bch| bch.iter(|| t.square_into(black_box(&a), &mut out)));
        // A log-visibility of 8 overlapping blockers (‖f̂‖ of a few units, where OL, HYB and PS*
        // all work); the OL table as the GLSL twin samples it.
        let f = ctx.random_blocker_log(&mut rng, 8);
        let ol = ctx.ol.resampled(shexp::GLSL_OL_SAMPLES);
        c.bench_function(&format!("sh exp OL n={n}"), |bch| bch.iter(|| shexp::exp_ol(&ol, black_box(&f))));
        c.bench_function(&format!("sh exp HYB n={n}"), |bch| {
            bch.iter(|| shexp::exp_hyb(t, &ol, black_box(&f), HYB_DEFAULT_TARGET))
        });
        c.bench_function(&format!("sh exp PS*-2 n={n}"), |bch| bch.iter(|| shexp::exp_ps_star(t, black_box(&f), 2)));
    }
}

/// 256 patches (θ0, θ1, φ0, φ1, λ) around the lobe axis, λ log-uniform in [1e-2, 1e5], patch
/// sides up to 4 lobe widths: the shading loop's mix, each with its own λ (nothing hoisted).
fn patches() -> Vec<[f64; 5]> {
    let mut rng = Pcg32::new(99, 1);
    (0..256)
        .map(|_| {
            let lambda = rng.uniform(1e-2f64.ln(), 1e5f64.ln()).exp();
            let w = (4.0 / lambda.sqrt()).min(FRAC_PI_2);
            let t0 = (FRAC_PI_2 + w * rng.uniform(-1.0, 1.0)).clamp(0.0, PI);
            let p0 = (FRAC_PI_2 + w * rng.uniform(-1.0, 1.0)).clamp(0.0, PI);
            [t0, (t0 + w * rng.uniform(0.0, 0.5)).min(PI), p0, (p0 + w * rng.uniform(0.0, 0.5)).min(PI), lambda]
        })
        .collect()
}

fn isg_bench(c: &mut Criterion) {
    let lut = IsgLut::generate_default();
    let ps = patches();
    let mut g = c.benchmark_group("isg per patch");
    g.throughput(Throughput::Elements(ps.len() as u64));
    g.bench_function("paper fit", |b| {
        b.iter(|| ps.iter().map(|p| isg::isg_paper_patch(p[0], p[1], p[2], p[3], p[4])).sum::<f64>())
    });
    g.bench_function("our LUT", |b| b.iter(|| ps.iter().map(|p| lut.patch(p[0], p[1], p[2], p[3], p[4])).sum::<f64>()));
    g.finish();
    let mut g = c.benchmark_group("isg per evaluation");
    g.throughput(Throughput::Elements(ps.len() as u64));
    g.bench_function("paper fit", |b| b.iter(|| ps.iter().map(|p| isg::isg_paper(p[1], p[3], p[4])).sum::<f64>()));
    g.bench_function("our LUT", |b| b.iter(|| ps.iter().map(|p| lut.eval(p[1], p[3], p[4])).sum::<f64>()));
    g.finish();
}

fn config() -> Criterion {
    Criterion::default().warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(2))
}

criterion_group! { name = benches; config = config(); targets = sh, isg_bench }
criterion_main!(benches);
