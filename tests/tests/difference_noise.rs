//! The noise of the proxy difference (sphere-proxy reference − triangle reference) on the real renderer: the
//! half-split estimate of one run (`lab::converge::combination_noise_sq`) against the noise measured directly
//! from two runs with independent seeds (E|D₁ − D₂|² = 2 Σ Var D), and against √(σ_s² + σ_t²), the references'
//! own noises added as if independent, which the shared random numbers make far too large.

use engine::passes::shade::reference::{ReferenceOptions, ReferenceStats, Visibility};
use engine::renderer::{RenderSettings, Renderer};
use lab::converge::{self, combination_noise_sq, HalfMeans};

#[test]
fn proxy_difference_noise_matches_independent_runs() {
    let gpu = engine_tests::gpu();
    let scene = scenes::build("bunny", None).expect("bunny scene");
    let (w, h, spp) = (48, 36, 256);
    let run = |visibility, seed| -> (ReferenceStats, HalfMeans) {
        let settings = RenderSettings { width: w, height: h, technique: "reference".into(), ..Default::default() };
        let mut r = Renderer::new(&gpu, &scene, settings).expect("renderer");
        let options = ReferenceOptions { samples_per_frame: 16, seed, visibility, ..Default::default() };
        converge::reference_mut(&mut r).expect("reference").set_options(options).expect("options");
        let (report, stats, halves) = converge::converge_until_split(&gpu, &mut r, spp, |_| false).expect("converge");
        r.destroy(&gpu);
        assert_eq!((report.samples, halves.samples_a, halves.samples_b), (spp, spp / 2, spp / 2));
        (stats, halves)
    };
    let (t1, th1) = run(Visibility::Triangles, 1);
    let (s1, sh1) = run(Visibility::Spheres, 1);
    let (t2, th2) = run(Visibility::Triangles, 2);
    let (s2, sh2) = run(Visibility::Spheres, 2);
    gpu.shutdown().expect("clean teardown");

    let mask: Vec<bool> = t1.covered.iter().zip(&s1.covered).map(|(a, b)| *a && *b).collect();
    let (mut norm, mut between) = (0.0f64, 0.0f64);
    for i in (0..mask.len()).filter(|&i| mask[i]) {
        for k in 0..3 {
            norm += (t1.mean[i][k] as f64).powi(2);
            let d1 = s1.mean[i][k] as f64 - t1.mean[i][k] as f64;
            let d2 = s2.mean[i][k] as f64 - t2.mean[i][k] as f64;
            between += (d1 - d2).powi(2);
        }
    }
    let pct = |sq: f64| 100.0 * (sq / norm).sqrt();
    // Independent seeds: Σ Var D measured directly.
    let direct = between / 2.0;
    let est1 = combination_noise_sq(&[(1.0, &sh1), (-1.0, &th1)], &mask);
    let est2 = combination_noise_sq(&[(1.0, &sh2), (-1.0, &th2)], &mask);
    let se_sq = |s: &ReferenceStats| -> f64 {
        (0..mask.len()).filter(|&i| mask[i]).flat_map(|i| s.stderr[i].map(|v| (v as f64).powi(2))).sum()
    };
    let independent = se_sq(&s1) + se_sq(&t1);
    eprintln!(
        "bunny {w}x{h} at {spp} spp: noise of spheres − triangles: half-split {:.3} % / {:.3} % (seeds 1 / 2), \
         from two seeds {:.3} %, √(σ_s² + σ_t²) {:.3} % (σ_t {:.3} %, σ_s {:.3} %)",
        pct(est1),
        pct(est2),
        pct(direct),
        pct(independent),
        pct(se_sq(&t1)),
        pct(se_sq(&s1))
    );
    // Each estimate has a few thousand degrees of freedom but heavy-tailed pixels: 25 % on the variance.
    for est in [est1, est2] {
        assert!((est / direct - 1.0).abs() < 0.25, "half-split {} % vs direct {} %", pct(est), pct(direct));
    }
    assert!(independent > 4.0 * direct, "shared seeds: √(σ_s² + σ_t²) {} % vs {} %", pct(independent), pct(direct));
}
