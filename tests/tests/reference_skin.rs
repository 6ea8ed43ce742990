//! The Monte Carlo reference sees the skinned geometry the G-buffer sees (issue 14, defect 4). It used to build
//! its triangle BVH from the object-space vertices times the instance transform only, so `--scene arm
//! --technique reference` traced the rest-pose (straight) arm: the shadow of an arm that is not there, and a
//! black blob at the elbow where the bent arm's surface lies inside the straight one.
//!
//! - The triangles the reference traces equal the skin pass's world vertices (read back) within 1e-4, at the
//!   scene's initial pose and after `Renderer::set_bones` and `set_instance_transform` (the BVH is rebuilt when
//!   the pose changes).
//! - The reference image follows the pose: re-posing to A after B gives the same bits as rendering A fresh
//!   (accumulation restarts with the pose), and A's image differs from B's where the shadow moved.

use engine::gpu::Gpu;
use engine::passes::shade::reference::{skin_matrix, skinned_position, ReferenceOptions};
use engine::renderer::{RenderSettings, Renderer};
use engine::resources::layout::GpuVertex;
use glam::{Mat4, Vec3};
use lab::converge;

const W: u32 = 48;
const H: u32 = 32;

fn reference_renderer(gpu: &Gpu, scene: &engine::scene::Scene) -> Renderer {
    let settings = RenderSettings { width: W, height: H, technique: "reference".into(), ..Default::default() };
    let mut r = Renderer::new(gpu, scene, settings).expect("renderer");
    let options = ReferenceOptions { samples_per_frame: 8, ..ReferenceOptions::default() };
    converge::reference_mut(&mut r).expect("reference").set_options(options).expect("options");
    r
}

/// Largest distance between a reference triangle's vertex and the skin pass's world vertex it came from, and the
/// largest distance of those world vertices from the unskinned (rest) ones.
fn compare_with_skin_pass(gpu: &Gpu, r: &mut Renderer, rest: &[Vec3]) -> (f32, f32) {
    let g = &r.scene.geometry;
    let world: Vec<GpuVertex> = gpu.read_buffer(&g.world_vertices).expect("world vertices");
    let indices: Vec<u32> = gpu.read_buffer(&g.indices).expect("indices");
    let indices = &indices[..g.index_count as usize];
    let reference = converge::reference_mut(r).expect("reference");
    let tris = reference.posed_triangles().expect("prepared");
    assert_eq!(tris.len(), indices.len() / 3, "one reference triangle per scene triangle");
    let (mut worst, mut moved) = (0.0f32, 0.0f32);
    for (t, ix) in tris.iter().zip(indices.chunks_exact(3)) {
        for k in 0..3 {
            let gpu_p = Vec3::from(world[ix[k] as usize].position);
            worst = worst.max((t[k] - gpu_p).length());
            moved = moved.max((gpu_p - rest[ix[k] as usize]).length());
        }
    }
    (worst, moved)
}

#[test]
fn reference_triangles_are_the_skin_pass_world_vertices() {
    let gpu = engine_tests::gpu();
    let scene = scenes::build("arm", None).expect("arm");
    // The vertices as the old reference placed them: instance transform, no skinning.
    let rest: Vec<Vec3> = scene
        .instances
        .iter()
        .flat_map(|inst| scene.meshes[inst.mesh].positions.iter().map(|p| inst.transform.transform_point3(*p)))
        .collect();
    let mut r = reference_renderer(&gpu, &scene);
    // The scene's initial pose (bent 60°), then straight, half bent, and bent the other way with every instance
    // moved.
    let poses: [Option<Vec<Mat4>>; 4] = [
        None,
        Some(scenes::arm::bones(0.0)),
        Some(scenes::arm::bones(30f32.to_radians())),
        Some(scenes::arm::bones(-45f32.to_radians())),
    ];
    for (i, pose) in poses.iter().enumerate() {
        if let Some(b) = pose {
            r.set_bones(b).expect("bones");
        }
        if i == 3 {
            // An instance transform moves the triangles too (the turntable of `bunny --animate`).
            let lift = Mat4::from_translation(Vec3::new(0.1, 0.4, -0.2)) * Mat4::from_rotation_y(0.3);
            for (k, inst) in scene.instances.iter().enumerate() {
                r.set_instance_transform(k, lift * inst.transform).expect("transform");
            }
        }
        r.render(&gpu).expect("frame");
        let (worst, moved) = compare_with_skin_pass(&gpu, &mut r, &rest);
        eprintln!("pose {i}: reference vs skin pass {worst:.3e}; skinned vs rest vertices {moved:.3}");
        assert!(worst <= 1e-4, "pose {i}: a reference triangle is {worst:.3e} from the skin pass's vertex");
        if i != 1 {
            // Bent poses move the forearm far from the rest pose: the comparison above can fail.
            assert!(moved > 0.3, "pose {i}: the pose moves vertices only {moved}");
        }
    }
    r.destroy(&gpu);
    gpu.shutdown().expect("clean teardown");
}

#[test]
fn host_skinning_twin_matches_its_formula() {
    // skin_matrix: weights summing to 0 give the identity; out-of-range bones count as the identity.
    let bones = [Mat4::from_translation(Vec3::X), Mat4::from_rotation_z(1.0)];
    assert_eq!(skin_matrix([0, 1, 0, 0], [0.0; 4], &bones), Mat4::IDENTITY);
    assert_eq!(skin_matrix([0, 1, 0, 0], [f32::NAN, 0.0, 0.0, 0.0], &bones), Mat4::IDENTITY);
    assert_eq!(skin_matrix([5, 0, 0, 0], [1.0, 0.0, 0.0, 0.0], &bones), Mat4::IDENTITY);
    let m = skin_matrix([0, 1, 0, 0], [0.25, 0.75, 0.0, 0.0], &bones);
    let want = bones[0] * 0.25 + bones[1] * 0.75;
    assert!(m.abs_diff_eq(want, 1e-7), "{m:?} vs {want:?}");
    let p = skinned_position(Mat4::from_scale(Vec3::splat(2.0)), bones[0], Vec3::new(1.0, 2.0, 3.0));
    assert_eq!(p, Vec3::new(4.0, 4.0, 6.0));
}

#[test]
fn reference_image_follows_the_pose() {
    let gpu = engine_tests::gpu();
    let scene = scenes::build("arm", None).expect("arm");
    // The scene as built is bent 60°.
    let straight = scenes::arm::bones(0.0);
    let mean = |r: &mut Renderer| {
        let per_vertex = r.settings.per_vertex;
        converge::reference_mut(r).expect("reference").stats(&gpu, per_vertex).expect("stats")
    };
    // A fresh renderer at the straight pose.
    let mut fresh = reference_renderer(&gpu, &scene);
    fresh.set_bones(&straight).expect("bones");
    fresh.render(&gpu).expect("frame");
    let want = mean(&mut fresh);
    fresh.destroy(&gpu);
    // Another one renders the bent pose first, then the straight one.
    let mut moved = reference_renderer(&gpu, &scene);
    moved.render(&gpu).expect("bent frame");
    let bent_stats = mean(&mut moved);
    moved.set_bones(&straight).expect("bones");
    moved.render(&gpu).expect("straight frame");
    let got = mean(&mut moved);
    moved.destroy(&gpu);
    assert_eq!(got.samples, want.samples, "the new pose restarts accumulation");
    assert_eq!(got.mean, want.mean, "re-posed to straight: the same bits as a fresh straight render");
    assert_eq!(got.nonfinite_samples, 0);
    // The bent and straight images differ (the forearm and its shadow move).
    let both = |i: usize| got.covered[i] && bent_stats.covered[i];
    let differing = (0..got.mean.len())
        .filter(|&i| both(i))
        .filter(|&i| (0..3).any(|c| (got.mean[i][c] - bent_stats.mean[i][c]).abs() > 0.05))
        .count();
    eprintln!("{differing} of {} covered pixels differ by more than 0.05 between the poses", got.mean.len());
    assert!(differing > 20, "only {differing} pixels differ between the bent and the straight arm");
    gpu.shutdown().expect("clean teardown");
}
