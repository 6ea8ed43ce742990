//! GPU (f32 GLSL, shaders-glsl/common/brdf.glsl) vs CPU (f64, engine_math::brdf) twins through
//! shaders-glsl/tests/brdf_twin.comp (layout documented there): the exact specular BRDF, the
//! sampling density over light directions, the tangent, and the SG lobes per point, for random
//! materials of the four models (exponents up to 1e4, α down to 0.02; Lafortune with random C, Phong
//! among them, half of the others with three lobes) and random geometry including grazing
//! views. The CPU twin sees exactly the f32 inputs (the material as uploaded).
//!
//! Tolerances: the BRDFs are exp of an argument E up to the model's sharpness (s, n_u, n_v or
//! 1/α²); f32 rounding of n·h and of the logarithm perturbs it by a few ulp times E, so values are
//! compared relatively at `256 EPS (1 + E)` (the Fresnel and Smith factors add a few ulp); lobe weights (products of cosines c) at
//! `1e-4 + 16 EPS / min c` relative. Where a sign test (n·l, n·v, v·h > 0) is within 1e-4
//! of its threshold the f32 and f64 branches may differ, and those outputs are not compared.

mod twin;

use engine::gpu::testing::{run_f32_kernel, test_gpu};
use engine::math::brdf::{self, HalfVectorFit, SpecularModel};
use engine::math::rng::Pcg32;
use engine::math::sg::Ndf;
use engine::resources::layout::GpuMaterial;
use engine::scene::{Brdf, LafortuneLobe, Material};
use glam::Vec3;
use twin::*;

const IN: usize = 37;
const OUT: usize = 56;

struct Case {
    material: GpuMaterial,
    model: SpecularModel,
    fit: HalfVectorFit,
    sharpness: f64,
    n: [f32; 3],
    v: [f32; 3],
    l: [f32; 3],
}

fn random_material(rng: &mut Pcg32, c: usize) -> (Material, f64) {
    let ks = Vec3::new(rng.uniform(0.0, 1.0) as f32, rng.uniform(0.0, 1.0) as f32, rng.uniform(0.0, 1.0) as f32);
    let mut m = Material::diffuse(Vec3::splat(0.5));
    m.specular = ks;
    let tangent = f32v(rng.unit_vector());
    m.tangent = Vec3::from_array(tangent);
    let sharp = match c % 5 {
        0 => {
            m.shininess = log_uniform(rng, 1.0, 1e4) as f32;
            m.shininess as f64
        }
        1 | 2 => {
            let alpha = log_uniform(rng, 0.02, 1.0) as f32;
            m.brdf = Brdf::CookTorrance { ndf: if c % 5 == 1 { Ndf::Beckmann } else { Ndf::Ggx }, roughness: alpha };
            1.0 / (alpha as f64 * alpha as f64)
        }
        4 => {
            let e = log_uniform(rng, 1.0, 1e4) as f32;
            let c = if c % 10 == 4 {
                engine::scene::PHONG_C
            } else {
                [-rng.uniform(0.3, 1.0) as f32, -rng.uniform(0.3, 1.0) as f32, rng.uniform(-1.0, 1.0) as f32]
            };
            // Every other non-Phong Lafortune material holds three lobes (random C, e, weights).
            let mut more = [LafortuneLobe::default(); 2];
            if c[0] != -1.0 && rng.uniform(0.0, 1.0) < 0.5 {
                for lobe in &mut more {
                    let c =
                        [rng.uniform(-1.0, 1.0) as f32, rng.uniform(-1.0, 1.0) as f32, rng.uniform(-1.0, 1.0) as f32];
                    *lobe = LafortuneLobe { c, e: log_uniform(rng, 1.0, 1e3) as f32, w: rng.uniform(0.05, 2.0) as f32 };
                }
            }
            m.brdf = Brdf::Lafortune { c, e, more };
            more.iter().fold(e, |a, l| a.max(l.e)) as f64
        }
        _ => {
            let (nu, nv) = (log_uniform(rng, 1.0, 1e4) as f32, log_uniform(rng, 1.0, 1e4) as f32);
            m.brdf = Brdf::AshikhminShirley { nu, nv };
            nu.max(nv) as f64
        }
    };
    (m, sharp)
}

fn cases() -> Vec<Case> {
    let mut rng = Pcg32::new(2718, 3);
    // The Ashikhmin–Shirley fit costs a few ms per material: share materials between cases.
    let materials: Vec<(Material, f64)> = (0..32).map(|c| random_material(&mut rng, c)).collect();
    let mut out = Vec::new();
    for c in 0..1024 {
        let (m, sharpness) = materials[c % materials.len()];
        let material = GpuMaterial::from_material(&m);
        let model = m.specular_model();
        let mut fit = HalfVectorFit::new(&model);
        // The GPU reads the fit as f32.
        match model {
            SpecularModel::BlinnPhong { .. } | SpecularModel::Lafortune { .. } => {}
            SpecularModel::CookTorrance { .. } => {
                fit.lambda_h = material.brdf[1] as f64;
                fit.mu[0] = material.brdf[2] as f64;
            }
            SpecularModel::AshikhminShirley { .. } => {
                fit.lambda_h = material.brdf[2] as f64;
                fit.delta = material.brdf[3] as f64;
                fit.mu = material.lobes.map(|x| x as f64);
            }
        }
        let n = normalize(rng.unit_vector());
        let (t, b) = brdf::orthonormal_basis(n);
        // View: from normal incidence to grazing (n·v down to 1e-4).
        let cos_v = match c % 5 {
            0 => 1e-4,
            1 => 1e-2,
            _ => rng.uniform(0.05, 1.0),
        };
        let phi = rng.uniform(0.0, 2.0 * std::f64::consts::PI);
        let sin_v = (1.0 - cos_v * cos_v).sqrt();
        let v = normalize(madd(madd(madd([0.0; 3], cos_v, n), sin_v * phi.cos(), t), sin_v * phi.sin(), b));
        // Light: near the mirror direction (the lobe) or anywhere above.
        let r = madd(madd([0.0; 3], 2.0 * dot(n, v), n), -1.0, v);
        let l = if c % 2 == 0 {
            normalize(madd(r, rng.uniform(0.0, 0.3) / sharpness.sqrt().max(1.0), rng.unit_vector()))
        } else {
            let mut l = rng.unit_vector();
            if dot(l, n) < 0.0 {
                l = madd(l, -2.0 * dot(l, n), n);
            }
            l
        };
        out.push(Case { material, model, fit, sharpness, n: f32v(n), v: f32v(v), l: f32v(normalize(l)) });
    }
    out
}

#[test]
fn brdf_glsl_matches_f64_twin() {
    let cases = cases();
    let mut input = Vec::with_capacity(cases.len() * IN);
    for c in &cases {
        let m = bytemuck::cast_slice::<GpuMaterial, f32>(std::slice::from_ref(&c.material));
        input.extend_from_slice(m);
        input.extend_from_slice(&c.n);
        input.extend_from_slice(&c.v);
        input.extend_from_slice(&c.l);
    }
    let gpu = test_gpu().expect("gpu");
    let out =
        run_f32_kernel(&gpu, "tests/brdf_twin.comp", &input, cases.len() * OUT, cases.len() as u32).expect("kernel");
    gpu.shutdown().expect("clean teardown");
    assert_all_finite(&out, OUT);
    let mut ck = Checker::default();
    let mut compared = [0usize; 3];
    for (i, c) in cases.iter().enumerate() {
        let o = &out[i * OUT..(i + 1) * OUT];
        let (n, v, l) = (f64v(c.n), f64v(c.v), f64v(c.l));
        let ks = [c.material.specular[0] as f64, c.material.specular[1] as f64, c.material.specular[2] as f64];
        let dir = [c.material.tangent[0] as f64, c.material.tangent[1] as f64, c.material.tangent[2] as f64];
        let t = brdf::tangent_from_direction(n, dir);
        for k in 0..3 {
            ck.check("tangent", i, o[4 + k], t[k], 1e-5);
        }
        let rel = 256.0 * EPS * (1.0 + c.sharpness);
        let h = normalize([v[0] + l[0], v[1] + l[1], v[2] + l[2]]);
        let clear = |x: f64| x.abs() > 1e-4;
        if clear(dot(n, l)) && clear(dot(n, v)) && clear(dot(v, h)) {
            let f = brdf::specular_brdf(&c.model, ks, n, t, v, l);
            let scale = f.iter().fold(0.0f64, |a, b| a.max(*b));
            for k in 0..3 {
                ck.check("f_s", i, o[k], f[k], rel * f[k].abs() + 1e-6 * scale + 1e-30);
            }
            let p = brdf::dir_pdf(&c.model, n, t, v, l);
            ck.check("dir pdf", i, o[3], p, rel * p + 1e-30);
            compared[0] += 1;
        }
        let lobes = brdf::specular_lobes(&c.model, &c.fit, ks, n, t, v);
        let wmax = lobes.iter().flat_map(|x| x.weight).fold(0.0f64, |a, b| a.max(b.abs()));
        for (j, lobe) in lobes.iter().enumerate() {
            let q = &o[7 + 7 * j..14 + 7 * j];
            // v·h_j of this lobe (h_j = normalize(axis + v)), and n·l_j.
            let hv = madd(lobe.axis, 1.0, v);
            let vh = dot(v, normalize(hv));
            let nl = dot(n, normalize(lobe.axis));
            for (&got, &want) in q[..3].iter().zip(&lobe.axis) {
                ck.check("lobe axis", i, got, want, 1e-5 * (1.0 + 1.0 / vh.abs().max(1e-3)));
            }
            ck.check("lobe λ", i, q[3], lobe.lambda, lobe.lambda * (1e-5 + 4.0 * EPS / vh.abs().max(1e-6)));
            if clear(nl) && clear(vh) {
                // The weights are products of cosines: f32 rounding of a cosine c is ~EPS/c relative.
                let small = nl.abs().min(vh.abs()).min(dot(n, v).max(1e-3));
                for k in 0..3 {
                    let w = lobe.weight[k];
                    // Lafortune's weight holds g^e = exp(e ln g): f32 rounds it like the BRDF.
                    let lafortune = matches!(c.model, SpecularModel::Lafortune { .. });
                    let sharp = if lafortune { rel } else { 0.0 };
                    let tol = (1e-4 + 16.0 * EPS / small + sharp) * w.abs() + 1e-5 * wmax + 1e-30;
                    ck.check("lobe weight", i, q[4 + k], w, tol);
                }
                compared[1] += 1;
            }
        }
        compared[2] += lobes.len();
    }
    ck.report("brdf.glsl twins");
    eprintln!("compared: {} f_s/pdf cases, {} lobe weights of {} lobes", compared[0], compared[1], compared[2]);
    assert!(compared[0] > 700 && compared[1] > 1500, "{compared:?}");
}
