//! Technique `lobes` on lavapipe: the GPU pass against its f64 twin (engine::passes::shade::lobes::cpu)
//! per receiver, with spherical lights, sphere and plane blockers and hard light placements; and the
//! twin against closed forms: one light without blockers = the analytic lobe integral, a fully
//! hidden light → 0, a half-covered light → the covered fraction; no NaN or inf anywhere; the fitted light
//! weights (no drift, GPU = twin). The BVH cut:
//! far nodes taken whole (GPU = twin, little change against leaves only) and the coarsening retry.

use engine::blockers::{BlockerPlane, Sphere};
use engine::math::brdf::{self, HalfVectorFit};
use engine::math::envmap::LatLongMap;
use engine::math::lobes::clamped_cosine_integral;
use engine::math::sphere_light::{sphere_light_clamped_cosine, sphere_light_sg_integral};
use engine::passes::shade::lobes::cpu::{
    dropped_share, specular_lobes, MaskKind, RgbLobe, Twin, TwinBvh, TwinLight, TwinReceiver,
};
use engine::passes::shade::lobes::{Leaves, LightRule, LobesOptions, MASK_WORK_BUDGET};
use engine::renderer::RenderSettings;
use engine::scene::{Scene, SphereLight};
use engine_tests::{assert_finite, rgb, Receiver};
use glam::{DVec3, Vec3};
use std::f64::consts::PI;

const W: u32 = 40;
const H: u32 = 30;
const ENV: f32 = 0.25;
const C: Vec3 = Vec3::new(0.1, 0.6, -0.1);
const R: f32 = 0.45;
const ALBEDO: [f64; 2] = [0.7, 0.8];

fn scene(lights: Vec<SphereLight>, planes: Vec<BlockerPlane>) -> Scene {
    let mut scene = engine_tests::fixtures::sphere_over_plane(LatLongMap::constant(64, 32, [ENV; 3]), 0.7, C, R);
    scene.lights = lights;
    scene.blockers.planes = planes;
    scene
}

/// The scene of [`scene`] whose ball casts its shadow as `spheres` (in the unit ball's space: world
/// C + R x, radius R r) instead of one sphere.
fn cloud_scene(lights: Vec<SphereLight>, spheres: Vec<Sphere>) -> Scene {
    let mut s = scene(lights, vec![]);
    s.blockers.spheres[1] = Some(spheres);
    s
}

/// `n` × `n` × `n` spheres of radius `r` on a grid of step `step` about `centre` (unit ball space).
fn grid(n: usize, step: f64, r: f64, centre: DVec3) -> Vec<Sphere> {
    let h = 0.5 * (n as f64 - 1.0);
    let mut out = Vec::new();
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let x = DVec3::new(i as f64 - h, j as f64 - h, k as f64 - h) * step;
                out.push(Sphere::new(centre + x, r));
            }
        }
    }
    out
}

/// Render one frame; the radiance, the receivers and the blocker BVH the shader read (its node array
/// and world spheres, read back, so the twin cuts exactly the GPU's tree).
fn render_for_twin(
    gpu: &engine::gpu::Gpu,
    scene: &Scene,
    settings: RenderSettings,
) -> (Vec<f32>, Vec<Receiver>, TwinBvh) {
    let (hdr, g, bvh) = engine_tests::render_with_bvh(gpu, scene, settings);
    (hdr, g, TwinBvh::from_nodes(bvh.nodes, bvh.spheres))
}

fn twin_lights(scene: &Scene) -> Vec<TwinLight> {
    scene
        .lights
        .iter()
        .map(|l| TwinLight {
            center: l.center.as_dvec3(),
            radius: l.radius as f64,
            radiance: l.radiance.as_dvec3().to_array(),
        })
        .collect()
}

/// GPU vs twin, relative to the receiver's unshadowed scale (ρ L_env + Σ U), over every 2nd receiver.
fn compare(gpu: &engine::gpu::Gpu, scene: &Scene, spec: &str, o: &LobesOptions) -> Vec<f64> {
    compare_with_env(gpu, scene, spec, o, None)
}

/// [`compare`]; with `env_lobes` (`env=lobes`) the environment term is the twin's `env_lobe_terms` of
/// those lobes (U − S through the normal's mask, times the planes' visibility) instead of the constant
/// environment's `env_visibility`.
fn compare_with_env(
    gpu: &engine::gpu::Gpu,
    scene: &Scene,
    spec: &str,
    o: &LobesOptions,
    env_lobes: Option<&[RgbLobe]>,
) -> Vec<f64> {
    let settings = RenderSettings { width: W, height: H, technique: spec.into(), ..Default::default() };
    let (hdr, g, world) = render_for_twin(gpu, scene, settings);
    let world = &world;
    assert_finite(&hdr, spec);
    assert!(hdr.iter().all(|v| *v >= 0.0), "{spec}: negative radiance");
    let twin = Twin::new(o).expect("twin tables");
    let lights = twin_lights(scene);
    let eye = scene.camera.eye.as_dvec3();
    let mut errs = Vec::new();
    for (i, px) in g.iter().enumerate().step_by(2) {
        let Some((p, n, m)) = *px else { continue };
        let view = (eye - p).normalize();
        // The material's specular term (none in the diffuse scenes): its cosine lobe for the lights,
        // and its SG lobes against the constant environment times the diffuse visibility.
        let mat = &scene.materials[m];
        let (model, ks) = (mat.specular_model(), mat.specular.as_dvec3().to_array());
        let t = DVec3::from_array(brdf::tangent_from_direction(n.to_array(), mat.tangent.as_dvec3().to_array()));
        let specular = specular_lobes(&model, ks, n, t, view);
        let r = TwinReceiver { p, n, view, rho: [ALBEDO[m]; 3], specular };
        let sg_lobes =
            brdf::specular_lobes(&model, &HalfVectorFit::new(&model), ks, n.to_array(), t.to_array(), view.to_array());
        let (mut want, mut scale) = match env_lobes {
            Some(env) => {
                let (t, v_hs) = twin.env_lobe_terms(&r, env, world, &scene.blockers.planes);
                (t.radiance().map(|x| x * v_hs), t.u.iter().cloned().fold(0.0, f64::max))
            }
            None => {
                let v = twin.env_visibility(p, n, world, &scene.blockers.planes);
                let mut want = [ALBEDO[m] * ENV as f64 * v; 3];
                let glossy = brdf::specular_sum_constant_env(&sg_lobes, [ENV as f64; 3]);
                (0..3).for_each(|c| want[c] += v * glossy[c]);
                (want, ALBEDO[m] * ENV as f64)
            }
        };
        for l in &lights {
            let t = twin.light_terms(&r, l, world, &scene.blockers.planes);
            if !t.outside {
                continue;
            }
            let add = if o.ratio {
                // light=ratio: the exact unshadowed term (the SG closed forms `none` uses) × clamp(1 − S/U).
                assert!(env_lobes.is_none(), "the ratio twin covers env=map");
                let (c, r) = (l.center.to_array(), l.radius);
                let diffuse = ALBEDO[m] / PI * sphere_light_clamped_cosine(p.to_array(), n.to_array(), c, r);
                let spec = brdf::specular_sum(&sg_lobes, |axis, lambda| {
                    [sphere_light_sg_integral(p.to_array(), c, r, axis, lambda); 3]
                });
                [0, 1, 2].map(|k| t.visibility() * l.radiance[k] * (diffuse + spec[k]))
            } else {
                t.radiance()
            };
            (0..3).for_each(|c| want[c] += add[c]);
            scale += t.u.iter().cloned().fold(0.0, f64::max);
        }
        let got = rgb(&hdr, i);
        for c in 0..3 {
            errs.push((got[c] - want[c]).abs() / scale);
        }
    }
    errs.sort_by(f64::total_cmp);
    errs
}

fn check(errs: &[f64], spec: &str, what: &str, p95_bound: f64, max_bound: f64) {
    assert!(errs.len() > 300, "{spec} {what}: too few receivers ({})", errs.len());
    let (p95, max) = (errs[errs.len() * 95 / 100], errs[errs.len() - 1]);
    eprintln!("{spec} ({what}): {} samples, error / unshadowed: 95th percentile {p95:.2e}, max {max:.2e}", errs.len());
    assert!(p95 < p95_bound && max < max_bound, "{spec} ({what}): p95 {p95}, max {max}");
}

/// The glossy materials of the specular tests: a Lafortune ground of three lobes (anisotropic e = 60, a
/// broad off-specular e = 6, a retro-reflective e = 15) and a Blinn-Phong ball (s = 100, its Phong lobe
/// e = s/4).
fn make_glossy(s: &mut Scene) {
    s.materials[0]
        .apply_brdf_spec(
            "lafortune:cx=-1,cy=-0.85,cz=1,e=60,ks=0.5,tangent=1/0/0,\
             w1=0.6,cx1=-0.7,cy1=-0.7,cz1=0.9,e1=6,w2=0.4,cx2=0.8,cy2=0.8,cz2=0.8,e2=15",
        )
        .unwrap();
    s.materials[1].apply_brdf_spec("blinn-phong:s=100,ks=0.4").unwrap();
}

fn light(center: [f32; 3], radius: f32, radiance: [f32; 3]) -> SphereLight {
    SphereLight { center: Vec3::from_array(center), radius, radiance: Vec3::from_array(radiance) }
}

#[test]
fn gpu_matches_the_f64_twin() {
    let gpu = engine_tests::gpu();
    let key = light([-0.6, 2.2, -0.5], 0.3, [12.0, 9.0, 6.0]);
    let fill = light([0.9, 1.6, 0.4], 0.15, [20.0, 20.0, 24.0]);
    let rect =
        BlockerPlane::rectangle(DVec3::new(0.8, 1.0, 0.2), DVec3::new(0.25, 0.0, 0.0), DVec3::new(0.0, 0.0, 0.2));
    let cases: Vec<(&str, LobesOptions, Vec<BlockerPlane>)> = vec![
        ("lobes", LobesOptions::default(), vec![]),
        (
            "lobes:leaves=aggressive,depth=5,light_scale=paper",
            LobesOptions { leaves: Leaves::Aggressive, depth: 5, energy: false, ..Default::default() },
            vec![],
        ),
        ("lobes", LobesOptions::default(), vec![BlockerPlane::half_space(DVec3::ZERO, DVec3::Y), rect]),
    ];
    for (spec, o, planes) in cases {
        let s = scene(vec![key, fill], planes.clone());
        let errs = compare(&gpu, &s, spec, &o);
        check(&errs, spec, if planes.is_empty() { "one sphere, two lights" } else { "with planes" }, 2e-3, 0.05);
    }
    gpu.shutdown().expect("clean teardown");
}

/// The specular reflectance lobes (§5.1) on the GPU and the twin: a Lafortune ground of three lobes
/// (anisotropic e = 60, broad off-specular, retro-reflective; measured 1.7e-4 at the 95th percentile) and a Blinn-Phong ball (s = 100, its Phong lobe e = s/4), two lights, with and without
/// planes: the lights through R × L × visibility products, the environment's glossy term as the SG
/// lobes times the diffuse visibility. And `light=ratio`: the exact unshadowed light (the SG closed forms
/// of engine::math::sphere_light) times the twin's clamp(1 − S/U) (against the `light=lobes` twin the
/// same GPU image was 9.5e-3 off at the 95th percentile with a one-lobe ground, so the bound tells the two apart).
#[test]
fn specular_lobes_match_the_f64_twin() {
    let gpu = engine_tests::gpu();
    let key = light([-0.6, 2.2, -0.5], 0.3, [12.0, 9.0, 6.0]);
    let fill = light([0.9, 1.6, 0.4], 0.15, [20.0, 20.0, 24.0]);
    let rect =
        BlockerPlane::rectangle(DVec3::new(0.8, 1.0, 0.2), DVec3::new(0.25, 0.0, 0.0), DVec3::new(0.0, 0.0, 0.2));
    for planes in [vec![], vec![BlockerPlane::half_space(DVec3::ZERO, DVec3::Y), rect]] {
        let mut s = scene(vec![key, fill], planes.clone());
        make_glossy(&mut s);
        for (spec, o) in [
            ("lobes", LobesOptions::default()),
            ("lobes:light=ratio", LobesOptions { ratio: true, ..Default::default() }),
        ] {
            let errs = compare(&gpu, &s, spec, &o);
            check(
                &errs,
                spec,
                if planes.is_empty() { "glossy, two lights" } else { "glossy, with a plane" },
                2e-3,
                0.05,
            );
        }
    }
    gpu.shutdown().expect("clean teardown");
}

/// `env=lobes`: an environment with a bright region, fitted with K = 6 cosine lobes (the technique's fit,
/// repeated here), a Lafortune ground and a Blinn-Phong ball, one light, with and without planes: GPU =
/// twin (`env_lobe_terms`: every R_r × L_k through the normal's mask). And the fit makes the environment
/// what the map is: its error is reported and small for a map that is a constant plus one lobe.
#[test]
fn environment_lobes_match_the_f64_twin() {
    let gpu = engine_tests::gpu();
    let mut env = LatLongMap::constant(64, 32, [ENV; 3]);
    let sun = DVec3::new(-0.4, 0.8, 0.3).normalize();
    for row in 0..env.height {
        for col in 0..env.width {
            let d = DVec3::from_array(env.texel_direction(col, row));
            let g = d.dot(sun).max(0.0).powf(12.0) as f32;
            env.texels[row * env.width + col] = [ENV + 3.0 * g, ENV + 2.4 * g, ENV + 1.5 * g];
        }
    }
    let k = 6;
    let (fit, error) = engine::passes::shade::lobes::fit_environment(&env, k, 6);
    assert_eq!(fit.len(), k);
    // A constant plus one cosine lobe: the constant is no lobe, so it takes several broad ones (measured 9.4 %).
    assert!(error < 0.12, "fit error {error}");
    let lobes: Vec<RgbLobe> =
        fit.iter().map(|l| RgbLobe { axis: DVec3::from_array(l.axis), e: l.lambda, s: l.mu }).collect();
    let key = light([-0.6, 2.2, -0.5], 0.3, [12.0, 9.0, 6.0]);
    let rect =
        BlockerPlane::rectangle(DVec3::new(0.8, 1.0, 0.2), DVec3::new(0.25, 0.0, 0.0), DVec3::new(0.0, 0.0, 0.2));
    // The whole map: the twin's environment is the fit of `env`, not a residual (the split is tested in env_lights.rs).
    let spec = format!("lobes:env=lobes,K={k},env_lights=off");
    let o = LobesOptions { env_lobes: k, ..Default::default() };
    for planes in [vec![], vec![BlockerPlane::half_space(DVec3::ZERO, DVec3::Y), rect]] {
        let mut s = scene(vec![key], planes.clone());
        s.environment = env.clone();
        make_glossy(&mut s);
        let errs = compare_with_env(&gpu, &s, &spec, &o, Some(&lobes));
        check(
            &errs,
            &spec,
            if planes.is_empty() { "environment lobes" } else { "environment lobes, planes" },
            2e-3,
            0.05,
        );
    }
    gpu.shutdown().expect("clean teardown");
}

/// The environment's plane factor is weighted by the environment (`env=map`): under a sky-only map
/// (upper hemisphere 1, lower 0) a ground half-space hides only dark directions, so the ball's sideways
/// receivers (|n·y| < 0.3, no sphere blockers) keep their unshadowed light (`lobes` ≈ `none`). The
/// unweighted factor, the ground's cosine-weighted visibility (1 + n·m)/2 ≤ 0.65, took away about half.
#[test]
fn environment_planes_are_weighted_by_the_environment() {
    let gpu = engine_tests::gpu();
    let mut sky = LatLongMap::constant(64, 32, [0.0; 3]);
    for row in 0..sky.height {
        for col in 0..sky.width {
            if sky.texel_direction(col, row)[1] > 0.0 {
                sky.texels[row * sky.width + col] = [1.0; 3];
            }
        }
    }
    let mut s = scene(vec![], vec![BlockerPlane::half_space(DVec3::ZERO, DVec3::Y)]);
    s.environment = sky;
    s.blockers.spheres = vec![None, None];
    let render = |spec: &str| {
        let settings = RenderSettings { width: W, height: H, technique: spec.into(), ..Default::default() };
        engine_tests::render_with_bvh(&gpu, &s, settings)
    };
    let (lobes, g, _) = render("lobes");
    let (none, _, _) = render("none");
    assert_finite(&lobes, "lobes");
    let (mut sum_l, mut sum_n, mut count) = (0.0, 0.0, 0);
    for (i, px) in g.iter().enumerate() {
        let Some((_, n, m)) = *px else { continue };
        if m != 1 || n.y.abs() >= 0.3 {
            continue;
        }
        sum_l += rgb(&lobes, i)[1];
        sum_n += rgb(&none, i)[1];
        count += 1;
    }
    assert!(count > 15, "too few sideways receivers: {count}");
    let ratio = sum_l / sum_n;
    // Measured 0.909 (the prefiltered lookup about the blocked lune blurs a little sky into it).
    eprintln!("sideways receivers under a sky, ground half-space: lobes / none = {ratio:.3} ({count} receivers)");
    assert!(ratio > 0.85 && ratio <= 1.0 + 1e-3, "{ratio}");
    gpu.shutdown().expect("clean teardown");
}

/// The environment under a ground rectangle, from downward-facing receivers (issue 37: the orange blotches and
/// black pixels along the bunny's lower silhouette, chess's white pieces and battle's rocks): a ball 0.15 above a
/// large plate, no sphere blockers, under a bright sky (a blue-white gradient) over a dim warm lower
/// hemisphere. Each receiver of the ball's lower half (n·y < −0.3) against the closed form ρ/π ∫ L (n·ω)⁺ over
/// the directions the plate leaves free (a quadrature over the hemisphere of n of the analytic environment
/// the map was filled from). The old factor, 1 − o L̄/E(n) with L̄ one lookup about the plate's mean
/// direction at its cap lobe's sharpness, read the whole sphere's light (sky included) once the plate filled
/// the hemisphere: o L̄ passed E(n), blue first, then every channel clamped to 0 (measured: all 3 channels
/// black at most of these receivers).
#[test]
fn environment_planes_keep_the_light_of_downward_receivers() {
    let sky = |d: DVec3| -> [f64; 3] {
        let t = (0.5 + 2.5 * d.y).clamp(0.0, 1.0);
        let t = t * t * (3.0 - 2.0 * t);
        let up = d.y.max(0.0);
        [0.25 + t * (1.2 + 0.6 * up - 0.25), 0.15 + t * (1.6 + 0.8 * up - 0.15), 0.06 + t * (2.2 + 1.2 * up - 0.06)]
    };
    let mut env = LatLongMap::constant(128, 64, [0.0; 3]);
    for row in 0..env.height {
        for col in 0..env.width {
            let d = DVec3::from_array(env.texel_direction(col, row));
            env.texels[row * env.width + col] = sky(d).map(|x| x as f32);
        }
    }
    let plate = BlockerPlane::rectangle(DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0), DVec3::new(0.0, 0.0, 2.0));
    let mut s = scene(vec![], vec![plate]);
    s.environment = env;
    s.blockers.spheres = vec![None, None];
    s.camera.eye = Vec3::new(0.0, 0.35, 2.2);
    s.camera.target = Vec3::new(0.1, 0.5, -0.1);
    let gpu = engine_tests::gpu();
    let settings = RenderSettings { width: W, height: H, technique: "lobes".into(), ..Default::default() };
    let (hdr, g, _) = engine_tests::render_with_bvh(&gpu, &s, settings);
    gpu.shutdown().expect("clean teardown");
    assert_finite(&hdr, "lobes");
    let (mut sum2, mut sum_w2, mut count, mut worst, mut dark) = (0.0, 0.0, 0, 0.0f64, 0);
    for (i, px) in g.iter().enumerate() {
        let Some((p, n, 1)) = *px else { continue };
        if n.y >= -0.3 {
            continue;
        }
        let (t, b) = engine::passes::shade::lobes::cpu::orthonormal_basis(n);
        let m = 96;
        let (mut want, mut free) = ([0.0; 3], [0.0; 3]);
        for a in 0..m {
            let r2 = (a as f64 + 0.5) / m as f64;
            for c in 0..m {
                let phi = 2.0 * PI * (c as f64 + 0.5) / m as f64;
                let w = (t * phi.cos() + b * phi.sin()) * r2.sqrt() + n * (1.0 - r2).sqrt();
                // Cosine-distributed cells: each holds π/m² of ∫ (n·ω)⁺ dω.
                let l = sky(w).map(|x| ALBEDO[1] / PI * x * PI / (m * m) as f64);
                (0..3).for_each(|k| free[k] += l[k]);
                if !plate.blocks_direction(p, w) {
                    (0..3).for_each(|k| want[k] += l[k]);
                }
            }
        }
        let got = rgb(&hdr, i);
        for k in 0..3 {
            let e = (got[k] - want[k]) / want[k];
            worst = worst.max(e.abs());
            sum2 += (got[k] - want[k]).powi(2);
            sum_w2 += want[k] * want[k];
            // Where the plate leaves at least a tenth of the light, nothing below a quarter of it: the two
            // receivers at the very bottom see only a sliver of a few degrees past the plate's edge, which few of
            // the 32 samples reach (measured 0.38 to 0.66 of the closed form there, at 2 % of the ball's lit
            // value); the old factor left 0 in most channels.
            dark += usize::from(want[k] >= 0.1 * free[k] && got[k] < 0.25 * want[k]);
        }
        count += 1;
    }
    let rmse = (sum2 / sum_w2).sqrt();
    eprintln!(
        "downward receivers over a plate under a sky: {count} receivers, relative RMSE {:.2} %, worst channel {:.1} %, \
         {dark} channels below a quarter of the closed form (where it is at least 10 % of the free light)",
        100.0 * rmse,
        100.0 * worst
    );
    assert!(count > 40, "too few downward receivers in view: {count}");
    // Measured 2.6 % (the prefiltered environment's blur at the plate's edge), 0 dark; the old factor 80 %.
    assert!(dark == 0 && rmse < 0.06, "relative RMSE {rmse}, worst {worst}, {dark} dark channels");
}

/// The cloth scene at rest (issue 37: large black blotches with hard edges on the ground under the cloth): 40 × 30
/// against the sphere-proxy reference at 64 spp. The environment's mask over a ground receiver holds the cloth's
/// 144 stand-in spheres and the bunnies' (coarsened cuts), and its leaves, weighted by the courtyard's bright
/// overhead light, held more than E(n): measured S = 1.04 E(n) under the cloth's middle, where the proxy leaves
/// about a third of the light. E − S clamped at 0 per channel went black there, with a hard edge where S crossed
/// E. Now the free light of the mask's cells over all of its light gives the free share (there 6 %, too dark,
/// but never black while a cell is free). No pixel below 2 % of the reference where the reference is above 5 %
/// of its median (the artefact gate's rule).
#[test]
fn the_cloth_casts_no_black_blotches() {
    use engine::passes::shade::reference::Visibility;
    let gpu = engine_tests::gpu();
    let scene = scenes::build("cloth", None).expect("scene");
    let settings = RenderSettings { width: W, height: H, ..Default::default() };
    let reference = lab::measure::reference_at(&gpu, &scene, &settings, Visibility::Spheres, 64, 16).unwrap();
    let (hdr, _) = engine_tests::render(&gpu, &scene, RenderSettings { technique: "lobes".into(), ..settings.clone() });
    gpu.shutdown().expect("clean teardown");
    assert_finite(&hdr, "lobes");
    let lum =
        |a: &[f32], i: usize| 0.2126 * a[4 * i] as f64 + 0.7152 * a[4 * i + 1] as f64 + 0.0722 * a[4 * i + 2] as f64;
    let pixels = (W * H) as usize;
    let mut lit: Vec<f64> = (0..pixels).filter(|&i| reference.mask[i]).map(|i| lum(&reference.hdr, i)).collect();
    lit.sort_by(f64::total_cmp);
    let median = lit[lit.len() / 2];
    let black: Vec<usize> = (0..pixels)
        .filter(|&i| reference.mask[i] && lum(&reference.hdr, i) > 0.05 * median)
        .filter(|&i| lum(&hdr, i) < 0.02 * lum(&reference.hdr, i))
        .collect();
    eprintln!("cloth at rest, lobes: {} black pixels where the reference is lit: {black:?}", black.len());
    assert!(black.is_empty(), "{} black pixels", black.len());
}

/// The cloth at rest is a flat sheet with nothing above it: its upper side sees the whole sky (the reference
/// traces its triangles). Techniques that read spheres see its 144 stand-ins (one per 4 × 4 quads, centred on
/// the sheet), which straddle the tangent plane of every cloth receiver. SHEXP §6.2's plain rule turned each
/// neighbour into the sphere of radius (h + r)/2 on the tangent plane: a ring of blockers about the horizon that
/// hid 22 to 26 % of the cosine-weighted sky, in the pattern of the patches (issue 37's grid on the cloth). With
/// the radius scale α (blocker_for_receiver_alpha) the near neighbours shrink to the inside rule's blocker. The
/// twin's environment visibility (the shader's rule; GPU = twin in the tests above) at the sheet's inner vertices
/// and quad centres, facing up, against the stand-ins of the rest pose: measured mean 0.901 (the plain rule
/// 0.778). Left: a receiver almost at a stand-in's centre (1 of 338 here) still meets the inside rule, a sphere of
/// radius h about a centre about h above it, which hides its sky.
/// The cloth's rest pose: its stand-in spheres as a BVH, and receivers on the sheet (inner vertices and quad
/// centres, every third row and column).
fn flat_cloth() -> (TwinBvh, Vec<DVec3>) {
    use engine::scene::cloth::{patch_sphere, rest_positions};
    let scene = scenes::build("cloth", None).expect("scene");
    let cloth = scene.blockers.cloth.clone().expect("the cloth");
    let (instance, _) = engine::scene::cloth::cloth_instance(&scene, &cloth).expect("its instance");
    let inst = &scene.instances[instance];
    let x: Vec<DVec3> = rest_positions(&cloth, &scene.meshes[inst.mesh].positions, inst.transform)
        .iter()
        .map(|p| p.as_dvec3())
        .collect();
    let (across, down) = cloth.sphere_grid();
    let stand_ins: Vec<Sphere> = (0..down)
        .flat_map(|b| (0..across).map(move |a| (a, b)))
        .map(|(a, b)| {
            let (c, r) = patch_sphere(&cloth, &x, a, b);
            Sphere::new(c, r)
        })
        .collect();
    let (cols, rows) = (cloth.columns as usize, cloth.rows as usize);
    let at = |i: usize, j: usize| x[j * cols + i];
    let mut receivers = Vec::new();
    for j in (4..rows - 5).step_by(3) {
        for i in (4..cols - 5).step_by(3) {
            receivers.push(at(i, j));
            receivers.push(0.25 * (at(i, j) + at(i + 1, j) + at(i, j + 1) + at(i + 1, j + 1)));
        }
    }
    (bvh(&stand_ins), receivers)
}

#[test]
fn the_flat_cloth_does_not_shadow_itself() {
    let (bvh, receivers) = flat_cloth();
    let twin = Twin::new(&LobesOptions::default()).expect("tables");
    let (mut worst, mut sum, mut count, mut low) = (1.0f64, 0.0, 0, 0);
    {
        {
            for &p in &receivers {
                let v = twin.env_visibility(p, DVec3::Y, &bvh, &[]);
                low += usize::from(v < 0.5);
                worst = worst.min(v);
                sum += v;
                count += 1;
            }
        }
    }
    eprintln!(
        "flat cloth, {count} receivers facing up: environment visibility mean {:.3}, worst {worst:.3}, {low} below \
         0.5 (truth 1)",
        sum / count as f64
    );
    let mean = sum / count as f64;
    assert!(mean > 0.85 && low * 100 <= count, "mean visibility {mean}, {low} of {count} below 0.5");
}

/// The same sheet under a light low over it (30° above the horizon, 5° in radius, far away: an environment light
/// of the courtyard's windows). The lights' masks with the plain rule see the stand-ins' ring of blockers over the
/// horizon and shadow many receivers (the grid that came back with the environment lights); with
/// `light_rule=alpha` (what `auto` picks in a scene with thin shells) the sheet leaves its light alone. Measured
/// mean light visibility (truth 1), plain / α: 0.599 / 0.979 at 30°, 0.930 / 0.994 at 45°, 0.994 / 0.994 at 60°;
/// at 15° both fail (0.087 / 0.201): the neighbours' stand-ins rise above that horizon under either rule.
#[test]
fn a_low_light_over_the_flat_cloth_is_not_hidden_by_its_stand_ins() {
    let (bvh, receivers) = flat_cloth();
    let mean = |rule: LightRule, deg: f64| {
        let twin = Twin::new(&LobesOptions { light_rule: rule, ..Default::default() }).expect("tables");
        let e = deg.to_radians();
        let dir = DVec3::new(e.cos() * 0.6, e.sin(), e.cos() * 0.8);
        let radius = 500.0 * 5f64.to_radians().sin();
        let total: f64 = receivers
            .iter()
            .map(|&p| {
                let l = TwinLight { center: p + 500.0 * dir, radius, radiance: [1.0; 3] };
                twin.light_terms(&TwinReceiver { p, ..receiver(DVec3::Y) }, &l, &bvh, &[]).visibility()
            })
            .sum();
        total / receivers.len() as f64
    };
    let (plain, alpha) = (mean(LightRule::Plain, 30.0), mean(LightRule::Alpha, 30.0));
    eprintln!("a light 30° over the flat cloth: mean visibility plain {plain:.3}, alpha {alpha:.3} (truth 1)");
    assert!(alpha > 0.95 && plain < 0.7, "plain {plain}, alpha {alpha}");
    assert_eq!(LightRule::Auto.resolve(true), LightRule::Alpha);
    assert_eq!(LightRule::Auto.resolve(false), LightRule::Plain);
}

/// `light_rule=auto` on the GPU: on the cloth (thin shells) the image is `light_rule=alpha`'s, not `plain`'s; on
/// `lamp-one` (no thin shell) it is `plain`'s.
#[test]
fn the_automatic_light_rule_follows_the_scene() {
    let gpu = engine_tests::gpu();
    for (name, same, other) in [("cloth", "alpha", "plain"), ("lamp-one", "plain", "alpha")] {
        let scene = scenes::build(name, None).expect("scene");
        let image = |spec: &str| {
            let settings = RenderSettings { width: 32, height: 24, technique: spec.into(), ..Default::default() };
            engine_tests::render(&gpu, &scene, settings).0
        };
        let auto = image("lobes");
        assert_finite(&auto, name);
        assert!(auto == image(&format!("lobes:light_rule={same}")), "{name}: auto is not light_rule={same}");
        assert!(auto != image(&format!("lobes:light_rule={other}")), "{name}: light_rule={other} changes nothing");
    }
    gpu.shutdown().expect("clean teardown");
}

/// Hard light placements on the GPU and the twin: a tiny light (e_cap ≈ 2e6, past the tables), a light
/// inside the blocker, a light below the ground (behind the plane receivers' tangent plane), a huge
/// light close over the ground (α → π/2); with a plane straddling the light cones. Finite, non-negative,
/// and equal to the twin.
#[test]
fn hard_lights_are_finite_and_match_the_twin() {
    let gpu = engine_tests::gpu();
    let lights = vec![
        light([0.3, 2.5, 0.6], 2.5e-3, [2e5, 2e5, 2e5]),
        light([0.1, 0.6, -0.1], 0.1, [30.0, 30.0, 30.0]),
        light([0.0, -1.0, 0.0], 0.4, [30.0, 30.0, 30.0]),
        light([-1.3, 1.2, 0.8], 1.0, [2.0, 2.0, 2.0]),
    ];
    let rect = BlockerPlane::rectangle(DVec3::new(0.3, 1.5, 0.6), DVec3::new(0.3, 0.0, 0.0), DVec3::new(0.0, 0.0, 0.3));
    let s = scene(lights, vec![rect]);
    let o = LobesOptions::default();
    let errs = compare(&gpu, &s, "lobes", &o);
    check(&errs, "lobes", "hard lights", 2e-3, 0.05);
    gpu.shutdown().expect("clean teardown");
}

fn bvh(spheres: &[Sphere]) -> TwinBvh {
    TwinBvh::new(spheres).expect("valid spheres")
}

fn receiver(n: DVec3) -> TwinReceiver {
    TwinReceiver { p: DVec3::ZERO, n, view: DVec3::Y, rho: [1.0; 3], specular: Vec::new() }
}

/// One light, no blockers: U is the analytic integral of (ρ/π cos) × the light's cap lobe.
#[test]
fn one_light_without_blockers_is_the_analytic_lobe_integral() {
    for energy in [true, false] {
        let twin = Twin::new(&LobesOptions { energy, ..Default::default() }).expect("tables");
        let mut worst: f64 = 0.0;
        for &(dist, radius, tilt) in &[
            (3.0f64, 0.3f64, 0.0f64),
            (2.0, 0.5, 0.7),
            (5.0, 0.05, 1.2),
            (1.5, 1.0, 0.3),
            (4.0, 0.2, 1.5),
            (3.0, 1e-3, 0.4),
        ] {
            let n = DVec3::new(tilt.sin(), tilt.cos(), 0.0);
            let l = TwinLight { center: DVec3::new(0.0, dist, 0.0), radius, radiance: [1.0; 3] };
            let t = twin.light_terms(&receiver(n), &l, &TwinBvh::default(), &[]);
            let alpha = (radius / dist).asin();
            let lobe = twin.cap_lobe(DVec3::Y, alpha, [1.0; 3], energy, twin.options.sharpen);
            let want = lobe.s[0] / PI * clamped_cosine_integral(lobe.e, n.y);
            let e = (t.u[0] - want).abs() / want;
            worst = worst.max(e);
            assert_eq!(t.s, [0.0; 3]);
        }
        eprintln!("one light, no blockers (energy {energy}): worst relative error of U {worst:.2e}");
        // Bound: the product table's interpolation in (e1, e2, α) and the hemisphere table (measured
        // ≤ 4e-3 here).
        assert!(worst < 1e-2, "{worst}");
    }
}

/// A light wholly behind a large blocker gives (almost) nothing; a light half covered by a plate
/// whose edge passes through its centre loses about half.
#[test]
fn hidden_and_half_covered_lights() {
    let n = DVec3::Y;
    let l = TwinLight { center: DVec3::new(0.0, 4.0, 0.0), radius: 0.4, radiance: [1.0; 3] };
    for leaves in [Leaves::Half, Leaves::Conservative, Leaves::Aggressive] {
        let twin = Twin::new(&LobesOptions { leaves, depth: 5, ..Default::default() }).expect("tables");
        // A sphere of radius 1 at height 2 subtends 30°, the light 5.7° (mask 8.6°): fully hidden.
        let hidden = twin.light_terms(&receiver(n), &l, &bvh(&[Sphere::new(DVec3::new(0.0, 2.0, 0.0), 1.0)]), &[]);
        let left = hidden.radiance()[0] / hidden.u[0];
        eprintln!("hidden light ({leaves:?}): {left:.2e} of U left, {} leaves", hidden.leaves);
        assert!(hidden.hidden && left == 0.0, "{left}");
        // A blocker of 1.25 α covers the light but not the whole mask: the leaves hide what lies under
        // it, but the L2 cap lobe of the light (e_cap α² ≈ 1.92) keeps exp(−0.96 · 1.25²) ≈ 22 % of its
        // integral outside 1.25 α: measured 20 % (conservative) and 27 % (aggressive) left at sharpen = 1;
        // 6.0 % and 7.6 % (half) at the default sharpen = 2. This is the cap lobe's shape error (DESIGN §3),
        // not the mask's.
        let r = 2.0 * (1.25 * (0.4f64 / 4.0).asin()).sin();
        let mostly = twin.light_terms(&receiver(n), &l, &bvh(&[Sphere::new(DVec3::new(0.0, 2.0, 0.0), r)]), &[]);
        let left = mostly.radiance()[0] / mostly.u[0];
        eprintln!("light hidden by a 1.25 α blocker ({leaves:?}): {left:.3} of U left, {} leaves", mostly.leaves);
        assert!(!mostly.hidden && left < 0.3, "{left}");
        // A plate over x > 0 at height 2: half the light (and half the mask) is covered.
        let plate =
            BlockerPlane::rectangle(DVec3::new(1.0, 2.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 0.0, 1.0));
        let half = twin.light_terms(&receiver(n), &l, &TwinBvh::default(), &[plate]);
        let v = half.visibility();
        eprintln!("half-covered light ({leaves:?}): visibility {v:.4}");
        // The partial cells along the edge (at the maximal depth) count half, whole or not at all: at the
        // default sharpen = 2 the light lobe is narrow enough that they weigh (measured 0.469 half, 0.433
        // conservative, 0.505 aggressive).
        let bound = if leaves == Leaves::Half { 0.05 } else { 0.1 };
        assert!((v - 0.5).abs() < bound, "{leaves:?}: {v}");
    }
}

/// Hard cases on the twin: receiver inside a blocker (→ hidden), light behind the tangent plane
/// (→ 0), a blocker straddling the cone's edge (between hidden and free), exponents past the tables.
#[test]
fn twin_hard_cases_are_sane() {
    let twin = Twin::new(&LobesOptions::default()).expect("tables");
    let n = DVec3::Y;
    let l = TwinLight { center: DVec3::new(0.0, 4.0, 0.0), radius: 0.4, radiance: [1.0; 3] };
    let inside = twin.light_terms(&receiver(n), &l, &bvh(&[Sphere::new(DVec3::new(0.0, 0.1, 0.0), 0.5)]), &[]);
    assert!(inside.radiance()[0] <= 0.02 * inside.u[0], "{inside:?}");
    let behind = TwinLight { center: DVec3::new(0.0, -4.0, 0.0), ..l };
    let b = twin.light_terms(&receiver(n), &behind, &TwinBvh::default(), &[]);
    assert!(b.u[0].is_finite() && b.u[0] < 1e-6, "{b:?}");
    let free = twin.light_terms(&receiver(n), &l, &TwinBvh::default(), &[]).u[0];
    let edge = twin.light_terms(&receiver(n), &l, &bvh(&[Sphere::new(DVec3::new(0.2, 2.0, 0.0), 0.15)]), &[]);
    let ve = edge.radiance()[0] / free;
    assert!(ve > 0.05 && ve < 0.95, "straddling blocker: {ve}");
    for radius in [1e-4, 1e-3, 3.99] {
        let t = twin.light_terms(
            &receiver(DVec3::new(0.6, 0.8, 0.0)),
            &TwinLight { radius, ..l },
            &bvh(&[Sphere::new(DVec3::new(0.01, 2.0, 0.0), 0.05)]),
            &[],
        );
        assert!(t.u.iter().chain(&t.s).all(|x| x.is_finite() && *x >= 0.0), "radius {radius}: {t:?}");
    }
}

// Overflow is counted and reported, never silent: on `chess` (308 spheres) with the leaves-only gather
// (`take_whole=0`) and the whole map (`env_lights=off`: no lights) most receivers see more than MAX_BLOCKERS blockers in the environment mask's cone and the
// technique says so; on `lamp-one` (the bunny's 64 spheres) at the defaults none does; a second call without a
// frame in between reports nothing (the counters restart). The work line (products, leaves) counts the frame's
// receivers.
#[test]
fn blocker_overflow_is_reported() {
    let gpu = engine_tests::gpu();
    let mut lines = Vec::new();
    for (name, spec) in [("chess", "lobes:take_whole=0,env_lights=off"), ("lamp-one", "lobes")] {
        let scene = scenes::build(name, None).expect("scene");
        let settings = RenderSettings { width: 32, height: 24, technique: spec.into(), ..Default::default() };
        let mut r = engine::renderer::Renderer::new(&gpu, &scene, settings).expect("renderer");
        r.render(&gpu).expect("frame");
        let report = r.technique_report(&gpu).expect("report");
        let first = report.warnings;
        let second = r.technique_warnings(&gpu).expect("warnings");
        // The work line counts this frame's receivers (32 × 24 at most), then restarts.
        assert_eq!(report.counts.len(), 1, "{name}: {:?}", report.counts);
        let receivers: u64 = report.counts[0].rsplit('(').next().unwrap().split(' ').next().unwrap().parse().unwrap();
        assert!(receivers > 100 && receivers <= 32 * 24, "{name}: {}", report.counts[0]);
        assert!(r.technique_report(&gpu).expect("report").counts.is_empty(), "{name}: work counters not reset");
        r.destroy(&gpu);
        eprintln!("{name} {spec}: {first:?}");
        assert!(second.is_empty(), "{name}: counters not reset: {second:?}");
        lines.push(first);
    }
    gpu.shutdown().expect("clean teardown");
    assert_eq!(lines[0].len(), 1, "chess: one overflow line expected");
    assert!(lines[0][0].contains("more than 64 blockers"), "{}", lines[0][0]);
    // The bound on what was dropped: a share of the sky in (0, 100] %.
    let sky: f64 = lines[0][0].split("bounded by ").nth(1).and_then(|t| t.split(' ').next()).unwrap().parse().unwrap();
    assert!(sky > 0.0 && sky <= 100.0, "{}", lines[0][0]);
    assert!(lines[0][0].contains("light masks 0"), "chess has no lights: {}", lines[0][0]);
    assert!(lines[1].is_empty(), "lamp-one: {:?}", lines[1]);
}

/// The BVH cut takes far nodes whole: 64 small spheres (radius 0.02, 0.06 apart) about 3 units above the
/// receiver lie inside one cell of the environment mask (its cells are ~0.36 rad wide about the normal),
/// so the root is one blocker instead of 64 leaves; the visibility moves by less than one half-weight
/// finest cell. The light's mask (depth 4 over 0.075 rad) is finer than the spheres: its cut keeps the
/// leaves, and its S is unchanged.
#[test]
fn cut_takes_far_nodes_whole() {
    let n = DVec3::Y;
    let cloud = bvh(&grid(4, 0.06, 0.02, DVec3::new(0.5, 3.0, 0.2)));
    let whole = Twin::new(&LobesOptions::default()).expect("tables");
    let leaves = Twin::new(&LobesOptions { take_whole: 0.0, ..Default::default() }).expect("tables");
    let tan_env = engine::passes::shade::lobes::MASK_MAX_HALF_ANGLE.tan();
    let (b_whole, o_whole) = whole.gather(DVec3::ZERO, n, n, tan_env, 5, &cloud, MaskKind::EnvMap);
    let (b_leaves, o_leaves) = leaves.gather(DVec3::ZERO, n, n, tan_env, 5, &cloud, MaskKind::EnvMap);
    eprintln!("environment mask: {} blockers whole, {} as leaves", b_whole.len(), b_leaves.len());
    assert!(!o_whole && !o_leaves);
    assert_eq!(b_leaves.len(), 64);
    assert_eq!(b_whole.len(), 1, "the far cloud is one node");
    let (vw, vl) =
        (whole.env_visibility(DVec3::ZERO, n, &cloud, &[]), leaves.env_visibility(DVec3::ZERO, n, &cloud, &[]));
    eprintln!("environment visibility: {vw:.5} whole, {vl:.5} as leaves");
    // One finest cell about the normal (0.36² sr) at half weight against ∫cos = π: 2 %.
    assert!(vw <= vl && vl - vw < 0.02, "{vw} {vl}");
    let l = TwinLight { center: DVec3::new(1.0, 6.0, 0.4), radius: 0.3, radiance: [1.0; 3] };
    let (tw, tl) =
        (whole.light_terms(&receiver(n), &l, &cloud, &[]), leaves.light_terms(&receiver(n), &l, &cloud, &[]));
    eprintln!("light: S/U {:.4} whole, {:.4} as leaves", tw.s[0] / tw.u[0], tl.s[0] / tl.u[0]);
    assert!(tw.s[0] > 0.0 && !tw.overflow);
    assert_eq!(tw.s, tl.s, "the light mask resolves the spheres: leaves kept");
}

/// The coarsening retry: 512 spheres close above the receiver overflow the environment mask's cut at a
/// fine take_whole; with `coarsen` the cut is retried coarser until it fits (no overflow), without it
/// the narrowest caps are dropped and counted.
#[test]
fn coarsening_retries_an_overflowing_cut() {
    let n = DVec3::Y;
    let cloud = bvh(&grid(8, 0.1, 0.03, DVec3::new(0.0, 1.2, 0.0)));
    let tan_env = engine::passes::shade::lobes::MASK_MAX_HALF_ANGLE.tan();
    let fine = LobesOptions { take_whole: 0.25, ..Default::default() };
    let once = Twin::new(&LobesOptions { coarsen: 0, ..fine.clone() }).expect("tables");
    let retried = Twin::new(&fine).expect("tables");
    let leaves = Twin::new(&LobesOptions { take_whole: 0.0, ..Default::default() }).expect("tables");
    let (b_once, o_once) = once.gather(DVec3::ZERO, n, n, tan_env, 5, &cloud, MaskKind::EnvMap);
    let (b_retried, o_retried) = retried.gather(DVec3::ZERO, n, n, tan_env, 5, &cloud, MaskKind::EnvMap);
    let (_, o_leaves) = leaves.gather(DVec3::ZERO, n, n, tan_env, 5, &cloud, MaskKind::EnvMap);
    eprintln!(
        "coarsening: {} blockers without retry (overflow {o_once}), {} with (overflow {o_retried})",
        b_once.len(),
        b_retried.len()
    );
    assert!(o_leaves && o_once, "the fine cut must overflow");
    assert!(!o_retried && b_retried.len() <= 64, "the retried cut must fit");
    let v_once = once.env_visibility(DVec3::ZERO, n, &cloud, &[]);
    let v_retried = retried.env_visibility(DVec3::ZERO, n, &cloud, &[]);
    eprintln!("environment visibility: {v_once:.4} dropping the narrowest, {v_retried:.4} coarsened");
    // Dropping the narrowest caps of a compact cloud loses little of its shadow.
    assert!(v_once >= v_retried - 1e-9 && v_once - v_retried < 0.02, "{v_once} {v_retried}");
}

/// A mask whose coarsest cut still overflows keeps its widest caps: 27 near spheres (radius 0.05, 1 unit up) among
/// 216 far tiny ones (radius 0.01, 20 units up), leaves only: the near ones are all kept whatever the traversal
/// order, and the 37 places left go to far ones.
#[test]
fn an_overflowing_mask_keeps_its_widest_caps() {
    let n = DVec3::Y;
    let mut spheres = grid(3, 0.2, 0.05, DVec3::new(0.1, 1.0, -0.1));
    spheres.extend(grid(6, 0.5, 0.01, DVec3::new(3.0, 20.0, 2.0)));
    let cloud = bvh(&spheres);
    let twin = Twin::new(&LobesOptions { take_whole: 0.0, ..Default::default() }).expect("tables");
    let tan_env = engine::passes::shade::lobes::MASK_MAX_HALF_ANGLE.tan();
    let (kept, overflow) = twin.gather(DVec3::ZERO, n, n, tan_env, 5, &cloud, MaskKind::EnvMap);
    let near = kept.iter().filter(|b| b.1 > 0.03).count();
    eprintln!("kept {} caps, {near} of them near (overflow {overflow})", kept.len());
    assert!(overflow, "243 leaves overflow 64");
    assert_eq!(near, 27, "every near sphere is kept");
    assert_eq!(kept.len(), 64, "the room left is filled with far ones");
    // One blocker past the limit drops one, not a whole width bin: 65 equal far spheres keep 64.
    let sixty_five: Vec<Sphere> = (0..65)
        .map(|i| Sphere::new(DVec3::new(0.3 * (i % 9) as f64 - 1.2, 3.0, 0.3 * (i / 9) as f64 - 1.0), 0.05))
        .collect();
    let (kept, overflow) = twin.gather(DVec3::ZERO, n, n, tan_env, 5, &bvh(&sixty_five), MaskKind::EnvMap);
    assert!(overflow && kept.len() == 64, "{overflow} {}", kept.len());
}

/// GPU against the twin where the cut matters: the ball's shadow cast by 216 small spheres (6³, radius
/// 0.027 world): the environment masks of the plane take nodes whole, the ball's own receivers see many
/// blockers; at the defaults and with a fine take_whole whose cuts overflow and are retried coarser.
#[test]
fn gpu_matches_the_twin_on_the_cut() {
    let gpu = engine_tests::gpu();
    let key = light([-0.6, 2.2, -0.5], 0.3, [12.0, 9.0, 6.0]);
    let fill = light([0.9, 1.6, 0.4], 0.15, [20.0, 20.0, 24.0]);
    let s = cloud_scene(vec![key, fill], grid(6, 0.25, 0.06, DVec3::ZERO));
    let cases = [
        ("lobes", LobesOptions::default()),
        ("lobes:take_whole=0.25", LobesOptions { take_whole: 0.25, ..Default::default() }),
        ("lobes:take_whole=0.25,coarsen=0", LobesOptions { take_whole: 0.25, coarsen: 0, ..Default::default() }),
    ];
    for (spec, o) in cases {
        let errs = compare(&gpu, &s, spec, &o);
        check(&errs, spec, "216 small spheres", 2e-3, 0.05);
    }
    gpu.shutdown().expect("clean teardown");
}

/// The fitted light leaf weights (`weights=fitted`, assets/tables/lobes_weights.txt) are what the fit gives
/// today (`cargo xtask lobes-weights --check` does the same), they lower the calibration error, and the GPU
/// applies them as the twin does (a plane under one sphere and one light: the calibration geometry).
#[test]
fn fitted_weights_have_not_drifted_and_the_gpu_applies_them() {
    use engine::passes::shade::lobes::fit;
    let stored = fit::load_table(&engine::tables::default_dir()).expect("table");
    let (w, rows, uniform, fitted) = fit::fit_default().expect("fit");
    eprintln!("{rows} receivers: unit weights {:.2} %, fitted {:.2} %, {w:?}", 100.0 * uniform, 100.0 * fitted);
    for d in 0..w.len() {
        assert!((w[d] - stored[d]).abs() < 1e-9, "depth {d}: stored {} vs fitted today {}", stored[d], w[d]);
    }
    // At the default sharpen = 2 the unit weights are already close (measured 0.70 % → 0.62 %; at sharpen = 1
    // it was 2.65 % → 1.59 %): the fit must still lower the error by a clear margin, and unit weights stay good.
    assert!(fitted < 0.95 * uniform, "the fit should lower the calibration error: {fitted} vs {uniform}");
    assert!(uniform < 0.01, "unit weights at the defaults: {uniform}");
    let gpu = engine_tests::gpu();
    let key = light([-0.6, 2.2, -0.5], 0.3, [12.0, 9.0, 6.0]);
    let o = LobesOptions { light_weights: stored, ..Default::default() };
    let errs = compare(&gpu, &scene(vec![key], vec![]), "lobes:weights=fitted", &o);
    check(&errs, "lobes:weights=fitted", "one sphere, one light", 2e-3, 0.05);
    gpu.shutdown().expect("clean teardown");
}

/// Option `phase` (the paper's Table 1 split): each variant stops every receiver after its phase and does
/// the earlier phases' work in full. On `lamp-one` (environment, one light, 64 spheres) at 24 × 18: every
/// variant renders finite values; the quad-tree phases count the same shadow leaves as the whole technique
/// (`mask`, `leaves`), the earlier ones none; only `all` computes the visibility products; and the image of
/// `all` is the default's.
#[test]
fn phase_variants_stop_after_their_phase() {
    let gpu = engine_tests::gpu();
    let scene = scenes::build("lamp-one", None).expect("scene");
    let mut runs = Vec::new();
    // The whole map, so that the scene's one light is the only light (R × L products before the masks).
    let specs = engine::passes::shade::lobes::PHASES.iter().map(|p| format!("lobes:phase={p},env_lights=off"));
    for phase in specs.chain(["lobes:env_lights=off".into()]) {
        let settings = RenderSettings { width: 24, height: 18, technique: phase.clone(), ..Default::default() };
        let mut r = engine::renderer::Renderer::new(&gpu, &scene, settings).expect("renderer");
        r.render(&gpu).expect("frame");
        let image = r.read_radiance(&gpu).expect("radiance");
        let report = r.technique_report(&gpu).expect("report");
        r.destroy(&gpu);
        engine_tests::assert_finite(&image, &phase);
        // "lobes: per shaded receiver P lobe products, … , L shadow leaves (N receivers)"
        let line = report.counts.first().cloned().unwrap_or_default();
        let number_before = |word: &str| -> f64 {
            let head = &line[..line.find(word).unwrap_or_else(|| panic!("{phase}: no '{word}' in {line:?}"))];
            head.split_whitespace().last().unwrap().parse().unwrap()
        };
        let (products, leaves) = (number_before(" lobe products"), number_before(" shadow leaves"));
        eprintln!("{phase}: {products} products, {leaves} leaves per receiver");
        runs.push((phase, products, leaves, image));
    }
    let [lobes, gather, mask, leaves, all, default] = &runs[..] else { panic!("six runs") };
    assert_eq!(all.3, default.3, "phase=all is the technique's image");
    assert!(mask.2 > 10.0, "the masks have shadow leaves: {}", mask.2);
    for r in [lobes, gather] {
        assert_eq!(r.2, 0.0, "{}: no quad-tree, no leaves", r.0);
    }
    for r in [mask, leaves] {
        assert_eq!(r.2, all.2, "{}: the same quad-trees as the technique", r.0);
    }
    for r in [lobes, gather, mask, leaves] {
        assert!(r.1 < 3.0 && r.1 < all.1 / 10.0, "{}: {} products (R × L only), all: {}", r.0, r.1, all.1);
    }
    gpu.shutdown().expect("clean teardown");
}

/// The paper's Fig. 13 (scene `spheres`: five balls with one exact blocker sphere each on a plane, one light, no
/// environment), 40×30 against the sphere reference at 1024 spp (its noise included): `lobes` at its defaults is
/// within the 3 % (measured 1.3 % net at 80×60, docs/techniques/lobes.md), and the paper's cap lobe (`sharpen=1`, 4.7 %)
/// is not, so the bound tells them apart.
#[test]
fn the_papers_five_spheres_are_within_three_percent() {
    use engine::passes::shade::reference::Visibility;
    let gpu = engine_tests::gpu();
    let scene = scenes::build("spheres", None).expect("scene");
    let settings = RenderSettings { width: W, height: H, ..Default::default() };
    let reference = lab::measure::reference_at(&gpu, &scene, &settings, Visibility::Spheres, 1024, 64).unwrap();
    let covered = |i: usize| reference.mask[i];
    let mut errors = Vec::new();
    for spec in ["lobes", "lobes:sharpen=1"] {
        let (hdr, _) =
            engine_tests::render(&gpu, &scene, RenderSettings { technique: spec.into(), ..settings.clone() });
        assert_finite(&hdr, spec);
        let e = engine_tests::relative_rmse(&hdr, &reference.hdr, covered);
        eprintln!("spheres (Fig. 13), {spec}: {:.2} % from the sphere reference", 100.0 * e);
        errors.push(e);
    }
    assert!(errors[0] < 0.03, "lobes: {} ≥ 3 %", errors[0]);
    assert!(errors[1] > 0.035, "sharpen=1 should be off by more: {}", errors[1]);
    gpu.shutdown().expect("clean teardown");
}

/// Deep masks on lavapipe: llvmpipe ends every loop of an invocation after 65535 iterations in all, and at
/// depth 6 (depth 5 on `lamp`) the masks near the bunny's shadow edge ran past it: 8 pixels in a row (one SIMD
/// group) lost their light (0 where the reference is 0.44). Each mask stops refining after its work budget
/// (option `budget`), in the shader and the twin alike; since a cell tests only the blockers that met its
/// parent, the default budget is no longer reached here. The paper's set-up (`examples/lamp_key.toml`) at depth
/// 6, 80×60, GPU = twin at every 2nd receiver, at the default budget (reached nowhere: 0 receivers on both
/// sides) and at `budget=512` (the light masks reach it at a quarter of the receivers, 1024 at 9 % since the depth adaptation; the GPU's count, which includes
/// the environment mask's, is at least the twin's count of light masks).
#[test]
fn deep_masks_stay_within_the_loop_budget_and_match_the_twin() {
    let gpu = engine_tests::gpu();
    let example = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/lamp_key.toml");
    let assets = scenes::assets_dir();
    let u = scenes::user::scene_file(&example, None, &assets, &Default::default()).expect("lamp_key.toml");
    let scene = u.scene;
    let planes = engine::resources::blockers::gather_planes(&scene).expect("planes");
    let lights = twin_lights(&scene);
    let eye = scene.camera.eye.as_dvec3();
    for (spec, budget) in [("lobes:depth=6", MASK_WORK_BUDGET), ("lobes:depth=6,budget=512", 512)] {
        let settings = RenderSettings { width: 80, height: 60, technique: spec.into(), ..Default::default() };
        let (hdr, g, world) = render_for_twin(&gpu, &scene, settings.clone());
        assert_finite(&hdr, spec);
        let twin = Twin::new(&LobesOptions { depth: 6, budget, ..Default::default() }).expect("twin tables");
        let mut errs = Vec::new();
        let (mut limited, mut receivers) = (0usize, 0usize);
        for (i, px) in g.iter().enumerate() {
            let Some((p, n, m)) = *px else { continue };
            let rho = scene.materials[m].diffuse.as_dvec3().to_array();
            let r = TwinReceiver { p, n, view: (eye - p).normalize(), rho, specular: Vec::new() };
            let (mut want, mut scale, mut hit) = ([0.0; 3], 0.0f64, false);
            for l in &lights {
                let t = twin.light_terms(&r, l, &world, &planes);
                let add = t.radiance();
                (0..3).for_each(|c| want[c] += add[c]);
                scale += t.u.iter().cloned().fold(0.0, f64::max);
                hit |= t.budget_limited;
            }
            receivers += 1;
            limited += usize::from(hit);
            if scale <= 1e-6 || i % 2 == 1 {
                continue;
            }
            let got = rgb(&hdr, i);
            (0..3).for_each(|c| errs.push((got[c] - want[c]).abs() / scale));
        }
        errs.sort_by(f64::total_cmp);
        check(&errs, spec, "lamp_key, the loop budget", 2e-3, 0.05);
        // The GPU's count of budget-limited receivers (the work line) against the twin's.
        let mut r = engine::renderer::Renderer::new(&gpu, &scene, settings).expect("renderer");
        r.render(&gpu).expect("frame");
        let line = r.technique_report(&gpu).expect("report").counts.first().cloned().unwrap_or_default();
        r.destroy(&gpu);
        let at = line.find("work budget at ").map(|k| k + "work budget at ".len()).expect("the budget count");
        let gpu_pct: f64 = line[at..].split(' ').next().unwrap().parse().expect("a percentage");
        let twin_pct = 100.0 * limited as f64 / receivers.max(1) as f64;
        eprintln!("{spec}: masks cut short by the budget at {gpu_pct:.2} % of receivers (twin {twin_pct:.2} %)");
        if budget == MASK_WORK_BUDGET {
            assert!(gpu_pct == 0.0 && limited == 0, "{spec}: {line}; twin {limited}");
        } else {
            assert!(twin_pct > 10.0 && gpu_pct >= twin_pct - 1.0, "{spec}: {line}; twin {twin_pct:.2} %");
        }
    }
    gpu.shutdown().expect("clean teardown");
}

/// The dropped-blocker bound (`cpu::dropped_share`, the shader's `lobes_dropped_share`) bounds what the cap hides:
/// its cosine-weighted solid angle over π for the environment, its overlap with the light's cap over the light's
/// solid angle for a light, both integrated numerically over the cap.
#[test]
fn the_dropped_share_bounds_the_shadow_of_the_cap() {
    let mut rng = engine::math::rng::Pcg32::new(7, 3);
    let n = DVec3::Y;
    for case in 0..40 {
        let dir = DVec3::from_array(rng.unit_vector());
        let beta = 10f64.powf(rng.uniform(-2.0, 0.2));
        let light_axis = DVec3::from_array(rng.unit_vector());
        let alpha = 10f64.powf(rng.uniform(-1.5, -0.3));
        // Integrate over the cap in its own polar coordinates (θ' from `dir`, φ about it).
        let (t, b) = {
            let h = if dir.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
            let t = dir.cross(h).normalize();
            (t, dir.cross(t))
        };
        let (m, k) = (200, 200);
        let (mut cos_weighted, mut overlap) = (0.0, 0.0);
        for i in 0..m {
            let th = beta * (i as f64 + 0.5) / m as f64;
            let d_omega = th.sin() * (beta / m as f64) * (2.0 * PI / k as f64);
            for j in 0..k {
                let ph = 2.0 * PI * (j as f64 + 0.5) / k as f64;
                let w = dir * th.cos() + (t * ph.cos() + b * ph.sin()) * th.sin();
                cos_weighted += w.dot(n).max(0.0) * d_omega;
                if w.dot(light_axis) > alpha.cos() {
                    overlap += d_omega;
                }
            }
        }
        let env = dropped_share(beta, None);
        let light = dropped_share(beta, Some(alpha));
        let (env_exact, light_exact) = (cos_weighted / PI, overlap / (2.0 * PI * (1.0 - alpha.cos())));
        assert!(env >= env_exact * (1.0 - 1e-3) - 1e-9, "case {case}: environment {env} < {env_exact}");
        assert!(light >= light_exact * (1.0 - 1e-3) - 1e-9, "case {case}: light {light} < {light_exact}");
        // Tight where the cap is small and about the normal.
        if beta < 0.1 && dir.dot(n) > 0.99 {
            assert!(env < 1.05 * env_exact, "case {case}: {env} vs {env_exact}");
        }
    }
}

/// Passing the 64-blocker limit does not pop: a receiver whose environment mask holds 64
/// equal spheres, then 65 (one more at the edge of the cloud), keeps 64 and its visibility moves by about one
/// sphere's share, as it does from 63 to 64 where nothing is dropped.
#[test]
fn passing_the_blocker_limit_moves_the_visibility_by_one_blocker() {
    let n = DVec3::Y;
    let twin = Twin::new(&LobesOptions { take_whole: 0.0, ..Default::default() }).expect("tables");
    let sphere = |i: usize| Sphere::new(DVec3::new(0.3 * (i % 9) as f64 - 1.2, 3.0, 0.3 * (i / 9) as f64 - 1.0), 0.05);
    let vis = |count: usize| {
        let spheres: Vec<Sphere> = (0..count).map(sphere).collect();
        twin.env_visibility(DVec3::ZERO, n, &bvh(&spheres), &[])
    };
    let (v63, v64, v65) = (vis(63), vis(64), vis(65));
    let (step_fits, step_over) = (v63 - v64, v64 - v65);
    eprintln!("visibility 63: {v63:.5}, 64: {v64:.5}, 65: {v65:.5}");
    assert!(step_over.abs() <= 2.0 * step_fits.abs() + 1e-3, "63 -> 64: {step_fits}, 64 -> 65: {step_over}");
}
