//! GPU (f32 GLSL, shaders-glsl/common/shading.glsl) vs CPU (f64, engine_math::shading) twins through
//! shaders-glsl/tests/shading_twin.comp (9 floats in, 6 out per case). The CPU twin sees exactly the
//! f32 inputs.
//!
//! The side choices (`n_g·v < 0`, `n_s·n_g < 0`) are discontinuous by design; the cases keep those
//! dot products at least 1e-4 from 0 so that f32 and f64 choose the same side (the choice itself is
//! then compared exactly through the geometric normal). The adaptation is continuous (module doc of
//! engine_math::shading), so its branch needs no such margin. Tolerance per component:
//! `8 EPS / (|lifted| |v + r̂|) + conditioning` (the adaptation divides by those two lengths, so the
//! f32 rounding of the vectors it normalizes is relative to them; `|v + r̂|` = 2 n·v is small for
//! edge-on views), the conditioning being the first-order bound on the change of the f64
//! result when all nine inputs move by up to ±2 EPS (the f32 evaluation's rounding, carried back to
//! its inputs: a dozen operations on unit-scale quantities).

mod twin;

use engine::gpu::testing::{run_f32_kernel, test_gpu};
use engine::math::rng::Pcg32;
use engine::math::shading::{adapt_shading_normal_detail, shading_normals};
use twin::*;

const IN: usize = 9;
const OUT: usize = 6;

/// `a` rotated by `angle` towards a random direction perpendicular to it.
fn tilt(a: [f64; 3], angle: f64, rng: &mut Pcg32) -> [f64; 3] {
    loop {
        let c = cross(a, rng.unit_vector());
        let l = dot(c, c).sqrt();
        if l > 1e-3 {
            let t = c.map(|x| x / l);
            return normalize(madd(a.map(|x| x * angle.cos()), angle.sin(), t));
        }
    }
}

fn cases() -> Vec<[[f32; 3]; 3]> {
    let mut rng = Pcg32::new(1515, 5);
    let mut out = Vec::new();
    while out.len() < 4096 {
        let c = out.len();
        let n_g = rng.unit_vector();
        // The view: steep, grazing (the silhouettes), edge-on within 1e-4, anywhere, from behind.
        let elevation = match c % 5 {
            0 => rng.uniform(0.3, 1.5),
            1 => log_uniform(&mut rng, 1e-3, 0.2),
            2 => log_uniform(&mut rng, 1e-4, 1e-3),
            3 => rng.uniform(-1.5, 1.5),
            _ => -log_uniform(&mut rng, 1e-3, 0.5),
        };
        let v = tilt(n_g, std::f64::consts::FRAC_PI_2 - elevation, &mut rng);
        // The shading normal: the geometric one (per vertex), a smooth mesh's small tilt, a tilt away
        // from the viewer past the silhouette, anywhere, exactly the view.
        let n_s = match c % 7 {
            0 => n_g,
            1 | 2 => tilt(n_g, log_uniform(&mut rng, 1e-3, 0.5), &mut rng),
            3 | 4 => {
                // In the plane of n_g and v, away from v by more than the view's elevation.
                let t = normalize(madd(v, -dot(v, n_g), n_g));
                let beta = elevation.abs() + rng.uniform(-0.05, 0.6);
                normalize(madd(n_g.map(|x| x * beta.cos()), -beta.sin(), t))
            }
            5 => rng.unit_vector(),
            _ => v,
        };
        let f = [f32v(n_s), f32v(n_g), f32v(v)];
        let (s64, g64, v64) = (f64v(f[0]), f64v(f[1]), f64v(f[2]));
        if dot(g64, v64).abs() < 1e-4 || dot(s64, g64).abs() < 1e-4 {
            continue;
        }
        out.push(f);
    }
    out
}

/// Bound on the change of the twin's outputs when every input component moves by up to ±d: the sum
/// over the nine components of the larger change of the two one-sided moves (first order).
fn conditioning(x: [[f64; 3]; 3], d: f64) -> [f64; OUT] {
    let flat = |(s, g): ([f64; 3], [f64; 3])| [s[0], s[1], s[2], g[0], g[1], g[2]];
    let base = flat(shading_normals(x[0], x[1], x[2]));
    let mut total = [0.0f64; OUT];
    for k in 0..9 {
        let mut worst = [0.0f64; OUT];
        for sign in [-1.0, 1.0] {
            let mut y = x;
            y[k / 3][k % 3] += sign * d;
            let o = flat(shading_normals(y[0], y[1], y[2]));
            for j in 0..OUT {
                worst[j] = worst[j].max((o[j] - base[j]).abs());
            }
        }
        for j in 0..OUT {
            total[j] += worst[j];
        }
    }
    total
}

#[test]
fn shading_normals_gpu_matches_cpu() {
    let cases = cases();
    let input: Vec<f32> = cases.iter().flat_map(|c| c.iter().flatten().copied()).collect();
    assert_eq!(input.len(), cases.len() * IN);
    let gpu = test_gpu().expect("GPU");
    let out =
        run_f32_kernel(&gpu, "tests/shading_twin.comp", &input, cases.len() * OUT, cases.len() as u32).expect("kernel");
    gpu.shutdown().expect("clean teardown");
    assert_all_finite(&out, OUT);
    let names = ["shading.x", "shading.y", "shading.z", "geometric.x", "geometric.y", "geometric.z"];
    let mut checker = Checker::default();
    let mut adapted = 0;
    for (i, c) in cases.iter().enumerate() {
        let x = [f64v(c[0]), f64v(c[1]), f64v(c[2])];
        let (s, g) = shading_normals(x[0], x[1], x[2]);
        let want = [s[0], s[1], s[2], g[0], g[1], g[2]];
        let cond = conditioning(x, 2.0 * EPS);
        // Rounding inside the adaptation is relative to the lengths it divides by.
        let s_side = if dot(x[0], g) < 0.0 { x[0].map(|v| -v) } else { x[0] };
        let parts = adapt_shading_normal_detail(s_side, g, x[2]);
        let amplification = 1.0 / (parts.lifted.min(1.0) * parts.half.min(1.0));
        for j in 0..OUT {
            if j >= 3 {
                // The geometric normal is ±n_g: the side choice is exact.
                checker.exact(names[j], i, out[i * OUT + j], want[j]);
            } else {
                checker.check(names[j], i, out[i * OUT + j], want[j], 8.0 * EPS * amplification + cond[j]);
            }
        }
        // The GPU's normal faces the viewer wherever a side is seen.
        let got = [out[i * OUT] as f64, out[i * OUT + 1] as f64, out[i * OUT + 2] as f64];
        let gv = dot(g, x[2]);
        if gv > 1e-3 {
            assert!(dot(got, x[2]) > 0.0, "case {i}: GPU normal faces away ({})", dot(got, x[2]));
        }
        if s != s_side {
            adapted += 1;
        }
    }
    checker.report("shading_normals");
    eprintln!("{adapted} of {} cases adapted", cases.len());
    assert!(adapted > 500, "the cases exercise the adaptation ({adapted})");
}
