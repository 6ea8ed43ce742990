//! The two example scene files render (tiny, validation on), the arm's clip moves its shadow, and the Monte Carlo
//! reference traces the glTF-animated pose (issue 16 item 4: its triangle BVH is rebuilt per pose, so a
//! glTF-animated frame has a triangle ground truth): the triangles it traces equal the skin pass's world vertices.

use engine::passes::shade::reference::ReferenceOptions;
use engine::renderer::{RenderSettings, Renderer};
use engine::resources::layout::GpuVertex;
use glam::Vec3;
use lab::converge;
use scenes::user::{self, UserOptions};
use std::path::PathBuf;

const W: u32 = 64;
const H: u32 = 48;

fn example(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples").join(name)
}

/// Small fits in a fresh cache (the examples' sphere counts, fewer iterations).
fn options(test: &str) -> UserOptions {
    let cache = std::env::temp_dir().join(format!("user-scenes-gpu-{}-{test}", std::process::id()));
    UserOptions {
        cache: Some(cache),
        fit: Some(engine::blockers::fit::FitSettings {
            grid_resolution: 12,
            lookup_resolution: 16,
            volume_samples: 32,
            max_iterations: 8,
            max_teleports: 2,
            ..Default::default()
        }),
        ..Default::default()
    }
}

#[test]
fn example_scene_files_render_and_the_arm_moves() {
    let gpu = engine_tests::gpu();
    let assets = scenes::assets_dir();
    for name in ["arm.toml", "still_life.toml", "glossy_light.toml", "lafortune_map.toml"] {
        let u = user::scene_file(&example(name), None, &assets, &options("examples"))
            .unwrap_or_else(|e| panic!("{name}: {e:#}"));
        let settings = RenderSettings { width: W, height: H, ..Default::default() };
        let mut r = Renderer::new(&gpu, &u.scene, settings).unwrap_or_else(|e| panic!("{name}: {e}"));
        r.render(&gpu).unwrap();
        let first = r.read_radiance(&gpu).unwrap();
        engine_tests::assert_finite(&first, name);
        assert!(first.iter().any(|v| *v > 0.0), "{name}: a black image");
        if let Some(clips) = u.clips {
            let a = scenes::Animation::clips(clips);
            a.apply(&mut r, 1.0).unwrap();
            r.render(&gpu).unwrap();
            let bent = r.read_radiance(&gpu).unwrap();
            engine_tests::assert_finite(&bent, name);
            let changed = first.iter().zip(&bent).filter(|(a, b)| (*a - *b).abs() > 1e-3 * a.abs().max(1e-3)).count();
            assert!(changed > 50, "{name}: the bent arm changes {changed} values only");
        } else {
            assert_ne!(name, "arm.toml", "the arm has clips");
        }
        r.destroy(&gpu);
    }
}

#[test]
fn the_reference_traces_the_gltf_animated_pose() {
    let gpu = engine_tests::gpu();
    let u =
        user::scene_file(&example("arm.toml"), None, &scenes::assets_dir(), &options("reference")).expect("arm.toml");
    let settings = RenderSettings { width: 32, height: 24, technique: "reference".into(), ..Default::default() };
    let mut r = Renderer::new(&gpu, &u.scene, settings).expect("renderer");
    let opts = ReferenceOptions { samples_per_frame: 4, ..ReferenceOptions::default() };
    converge::reference_mut(&mut r).expect("reference").set_options(opts).expect("options");
    let clips = scenes::Animation::clips(u.clips.expect("the arm has clips"));
    for t in [0.0, 1.0] {
        clips.apply(&mut r, t).unwrap();
        r.render(&gpu).unwrap();
        let g = &r.scene.geometry;
        let world: Vec<GpuVertex> = gpu.read_buffer(&g.world_vertices).expect("world vertices");
        let indices: Vec<u32> = gpu.read_buffer(&g.indices).expect("indices");
        let indices = indices[..g.index_count as usize].to_vec();
        let reference = converge::reference_mut(&mut r).expect("reference");
        let tris = reference.posed_triangles().expect("prepared");
        assert_eq!(tris.len(), indices.len() / 3);
        let mut worst = 0f32;
        for (tri, ix) in tris.iter().zip(indices.chunks_exact(3)) {
            for k in 0..3 {
                worst = worst.max((tri[k] - Vec3::from(world[ix[k] as usize].position)).length());
            }
        }
        assert!(worst < 1e-4, "t = {t}: reference triangles are {worst} from the skinned vertices");
        drop(tris);
        engine_tests::assert_finite(&r.read_radiance(&gpu).unwrap(), "reference");
    }
    r.destroy(&gpu);
}
