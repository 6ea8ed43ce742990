//! Plane blockers (half-spaces and rectangles, engine_blockers::plane) on lavapipe:
//! - a plane with no geometry at all: `isg` and the sphere-proxy reference see only the upper
//!   hemisphere (closed form) because of the plane alone, while the triangle reference (nothing below)
//!   does not, so the test fails when a technique ignores planes;
//! - `isg` against its f64 twin (cpu::shade_diffuse_and_ratio_by with the gathered planes) at the
//!   G-buffer's receivers of a scene with a ground rectangle, a wall plate and one sphere.
//!
//! The registry-wide closed-form test (every shadowing technique) is in techniques.rs.

use engine::math::envmap::LatLongMap;
use engine::math::isg::IsgLut;
use engine::passes::shade::isg::{cpu, Diffuse, IsgOptions};
use engine::passes::shade::reference::{ReferenceOptions, Visibility};
use engine::renderer::{RenderSettings, Renderer};
use engine::scene::blockers::BlockerPlane;
use engine::scene::Scene;
use engine_tests::fixtures::{ball_above_ground, GroundBlocker};
use engine_tests::{assert_finite, relative_rmse, render_with_gbuffer, rgb, Receiver};
use glam::{DVec3, Vec3};
use lab::converge;

const W: u32 = 48;
const H: u32 = 36;

fn settings(technique: &str) -> RenderSettings {
    RenderSettings { width: W, height: H, technique: technique.into(), ..Default::default() }
}

/// The reference at `spp` samples per pixel with `visibility`.
fn reference(gpu: &engine::gpu::Gpu, scene: &Scene, spp: u32, visibility: Visibility) -> (Vec<f32>, Vec<Receiver>) {
    let mut r = Renderer::new(gpu, scene, settings("reference")).expect("renderer");
    let opts = ReferenceOptions { samples_per_frame: 16, visibility, ..Default::default() };
    converge::reference_mut(&mut r).expect("reference").set_options(opts).expect("options");
    converge::converge(gpu, &mut r, 0.0, spp).expect("accumulate");
    let hdr = r.read_radiance(gpu).expect("radiance");
    r.destroy(gpu);
    let (_, g) = render_with_gbuffer(gpu, scene, settings("none"));
    (hdr, g)
}

/// A ball above a half-space y < 0 with no ground mesh: the plane is the only thing below.
#[test]
fn a_plane_without_geometry_hides_the_lower_hemisphere() {
    let gpu = engine_tests::gpu();
    let (albedo, l) = (0.7f32, 1.5f32);
    let env = LatLongMap::constant(64, 32, [l; 3]);
    let mut scene = ball_above_ground(env, albedo, Vec3::new(0.0, 0.6, 0.0), 0.4, GroundBlocker::HalfSpace);
    scene.instances.truncate(1);
    scene.meshes.truncate(1);
    let (isg, g) = render_with_gbuffer(&gpu, &scene, settings("isg"));
    let (spheres, _) = reference(&gpu, &scene, 1024, Visibility::Spheres);
    let (triangles, _) = reference(&gpu, &scene, 256, Visibility::Triangles);
    gpu.shutdown().expect("clean teardown");
    let want: Vec<f32> = g
        .iter()
        .flat_map(|px| {
            let v = px.map_or(0.0, |(_, n, _)| albedo * l * (1.0 + n.y as f32) / 2.0);
            [v, v, v, 1.0]
        })
        .collect();
    let ball = |i: usize| g[i].is_some();
    assert!((0..g.len()).filter(|&i| ball(i)).count() > 300, "the ball is in view");
    for (img, what, bound) in [(&isg, "isg", 0.02), (&spheres, "reference (spheres)", 0.03)] {
        assert_finite(img, what);
        let e = relative_rmse(img, &want, ball);
        eprintln!("{what}: upper hemisphere only, relative RMSE {:.2} % (bound {:.0} %)", 100.0 * e, 100.0 * bound);
        assert!(e < bound, "{what}: {e} against the closed form");
    }
    // Without the plane (the triangle reference has nothing below the ball) the underside is lit.
    let e = relative_rmse(&triangles, &want, ball);
    eprintln!("reference (triangles, no ground mesh): {:.1} % from the closed form", 100.0 * e);
    assert!(e > 0.15, "the test cannot tell a plane from none: {e}");
}

// `isg` (diffuse=sg, every BVH node opened) against its f64 twin with planes among the blockers: the
// ground (a mesh marked as a plane: a rectangle), a wall plate standing beside the sphere (an explicit
// rectangle) and a half-space tilted under it all. f32 differences in the patch-centre tests can flip a
// patch on a boundary, so the bound is on the 95th percentile (2e-3 relative) and the maximum (5 %).
#[test]
fn gpu_matches_the_f64_twin_with_planes() {
    let gpu = engine_tests::gpu();
    let sky = scenes::sphere::sky();
    let (c, r) = (Vec3::new(0.2, 0.6, -0.1), 0.45f32);
    let mut scene = engine_tests::fixtures::sphere_over_plane(sky.clone(), 0.7, c, r);
    scene.blockers.plane_meshes = vec![true, false];
    scene.blockers.planes = vec![
        BlockerPlane::rectangle(DVec3::new(-0.8, 0.5, 0.0), DVec3::new(0.0, 0.5, 0.0), DVec3::new(0.0, 0.0, 0.9)),
        BlockerPlane::half_space(DVec3::new(0.0, -0.05, 0.0), DVec3::new(0.2, 1.0, 0.1)),
    ];
    let planes = engine::resources::blockers::gather_planes(&scene).expect("planes");
    assert_eq!(planes.len(), 3);
    let lut = IsgLut::generate_default();
    let lobes = engine_tests::isg_lobes_as_the_gpu_reads_them(&sky);
    // The twin sees the planes as the GPU does (f32 records).
    let planes: Vec<BlockerPlane> = planes
        .iter()
        .map(|p| {
            let f = |v: DVec3| v.as_vec3().as_dvec3();
            BlockerPlane {
                normal: f(p.normal),
                offset: p.offset as f32 as f64,
                rect: p.rect.map(|(c, u, v)| (f(c), f(u), f(v))),
                epsilon: p.epsilon as f32 as f64,
            }
        })
        .collect();
    let spheres = [engine::blockers::Sphere::new(c.as_dvec3(), r as f64)];
    let occ = cpu::Occluders { spheres: &spheres, thin: &[], planes: &planes };
    let spec = "isg:diffuse=sg,threshold=0";
    let (hdr, g) = render_with_gbuffer(&gpu, &scene, settings(spec));
    let (plain, _) = render_with_gbuffer(&gpu, &scene, settings("none"));
    gpu.shutdown().expect("clean teardown");
    assert_finite(&hdr, spec);
    let o = IsgOptions { diffuse: Diffuse::Sg, node_threshold: 0.0, ..IsgOptions::default() };
    let (mut errs, mut by_planes) = (Vec::new(), 0);
    for (i, px) in g.iter().enumerate().step_by(3) {
        let Some((p, n, m)) = *px else { continue };
        let albedo = [0.7, 0.8][m];
        let pt = cpu::Point {
            position: p,
            normal: n,
            view: DVec3::Y,
            diffuse: [albedo; 3],
            specular: [0.0; 3],
            shininess: 1.0,
        };
        let (want, _) = cpu::shade_diffuse_and_ratio_by(&pt, &lobes, &o, &occ, &lut);
        let (alone, _) = cpu::shade_diffuse_and_ratio(&pt, &lobes, &o, &spheres, &lut);
        by_planes += ((alone[1] - want[1]).abs() > 0.02 * alone[1]) as usize;
        let got = rgb(&hdr, i);
        for ch in 0..3 {
            errs.push((got[ch] - want[ch]).abs() / want[ch].abs().max(1e-3));
        }
    }
    errs.sort_by(f64::total_cmp);
    let (p95, max) = (errs[errs.len() * 95 / 100], errs[errs.len() - 1]);
    eprintln!(
        "{spec}: {} samples ({by_planes} receivers shadowed by the planes), p95 {p95:.2e}, max {max:.2e}",
        errs.len()
    );
    assert!(errs.len() > 300 && by_planes > 30, "too few receivers ({}) or plane shadows ({by_planes})", errs.len());
    assert!(p95 < 2e-3 && max < 0.05, "{spec}: GPU vs twin relative error p95 {p95}, max {max}");
    assert!(relative_rmse(&hdr, &plain, |_| true) > 0.01, "the planes and sphere shadow the scene");
}
