//! The artefact gate (issue 35): every registered technique (engine::passes::shade::TECHNIQUES) on every
//! registered demo scene (scenes::SCENES, at rest) and every test scene
//! (engine_tests::fixtures::gate_scenes, under the courtyard), at 40 × 30, per pixel, at its default options.
//! A new scene or technique is covered by being registered. Each image must
//!
//! 1. be finite and non-negative, every pixel;
//! 2. have no pixel below 2 % of a cheap sphere-proxy reference (64 spp, the same scene) where that reference is
//!    lit: its luminance, less three of its standard errors, above 5 % of the median luminance of the covered
//!    pixels (so that the reference's noise cannot make a shadow look lit);
//! 3. keep a sane chroma where the reference is lit: no channel whose share of the pixel's R + G + B is a
//!    quarter or less, or four times or more, of its share in the reference, for the channels that carry at
//!    least a tenth of the reference pixel and whose reference value, less three standard errors, is above 0.
//!
//! The sphere-proxy reference is the technique-independent truth of what the techniques approximate: a pixel
//! the proxy lights and a technique leaves black, or tints, is the technique's artefact, not the proxy's. The
//! Monte Carlo `reference` is itself checked at 64 spp with its default (triangle) visibility: the comparison
//! then measures the proxy too. It may leave isolated pixels black, at most [`TRIANGLE_BLACK_SHARE`] of the lit
//! ones: a character of `crowd` is 17 overlapping closed parts (assets/battle/troll.glb), and where two parts
//! meet at a grazing angle the G-buffer can resolve a point a rounding error inside the other part, which every
//! ray then leaves through that part's surface (0 of 128 samples lit at such a pixel; the proxy lights it). A
//! wrong ray offset blackens whole regions (every pixel under a ball) and still fails.
//!
//! Every failure of every pair is collected and printed (scene, technique, check, pixels as (x, y) with the
//! technique's and the reference's values) before the test fails, so one run shows all that remains.

use engine::gpu::Gpu;
use engine::passes::shade::reference::{ReferenceOptions, ReferenceStats, Visibility};
use engine::passes::shade::TECHNIQUES;
use engine::renderer::{RenderSettings, Renderer};
use engine::scene::Scene;
use lab::converge;

const W: u32 = 40;
const H: u32 = 30;
/// Samples per pixel of the sphere-proxy reference and of the `reference` technique.
const SPP: u32 = 64;
/// A pixel is black below this fraction of the reference's luminance.
const BLACK: f64 = 0.02;
/// The reference is lit above this fraction of its median luminance.
const LIT: f64 = 0.05;
/// The share of the lit pixels the triangle reference may leave black (see the module's notes).
const TRIANGLE_BLACK_SHARE: f64 = 0.005;
/// A channel's share of R + G + B may differ from the reference's by less than this factor.
const CHROMA: f64 = 4.0;
/// A channel's share in the reference must be at least this for its chroma to be checked.
const CHROMA_MIN_SHARE: f64 = 0.1;

fn luminance(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// The converged statistics of the reference with `visibility` at [`SPP`] on `r`'s scene.
fn reference(gpu: &Gpu, r: &mut Renderer, visibility: Visibility) -> ReferenceStats {
    r.set_technique(gpu, "reference").expect("reference technique");
    let options = ReferenceOptions { samples_per_frame: 16, seed: 1, visibility, ..Default::default() };
    converge::reference_mut(r).expect("reference").set_options(options).expect("options");
    converge::converge(gpu, r, 0.0, SPP).expect("accumulate").1
}

/// One failed check: what, and the pixels `(x, y, technique RGB, reference RGB)` (the first few).
struct Failure {
    scene: String,
    technique: &'static str,
    check: &'static str,
    count: usize,
    pixels: Vec<(usize, usize, [f32; 3], [f32; 3])>,
}

/// The three checks of one image against the proxy reference.
/// `black_allowed`: black pixels tolerated (0 but for the triangle reference).
fn check(
    scene: &str,
    technique: &'static str,
    hdr: &[f32],
    truth: &ReferenceStats,
    black_allowed: f64,
    out: &mut Vec<Failure>,
) {
    let n = (W * H) as usize;
    let px = |i: usize| [hdr[4 * i], hdr[4 * i + 1], hdr[4 * i + 2]];
    let f64s = |c: [f32; 3]| c.map(|v| v as f64);
    let mut lum: Vec<f64> = (0..n).filter(|&i| truth.covered[i]).map(|i| luminance(f64s(truth.mean[i]))).collect();
    lum.sort_by(f64::total_cmp);
    let median = lum.get(lum.len() / 2).copied().unwrap_or(0.0);
    let lit = |i: usize| {
        let se = f64s(truth.stderr[i]);
        let se_lum =
            (0.2126f64.powi(2) * se[0] * se[0] + 0.7152f64.powi(2) * se[1] * se[1] + 0.0722f64.powi(2) * se[2] * se[2])
                .sqrt();
        truth.covered[i] && luminance(f64s(truth.mean[i])) - 3.0 * se_lum > LIT * median
    };
    let mut failed = |name: &'static str, bad: Vec<usize>| {
        if !bad.is_empty() {
            out.push(Failure {
                scene: scene.to_string(),
                technique,
                check: name,
                count: bad.len(),
                pixels: bad.iter().take(8).map(|&i| (i % W as usize, i / W as usize, px(i), truth.mean[i])).collect(),
            });
        }
    };
    failed("non-finite or negative", (0..n).filter(|&i| !px(i).iter().all(|v| v.is_finite() && *v >= 0.0)).collect());
    let black: Vec<usize> =
        (0..n).filter(|&i| lit(i) && luminance(f64s(px(i))) < BLACK * luminance(f64s(truth.mean[i]))).collect();
    let chroma: Vec<usize> = (0..n)
        .filter(|&i| lit(i) && !black.contains(&i) && px(i).iter().all(|v| v.is_finite() && *v >= 0.0))
        .filter(|&i| {
            let (t, r, se) = (f64s(px(i)), f64s(truth.mean[i]), f64s(truth.stderr[i]));
            let (ts, rs) = (t.iter().sum::<f64>(), r.iter().sum::<f64>());
            (0..3).any(|k| {
                let (share_t, share_r) = (t[k] / ts, r[k] / rs);
                share_r >= CHROMA_MIN_SHARE
                    && r[k] - 3.0 * se[k] > 0.0
                    && !(share_t > share_r / CHROMA && share_t < share_r * CHROMA)
            })
        })
        .collect();
    let lit_count = (0..n).filter(|&i| lit(i)).count();
    let w = W as usize;
    let clustered = black.iter().any(|&i| {
        let (x, y) = (i % w, i / w);
        [(x > 0, i.wrapping_sub(1)), (x + 1 < w, i + 1), (y > 0, i.wrapping_sub(w)), (i + w < n, i + w)]
            .iter()
            .any(|&(inside, j)| inside && black.contains(&j))
    });
    if clustered || black.len() as f64 > black_allowed * lit_count as f64 {
        failed("black where the proxy reference is lit", black.clone());
    } else if !black.is_empty() {
        eprintln!("{scene} × {technique}: {} isolated black pixels of {lit_count} lit (allowed)", black.len());
    }
    failed("chroma off the proxy reference", chroma);
}

/// Every technique on one scene: the failures, and the seconds it took.
fn gate_scene(gpu: &Gpu, name: &str, scene: &Scene, out: &mut Vec<Failure>) -> f64 {
    let t0 = std::time::Instant::now();
    let settings = RenderSettings { width: W, height: H, technique: "none".into(), ..Default::default() };
    let mut r = Renderer::new(gpu, scene, settings).unwrap_or_else(|e| panic!("{name}: {e}"));
    let truth = reference(gpu, &mut r, Visibility::Spheres);
    assert_eq!(truth.nonfinite_samples, 0, "{name}: the proxy reference has non-finite samples");
    assert!(truth.covered.iter().filter(|c| **c).count() > 50, "{name}: too few pixels covered at {W}x{H}");
    for entry in TECHNIQUES {
        let t = std::time::Instant::now();
        let black_allowed = if entry.tolerances.samples > 0 { TRIANGLE_BLACK_SHARE } else { 0.0 };
        let hdr = if entry.tolerances.samples > 0 {
            // Monte Carlo: the default visibility, SPP samples.
            let stats = reference(gpu, &mut r, ReferenceOptions::default().visibility);
            assert_eq!(stats.nonfinite_samples, 0, "{name}: {}: non-finite samples", entry.name);
            r.read_radiance(gpu).expect("radiance")
        } else {
            r.set_technique(gpu, entry.name).unwrap_or_else(|e| panic!("{name}: {}: {e}", entry.name));
            r.render(gpu).and_then(|_| r.read_radiance(gpu)).unwrap_or_else(|e| panic!("{name}: {}: {e}", entry.name))
        };
        let before = out.len();
        check(name, entry.name, &hdr, &truth, black_allowed, out);
        eprintln!(
            "{name} × {}: {} ({:.1} s)",
            entry.name,
            if out.len() == before { "pass".to_string() } else { format!("{} failed checks", out.len() - before) },
            t.elapsed().as_secs_f64()
        );
    }
    r.destroy(gpu);
    t0.elapsed().as_secs_f64()
}

#[test]
fn every_technique_on_every_scene_is_free_of_artefacts() {
    let gpu = engine_tests::gpu();
    let t0 = std::time::Instant::now();
    let mut failures = Vec::new();
    let mut scenes = 0;
    for entry in scenes::SCENES {
        let scene = scenes::build(entry.name, None).unwrap_or_else(|e| panic!("{}: {e:#}", entry.name));
        let s = gate_scene(&gpu, entry.name, &scene, &mut failures);
        eprintln!("{}: {s:.1} s", entry.name);
        scenes += 1;
    }
    let env = engine::scene::load_environment(&scenes::assets_dir().join("envmaps/courtyard.exr")).expect("courtyard");
    for (name, scene) in engine_tests::fixtures::gate_scenes(&env) {
        let s = gate_scene(&gpu, name, &scene, &mut failures);
        eprintln!("{name}: {s:.1} s");
        scenes += 1;
    }
    gpu.shutdown().expect("clean teardown");
    eprintln!(
        "artefact gate: {} techniques × {scenes} scenes at {W}x{H} in {:.0} s, {} failed checks",
        TECHNIQUES.len(),
        t0.elapsed().as_secs_f64(),
        failures.len()
    );
    let report: Vec<String> = failures
        .iter()
        .map(|f| {
            let pixels: Vec<String> = f
                .pixels
                .iter()
                .map(|(x, y, t, r)| {
                    format!("({x}, {y}) {:.3}/{:.3}/{:.3} vs {:.3}/{:.3}/{:.3}", t[0], t[1], t[2], r[0], r[1], r[2])
                })
                .collect();
            format!("{} × {}: {}: {} pixels: {}", f.scene, f.technique, f.check, f.count, pixels.join(", "))
        })
        .collect();
    assert!(failures.is_empty(), "{} failed checks:\n{}", failures.len(), report.join("\n"));
}

/// The checks themselves on a synthetic 40 × 30 image against a synthetic reference: a black pixel, a tinted
/// pixel, a negative and a NaN pixel are each found; a dim reference pixel whose noise reaches 5 % of the median
/// is not called lit; the same image as the reference passes.
#[test]
fn the_checks_find_what_they_name() {
    let n = (W * H) as usize;
    let grey = [0.5f32, 0.4, 0.3];
    let mut truth = ReferenceStats {
        samples: SPP,
        mean: vec![grey; n],
        stderr: vec![[0.01; 3]; n],
        covered: vec![true; n],
        nonfinite_samples: 0,
    };
    // Pixel 7: dim (2 % of the median) with a standard error that reaches past 5 %.
    truth.mean[7] = [0.01, 0.008, 0.006];
    truth.stderr[7] = [0.01; 3];
    let image = |edit: &dyn Fn(&mut Vec<f32>)| {
        let mut hdr: Vec<f32> = truth.mean.iter().flat_map(|c| [c[0], c[1], c[2], 1.0]).collect();
        edit(&mut hdr);
        hdr
    };
    let run_allowing = |hdr: &[f32], black_allowed: f64| {
        let mut out = Vec::new();
        check("synthetic", "test", hdr, &truth, black_allowed, &mut out);
        out.iter().map(|f| (f.check, f.pixels.iter().map(|p| (p.0, p.1)).collect::<Vec<_>>())).collect::<Vec<_>>()
    };
    let run = |hdr: &[f32]| run_allowing(hdr, 0.0);
    assert!(run(&image(&|_| {})).is_empty(), "the reference itself passes");
    // Pixel 7 black: not lit within its noise, so not a failure.
    assert!(run(&image(&|h| h[28..31].copy_from_slice(&[0.0; 3]))).is_empty());
    let black = image(&|h| h[4 * 45..4 * 45 + 3].copy_from_slice(&[0.004, 0.003, 0.002]));
    assert_eq!(run(&black), vec![("black where the proxy reference is lit", vec![(5, 1)])]);
    // The triangle reference's allowance: isolated black pixels up to the share pass; two neighbours, or more
    // isolated pixels than the share, fail.
    assert!(run_allowing(&black, TRIANGLE_BLACK_SHARE).is_empty(), "one isolated pixel is allowed");
    let pair = image(&|h| {
        h[4 * 45..4 * 45 + 3].copy_from_slice(&[0.0; 3]);
        h[4 * 46..4 * 46 + 3].copy_from_slice(&[0.0; 3]);
    });
    assert_eq!(run_allowing(&pair, TRIANGLE_BLACK_SHARE).len(), 1, "two neighbours fail");
    let scattered = image(&|h| {
        for k in 0..8 {
            let i = 4 * (2 * k * W as usize + 3 * k + 100);
            h[i..i + 3].copy_from_slice(&[0.0; 3]);
        }
    });
    assert_eq!(run_allowing(&scattered, TRIANGLE_BLACK_SHARE).len(), 1, "8 of 1199 lit is over 0.5 %");
    // Blue at a twentieth of its share: a tint (R, G within a factor 4 do not count).
    let tinted = image(&|h| h[4 * 81..4 * 81 + 3].copy_from_slice(&[0.5, 0.4, 0.015]));
    assert_eq!(run(&tinted), vec![("chroma off the proxy reference", vec![(1, 2)])]);
    let dimmer = image(&|h| h[4 * 81..4 * 81 + 3].copy_from_slice(&[0.1, 0.08, 0.06]));
    assert!(run(&dimmer).is_empty(), "a darker pixel of the same chroma passes");
    let bad = image(&|h| {
        h[4 * 3] = -1e-3;
        h[4 * 4 + 1] = f32::NAN;
    });
    assert_eq!(run(&bad), vec![("non-finite or negative", vec![(3, 0), (4, 0)])]);
}
