//! Rotating the environment at run time (`Renderer::set_environment_rotation`, the viewer's `E` key,
//! `demo --env-rotation`; 32×24, validation on): for every registered technique but the reference, the image
//! after the turn equals a renderer built with the turned map, differs from the unturned one, and turning back
//! gives the first image again; the reference restarts its samples; a non-finite angle is an error that leaves
//! the renderer as it was; `--env-spin` (`scenes::spin_environment`) turns by the rate times the time.

use engine::math::envmap::LatLongMap;
use engine::passes::shade::reference::ReferenceOptions;
use engine::passes::shade::TECHNIQUES;
use engine::renderer::{RenderSettings, Renderer};
use engine_tests::{assert_finite, fixtures::sphere_over_plane, gpu, relative_rmse, render};
use glam::Vec3;
use lab::converge::reference_mut;

const W: u32 = 32;
const H: u32 = 24;

/// A ball over a plane under an environment bright towards +x and +y (a quarter turn about +y moves the
/// bright side, so the image changes).
fn scene(rotation: f32) -> engine::scene::Scene {
    let mut env = LatLongMap::constant(32, 16, [0.0; 3]);
    for row in 0..16 {
        for col in 0..32 {
            let d = env.texel_direction(col, row);
            let x = d[0].max(0.0) as f32;
            env.texels[row * 32 + col] = [0.2 + 2.0 * x, 0.3 + 0.7 * d[1].max(0.0) as f32, 0.3 + x];
        }
    }
    sphere_over_plane(env.rotated_y(rotation), 0.5, Vec3::new(0.0, 0.6, 0.0), 0.4)
}

fn settings(technique: &str) -> RenderSettings {
    RenderSettings { width: W, height: H, technique: technique.into(), ..Default::default() }
}

#[test]
fn turned_environment_renders_as_if_built_turned() {
    let gpu = gpu();
    let base = scene(0.0);
    for t in TECHNIQUES.iter().filter(|t| t.name != "reference") {
        let mut r = Renderer::new(&gpu, &base, settings(t.name)).unwrap();
        r.render(&gpu).unwrap();
        let before = r.read_radiance(&gpu).unwrap();
        let start = std::time::Instant::now();
        r.set_environment_rotation(&gpu, 90.0).unwrap();
        println!("{}: turned in {:.0} ms", t.name, start.elapsed().as_secs_f64() * 1e3);
        assert_eq!(r.environment_rotation(), 90.0);
        r.render(&gpu).unwrap();
        let turned = r.read_radiance(&gpu).unwrap();
        assert_finite(&turned, t.name);
        let (fresh, _) = render(&gpu, &scene(90.0), settings(t.name));
        let e = relative_rmse(&turned, &fresh, |_| true);
        assert!(e < 1e-5, "{}: turned at run time vs built turned: {e}", t.name);
        let change = relative_rmse(&turned, &before, |_| true);
        assert!(change > 1e-2, "{}: a quarter turn changed the image by only {change}", t.name);
        r.set_environment_rotation(&gpu, 0.0).unwrap();
        r.render(&gpu).unwrap();
        let back = r.read_radiance(&gpu).unwrap();
        let e = relative_rmse(&back, &before, |_| true);
        assert!(e < 1e-5, "{}: turned back vs never turned: {e}", t.name);
        r.destroy(&gpu);
    }
}

#[test]
fn the_reference_restarts_and_bad_angles_are_refused() {
    let gpu = gpu();
    let mut r = Renderer::new(&gpu, &scene(0.0), settings("reference")).unwrap();
    let reference = reference_mut(&mut r).unwrap();
    reference.set_options(ReferenceOptions { samples_per_frame: 1, ..reference.options() }).unwrap();
    r.render(&gpu).unwrap();
    r.render(&gpu).unwrap();
    assert!(reference_mut(&mut r).unwrap().samples(false) > 0);
    r.set_environment_rotation(&gpu, 45.0).unwrap();
    assert_eq!(reference_mut(&mut r).unwrap().samples(false), 0, "samples of the old environment kept");
    for bad in [f32::NAN, f32::INFINITY] {
        let e = r.set_environment_rotation(&gpu, bad).unwrap_err().to_string();
        assert!(e.contains("not finite"), "{e}");
        assert_eq!(r.environment_rotation(), 45.0, "a refused angle changed the renderer");
    }
    r.render(&gpu).unwrap();
    assert_finite(&r.read_radiance(&gpu).unwrap(), "after refused angles");
    r.destroy(&gpu);
}

#[test]
fn spinning_turns_by_the_rate_times_the_time() {
    let gpu = gpu();
    let mut r = Renderer::new(&gpu, &scene(0.0), settings("none")).unwrap();
    scenes::spin_environment(&gpu, &mut r, 180.0, 0.5).unwrap();
    assert_eq!(r.environment_rotation(), 90.0);
    r.render(&gpu).unwrap();
    let turned = r.read_radiance(&gpu).unwrap();
    let (fresh, _) = render(&gpu, &scene(90.0), settings("none"));
    let e = relative_rmse(&turned, &fresh, |_| true);
    assert!(e < 1e-5, "spun to 90° vs built turned: {e}");
    // Negative rates and more than a turn: modulo 360.
    scenes::spin_environment(&gpu, &mut r, -900.0, 0.5).unwrap();
    assert_eq!(r.environment_rotation(), 270.0);
    r.destroy(&gpu);
}
