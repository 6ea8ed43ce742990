//! The lit room (`scenes::gltf_writer::lit_room`, `examples/lit_room.gltf`) renders through its own camera with its
//! own lights in every technique (tiny, validation on): finite, not black; and the directional light arrives with
//! the illuminance the file gives, in the engine's units (lux / 683), through the renderer: `none` shades spherical
//! lights in closed form, so the sun's share of a floor pixel is ρ/π · E cos θ.

use engine::renderer::{RenderSettings, Renderer};
use engine::scene::gltf_import::PHOTOMETRIC_EXPOSURE;
use std::path::PathBuf;

const W: u32 = 64;
const H: u32 = 48;

fn lit_room() -> engine::scene::Scene {
    let example = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/lit_room.gltf");
    let cache = std::env::temp_dir().join(format!("authored-gpu-{}", std::process::id()));
    let opts = engine_tests::small_fit_options(8, &cache);
    scenes::load(example.to_str().unwrap(), None, &opts).expect("examples/lit_room.gltf").scene
}

fn render(gpu: &engine::gpu::Gpu, scene: &engine::scene::Scene, technique: &str) -> Vec<f32> {
    let settings = RenderSettings { width: W, height: H, technique: technique.into(), ..Default::default() };
    let mut r = Renderer::new(gpu, scene, settings).unwrap_or_else(|e| panic!("{technique}: {e}"));
    r.render(gpu).unwrap();
    let out = r.read_radiance(gpu).unwrap();
    r.destroy(gpu);
    engine_tests::assert_finite(&out, technique);
    out
}

#[test]
fn the_lit_room_renders_in_every_technique_and_its_sun_has_the_files_illuminance() {
    let gpu = engine_tests::gpu();
    let scene = lit_room();
    assert_eq!((scene.lights.len(), scene.meshes.len()), (2, 2), "two file lights; block and floor, no engine ground");
    let mut with = Vec::new();
    for technique in ["none", "isg", "shexp", "lobes", "reference"] {
        let img = render(&gpu, &scene, technique);
        let lit = img.chunks_exact(4).filter(|p| p[1] > 0.0).count();
        assert!(lit > (W * H / 4) as usize, "{technique}: only {lit} lit pixels");
        if technique == "none" {
            with = img;
        }
    }
    // The sun's share: with and without it, technique `none`.
    let mut dark = scene.clone();
    dark.lights.truncate(1);
    let without = render(&gpu, &dark, "none");
    // The floor (ρ_d = 0.6) faces up; the sun is 50° high: E cos θ = E sin 50°.
    let e = scenes::gltf_writer::ROOM_SUN_LUX * PHOTOMETRIC_EXPOSURE * 50f32.to_radians().sin();
    let want = 0.6 / std::f32::consts::PI * e;
    let deltas: Vec<f32> = with.chunks_exact(4).zip(without.chunks_exact(4)).map(|(a, b)| a[1] - b[1]).collect();
    // Within 6 %: the floor's weak specular term (k_s = 0.04, roughness 1) adds a little.
    let floor = deltas.iter().filter(|d| (**d / want - 1.0).abs() < 0.06).count();
    assert!(
        floor > (W * H / 5) as usize,
        "{floor} pixels get the sun's ρ/π·E cos θ = {want} (deltas: {:?})",
        &deltas[deltas.len() - W as usize..]
    );
}
