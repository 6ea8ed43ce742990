//! Switching BRDFs at run time (`Renderer::set_materials`, the viewer's `B` key, 32×24, validation on): the
//! image after the switch equals a renderer built with those materials, the reference discards the samples it
//! accumulated under the old ones, and a wrong count or a non-finite parameter is an error, not a frame.

use demos::BrdfCycle;
use engine::converge::reference_mut;
use engine::math::envmap::LatLongMap;
use engine::passes::shade::reference::ReferenceOptions;
use engine::renderer::{RenderSettings, Renderer};
use engine::scene::Material;
use engine_tests::{assert_finite, fixtures::sphere_over_plane, gpu, relative_rmse, render};
use glam::Vec3;

const W: u32 = 32;
const H: u32 = 24;

fn scene() -> engine::scene::Scene {
    // A glossy ball over a diffuse plane under a non-constant environment (so the BRDF shows).
    let mut env = LatLongMap::constant(32, 16, [0.0; 3]);
    for row in 0..16 {
        for col in 0..32 {
            let d = env.texel_direction(col, row);
            env.texels[row * 32 + col] = [0.3 + 0.7 * d[1].max(0.0) as f32, 0.5, 0.4 + 0.6 * d[0].abs() as f32];
        }
    }
    let mut s = sphere_over_plane(env, 0.5, Vec3::new(0.0, 0.6, 0.0), 0.4);
    s.materials[1] = Material::glossy(Vec3::splat(0.6), 0.3, 50.0);
    s
}

fn settings(technique: &str) -> RenderSettings {
    RenderSettings { width: W, height: H, technique: technique.into(), ..Default::default() }
}

#[test]
fn switched_materials_render_as_if_built_with_them() {
    let gpu = gpu();
    let base = scene();
    let mut cycle = BrdfCycle::new(&base);
    let mut r = Renderer::new(&gpu, &base, settings("none")).unwrap();
    r.render(&gpu).unwrap();
    let before = r.read_radiance(&gpu).unwrap();
    // Every preset, then back to the scene's own.
    for _ in 0..=demos::BRDF_PRESETS.len() {
        let materials = cycle.step().unwrap();
        r.set_materials(&gpu, &materials).unwrap();
        r.render(&gpu).unwrap();
        let switched = r.read_radiance(&gpu).unwrap();
        assert_finite(&switched, cycle.label());
        let mut built = base.clone();
        built.materials = materials;
        let (fresh, _) = render(&gpu, &built, settings("none"));
        let e = relative_rmse(&switched, &fresh, |_| true);
        assert!(e < 1e-6, "{}: switched vs built {e}", cycle.label());
        if cycle.label() != "scene's own" {
            // The ball's BRDF changed, so the image did (the test can fail).
            assert!(relative_rmse(&switched, &before, |_| true) > 1e-3, "{}: no change", cycle.label());
        }
    }
    r.destroy(&gpu);
}

#[test]
fn the_reference_restarts_and_bad_materials_are_refused() {
    let gpu = gpu();
    let base = scene();
    let mut r = Renderer::new(&gpu, &base, settings("reference")).unwrap();
    let reference = reference_mut(&mut r).unwrap();
    reference.set_options(ReferenceOptions { samples_per_frame: 1, ..reference.options() }).unwrap();
    r.render(&gpu).unwrap();
    r.render(&gpu).unwrap();
    assert!(reference_mut(&mut r).unwrap().samples(false) > 0);
    let mut materials = base.materials.clone();
    materials[1].apply_brdf_spec("blinn-phong:s=1000,ks=0.5").unwrap();
    r.set_materials(&gpu, &materials).unwrap();
    assert_eq!(reference_mut(&mut r).unwrap().samples(false), 0, "samples of the old materials kept");

    let e = r.set_materials(&gpu, &materials[..1]).unwrap_err().to_string();
    assert!(e.contains("1 materials given, the scene has 2"), "{e}");
    materials[0].diffuse = Vec3::new(f32::NAN, 0.5, 0.5);
    let e = r.set_materials(&gpu, &materials).unwrap_err().to_string();
    assert!(e.contains("material 0 has a non-finite parameter"), "{e}");
    r.render(&gpu).unwrap();
    assert_finite(&r.read_radiance(&gpu).unwrap(), "after refused materials");
    r.destroy(&gpu);
}

#[test]
fn brdf_switch_targets_the_glossy_materials() {
    // Chess: the white and black pieces (materials 0 and 1), not the squares or the ground.
    let chess = demos::scenes::build("chess", None).unwrap();
    assert_eq!(demos::brdf_materials(&chess), vec![0, 1]);
    // No glossy material: material 0, as --brdf always did.
    let arm = demos::scenes::build("arm", None).unwrap();
    assert_eq!(demos::brdf_materials(&arm), vec![0]);
    // Every preset parses and changes only the targets.
    let mut cycle = BrdfCycle::new(&chess);
    for _ in 0..demos::BRDF_PRESETS.len() {
        let m = cycle.step().unwrap();
        assert_eq!(m[2..], chess.materials[2..], "{}", cycle.label());
        assert_ne!(m[0], chess.materials[0], "{}", cycle.label());
    }
    assert_eq!(cycle.step().unwrap(), chess.materials, "the cycle returns to the scene's own");
}
