//! Switching BRDFs at run time (`Renderer::set_materials`, the viewer's `B` key, 32×24, validation on): the
//! image after the switch equals a renderer built with those materials, the reference discards the samples it
//! accumulated under the old ones, and a wrong count or a non-finite parameter is an error, not a frame.

use engine::math::envmap::LatLongMap;
use engine::passes::shade::reference::ReferenceOptions;
use engine::renderer::{RenderSettings, Renderer};
use engine::scene::Material;
use engine_tests::{assert_finite, fixtures::sphere_over_plane, gpu, relative_rmse, render};
use glam::Vec3;
use lab::converge::reference_mut;
use scenes::BrdfCycle;

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
    for _ in 0..=scenes::BRDF_PRESETS.len() {
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
    let chess = scenes::build("chess", None).unwrap();
    assert_eq!(scenes::brdf_materials(&chess), vec![0, 1]);
    // No glossy material: material 0, as --brdf always did.
    let arm = scenes::build("arm", None).unwrap();
    assert_eq!(scenes::brdf_materials(&arm), vec![0]);
    // Every preset parses and changes only the targets.
    let mut cycle = BrdfCycle::new(&chess);
    for _ in 0..scenes::BRDF_PRESETS.len() {
        let m = cycle.step().unwrap();
        assert_eq!(m[2..], chess.materials[2..], "{}", cycle.label());
        assert_ne!(m[0], chess.materials[0], "{}", cycle.label());
    }
    assert_eq!(cycle.step().unwrap(), chess.materials, "the cycle returns to the scene's own");
}

/// Per-vertex materials (a material map, `Mesh::material_offsets`): the plane's left half (x < 0) is Phong
/// e = 10, its right half an off-specular Lafortune lobe e = 200, under a light and the environment. Every
/// registered technique, per pixel and per vertex: each half renders as the plane built with its material
/// alone (per pixel: exactly, the material is the triangle's first vertex's; per vertex: away from the
/// boundary's cells), and the halves differ (so the test can fail).
#[test]
fn per_vertex_materials_reach_every_technique() {
    use engine::passes::shade::TECHNIQUES;
    use engine::scene::{Brdf, SphereLight};
    let gpu = gpu();
    let mut base = scene();
    base.lights = vec![SphereLight { center: Vec3::new(0.3, 1.6, -1.4), radius: 0.3, radiance: Vec3::splat(8.0) }];
    let phong = |mut m: Material, c: [f32; 3], e: f32, ks: f32| {
        m.brdf = Brdf::lafortune(c, e);
        m.specular = Vec3::splat(ks);
        m
    };
    let a = phong(base.materials[0], engine::scene::PHONG_C, 10.0, 0.3);
    // b holds three Lafortune lobes (Eq. 28's sum).
    let mut b = Material::diffuse(Vec3::splat(0.1));
    b.apply_brdf_spec("lafortune:cx=-1,cy=-1,cz=0.7,e=200,ks=0.8,w1=0.5,e1=8,w2=0.3,cx2=0.9,cy2=0.9,cz2=0.9,e2=20")
        .unwrap();
    // Materials: 0 = a, 1 = b, 2 = the ball; the plane's vertices right of x = 0 take offset 1.
    let ball = base.materials[1];
    let mut mixed = base.clone();
    mixed.materials = vec![a, b, ball];
    mixed.instances[1].material = 2;
    let plane = &mut mixed.meshes[0];
    plane.material_offsets = plane.positions.iter().map(|p| u32::from(p.x > 1e-6)).collect();
    let only = |material: usize| {
        let mut s = mixed.clone();
        s.meshes[0].material_offsets.clear();
        s.instances[0].material = material;
        s
    };
    let (all_a, all_b) = (only(0), only(1));
    for entry in TECHNIQUES {
        for per_vertex in [false, true] {
            let what = format!("{}{}", entry.name, if per_vertex { " per vertex" } else { "" });
            let s = RenderSettings { per_vertex, ..settings(entry.name) };
            let (got, receivers) = engine_tests::render_with_gbuffer(&gpu, &mixed, s.clone());
            assert_finite(&got, &what);
            let (want_a, _) = render(&gpu, &all_a, s.clone());
            let (want_b, _) = render(&gpu, &all_b, s);
            // Per pixel: the G-buffer's material says which half; per vertex: the pixel's position, a cell
            // (0.375) clear of the boundary.
            let half = |i: usize, which: usize| match receivers[i] {
                Some((p, _, m)) if m < 2 => {
                    if per_vertex {
                        (if which == 0 { p.x < -0.4 } else { p.x > 0.4 }) && p.y.abs() < 1e-3
                    } else {
                        m == which
                    }
                }
                _ => false,
            };
            let count = |which| (0..receivers.len()).filter(|&i| half(i, which)).count();
            assert!(count(0) > 40 && count(1) > 40, "{what}: halves in view ({}, {})", count(0), count(1));
            let ea = relative_rmse(&got, &want_a, |i| half(i, 0));
            let eb = relative_rmse(&got, &want_b, |i| half(i, 1));
            let apart = relative_rmse(&want_a, &want_b, |i| half(i, 1));
            eprintln!("{what}: left vs all-a {ea:.1e}, right vs all-b {eb:.1e}; the materials differ by {apart:.2}");
            assert!(ea < 1e-5 && eb < 1e-5, "{what}: left {ea}, right {eb}");
            assert!(apart > 0.05, "{what}: the two materials render alike ({apart})");
        }
    }
    // Bad offsets are errors, not frames: a wrong count, and offsets past the last material.
    let mut short = mixed.clone();
    short.meshes[0].material_offsets.pop();
    let e = Renderer::new(&gpu, &short, settings("none")).err().expect("a short offset list").to_string();
    assert!(e.contains("material offsets for") && e.contains("vertices"), "{e}");
    let mut past = mixed.clone();
    past.instances[0].material = 2;
    let e = Renderer::new(&gpu, &past, settings("none")).err().expect("offsets past the materials").to_string();
    assert!(e.contains("reach material 3 of 3"), "{e}");
    gpu.shutdown().expect("clean teardown");
}
