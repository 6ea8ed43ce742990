//! Lights from the environment (engine::math::env_lights, `env_lights=on`): the decomposition must not count
//! anything twice, whatever the map.
//! - The furnace-style identity: unshadowed (`none`), the lights plus the residual render what the whole map
//!   renders, per pixel, on a plane and on the bunny, under both shipped maps.
//! - K = 0 is exactly today's image; a black map, a constant map and a map of one bright texel work.
//! - Every registered technique with the option renders finite, non-negative pixels with it on.
//! - Turning the environment turns its lights.

use engine::math::envmap::LatLongMap;
use engine::passes::shade::TECHNIQUES;
use engine::renderer::{RenderSettings, Renderer};
use engine::scene::{Camera, Instance, Material, Scene, SceneBlockers};
use engine_tests::relative_rmse;
use glam::{Mat4, Vec3};

const W: u32 = 48;
const H: u32 = 36;

fn envmap(name: &str) -> LatLongMap {
    engine::scene::load_environment(&scenes::assets_dir().join("envmaps").join(name)).expect("shipped map")
}

/// A Lambertian plane (and nothing else) under `env`, seen from above at an angle.
fn plane(env: LatLongMap) -> Scene {
    Scene {
        meshes: vec![scenes::shapes::ground_plane(1.5, 8)],
        materials: vec![Material::diffuse(Vec3::splat(0.6))],
        instances: vec![Instance { mesh: 0, transform: Mat4::IDENTITY, material: 0 }],
        environment: env,
        environment_intensity: 1.0,
        env_lights: Default::default(),
        lights: Vec::new(),
        blockers: SceneBlockers::default(),
        camera: Camera { eye: Vec3::new(0.0, 2.2, 2.4), target: Vec3::new(0.0, 0.0, -0.2), fov_y_degrees: 45.0 },
    }
}

fn bunny() -> Scene {
    scenes::build("bunny", None).expect("bunny scene")
}

/// Render `scene` with `spec`; also the number of lights the split made (None: no split was made).
fn render(scene: &Scene, spec: &str) -> (Vec<f32>, Option<usize>) {
    let gpu = engine_tests::gpu();
    let mut r = Renderer::new(
        &gpu,
        scene,
        RenderSettings { width: W, height: H, technique: spec.into(), ..Default::default() },
    )
    .expect("renderer");
    r.render(&gpu).expect("frame");
    let hdr = r.read_radiance(&gpu).expect("readback");
    let lights = r.scene.env_split_if_made().map(|s| s.decomposition.lights.len());
    r.destroy(&gpu);
    gpu.shutdown().expect("clean teardown");
    engine_tests::assert_finite(&hdr, spec);
    (hdr, lights)
}

/// Relative RMSE of `none` with the split against `none` without it, over every pixel (the background is the
/// whole map in both), and the largest relative error of a pixel's channel.
fn identity_error(scene: &Scene) -> (f64, f64, usize) {
    let (whole, none_split) = render(scene, "none");
    assert_eq!(none_split, None, "env_lights=off makes no split");
    let (split, lights) = render(scene, "none:env_lights=on");
    let lights = lights.expect("env_lights=on makes the split");
    let rmse = relative_rmse(&split, &whole, |_| true);
    let max = (0..whole.len() / 4)
        .flat_map(|i| {
            let (a, b) = (engine_tests::rgb(&split, i), engine_tests::rgb(&whole, i));
            (0..3).map(move |c| (a[c] - b[c]).abs() / b[c].max(1e-6))
        })
        .fold(0.0, f64::max);
    (rmse, max, lights)
}

#[test]
fn lights_plus_residual_equal_the_map_unshadowed() {
    // Measured (48×36): plane courtyard 0.44 % RMSE / 1.3 % max, sunset 0.13 % / 0.4 %; bunny courtyard
    // 0.56 % / 4.9 %. What remains is the shape of each piece against its cap (same power, mean direction
    // and spread; the difference is of second order in the cap's size) and, for the glossy bunny, the
    // lobes that resolve it. The bounds are the measurements with margin.
    for (name, scene, rmse_bound, max_bound) in [
        ("plane, courtyard", plane(envmap("courtyard.exr")), 0.015, 0.03),
        ("plane, sunset", plane(envmap("sunset.exr")), 0.02, 0.05),
        ("bunny", bunny(), 0.02, 0.25),
    ] {
        let (rmse, max, lights) = identity_error(&scene);
        eprintln!("{name}: {lights} lights, relative RMSE {:.3} %, max {:.2} %", 100.0 * rmse, 100.0 * max);
        assert!(lights >= 2, "{name}: {lights} lights");
        assert!(rmse < rmse_bound, "{name}: relative RMSE {rmse}");
        assert!(max < max_bound, "{name}: largest pixel error {max}");
    }
}

#[test]
fn no_lights_is_todays_image_and_hard_maps_work() {
    // K = 0: the split holds the map itself and no light, so the image is today's, bit for bit.
    let mut scene = plane(envmap("courtyard.exr"));
    scene.env_lights.max_lights = 0;
    let (whole, _) = render(&scene, "none");
    let (split, lights) = render(&scene, "none:env_lights=on");
    assert_eq!(lights, Some(0));
    assert_eq!(whole, split, "K = 0 changes nothing");
    // Black: no light, a black image, no division by zero.
    let (black, lights) = render(&plane(LatLongMap::constant(64, 32, [0.0; 3])), "none:env_lights=on");
    assert_eq!(lights, Some(0));
    assert!(black.chunks(4).all(|p| p[..3] == [0.0; 3]));
    // Constant: no light (nothing is brighter than the mean).
    let (_, lights) = render(&plane(LatLongMap::constant(64, 32, [0.5, 0.7, 1.0])), "none:env_lights=on");
    assert_eq!(lights, Some(0));
    // One bright texel: one light holding all of it; the identity still holds.
    let mut one = LatLongMap::constant(64, 32, [0.0; 3]);
    one.texels[6 * 64 + 10] = [500.0, 400.0, 300.0];
    let (rmse, _, lights) = identity_error(&plane(one));
    assert_eq!(lights, 1);
    assert!(rmse < 0.01, "one texel: {rmse}");
}

#[test]
fn every_technique_renders_with_the_environment_lights() {
    let scene = bunny();
    for entry in TECHNIQUES.iter().filter(|t| t.options.iter().any(|o| o.key == "env_lights")) {
        let (hdr, lights) = render(&scene, &format!("{}:env_lights=on", entry.name));
        assert!(lights.unwrap_or(0) >= 2, "{}: the split was not used", entry.name);
        assert!(hdr.iter().all(|x| x.is_finite() && *x >= 0.0), "{}: a negative or non-finite pixel", entry.name);
    }
}

#[test]
fn turning_the_environment_turns_its_lights() {
    let gpu = engine_tests::gpu();
    let scene = plane(envmap("sunset.exr"));
    let settings =
        RenderSettings { width: 16, height: 12, technique: "none:env_lights=on".into(), ..Default::default() };
    let mut r = Renderer::new(&gpu, &scene, settings).expect("renderer");
    let first = r.scene.env_split_if_made().expect("split").decomposition.lights[0];
    r.set_environment_rotation(&gpu, 90.0).expect("rotate");
    let turned = r.scene.env_split_if_made().expect("split made again").decomposition.lights[0];
    r.render(&gpu).expect("frame");
    r.destroy(&gpu);
    gpu.shutdown().expect("clean teardown");
    // The map turns about +y by 90°: a texel's azimuth φ = 2πu grows by 90° (LatLongMap::rotated_y).
    let az = |d: [f64; 3]| d[2].atan2(d[0]).to_degrees();
    let delta = (az(turned.direction) - az(first.direction)).rem_euclid(360.0);
    assert!((delta - 90.0).abs() < 1.0, "the brightest light turned by {delta}°");
    assert!((turned.share - first.share).abs() < 0.01);
}
