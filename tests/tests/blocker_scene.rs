//! Blockers in the renderer: the animate → skin → blocker_spheres → blocker_bvh chain on real scenes.
//!
//! - Skinned arm bent at the elbow: the spheres follow the same bone matrices as the skin pass, every
//!   deformed vertex stays inside some deformed sphere within [`COVER_TOLERANCE`], and the BVH over the
//!   moved spheres is valid.
//! - Bunny (64 fitted spheres) moved rigidly every frame: spheres equal the instance transform applied
//!   to the rest spheres (radius times the scale), the BVH is valid each frame, and steady animated
//!   frames allocate no device memory.

use engine::blockers::traverse;
use engine::renderer::{RenderSettings, Renderer};
use engine::resources::blockers::GpuBvhNode;
use engine::resources::layout::GpuVertex;
use glam::{Mat4, Vec3};

/// Largest distance (scene units) by which a deformed arm vertex may lie outside every deformed sphere.
/// Linear blend skinning pulls elbow vertices inside the bent cylinder (it never pushes them out much),
/// and the kept radii bound the rest; 0.01 is 7 % of the arm radius (0.15) and 0.5 % of its length.
const COVER_TOLERANCE: f32 = 0.01;

fn small() -> RenderSettings {
    RenderSettings { width: 32, height: 24, technique: "none".into(), ..Default::default() }
}

fn read_state(gpu: &engine::gpu::Gpu, r: &Renderer) -> (Vec<GpuVertex>, Vec<[f32; 4]>, Vec<GpuBvhNode>) {
    let n = r.scene.blockers.sphere_count as usize;
    let mut spheres = gpu.read_buffer::<[f32; 4]>(&r.scene.blockers.spheres).unwrap();
    spheres.truncate(n);
    let mut nodes = gpu.read_buffer::<GpuBvhNode>(&r.scene.blockers.bvh_nodes).unwrap();
    nodes.truncate((2 * n).saturating_sub(1));
    (gpu.read_buffer::<GpuVertex>(&r.scene.geometry.world_vertices).unwrap(), spheres, nodes)
}

/// Max over `points` of (distance to the nearest sphere surface, 0 when inside).
fn worst_uncovered(points: &[Vec3], spheres: &[[f32; 4]]) -> f32 {
    points
        .iter()
        .map(|p| {
            spheres
                .iter()
                .map(|s| (p.distance(Vec3::new(s[0], s[1], s[2])) - s[3]).max(0.0))
                .fold(f32::INFINITY, f32::min)
        })
        .fold(0.0, f32::max)
}

#[test]
fn skinned_spheres_follow_a_bent_joint() {
    let gpu = engine_tests::gpu();
    let scene = scenes::arm::scene(0.0);
    let arm_vertices = scene.meshes[0].positions.len();
    let model = scene.instances[0].transform;
    let mut r = Renderer::new(&gpu, &scene, small()).unwrap();
    for angle in [0.0f32, 30.0, 60.0, 90.0] {
        let bones = scenes::arm::bones(angle.to_radians());
        r.set_bones(&bones).unwrap();
        r.render(&gpu).unwrap();
        let (world, spheres, nodes) = read_state(&gpu, &r);
        assert_eq!(spheres.len(), 12);
        // The skin pass bent the mesh: the tip follows bone 1.
        let tip_rest = scene.meshes[0].positions[arm_vertices - 1];
        let tip_want = model.transform_point3(bones[1].transform_point3(tip_rest));
        let tip = Vec3::from_slice(&world[arm_vertices - 1].position[..3]);
        assert!(tip.distance(tip_want) < 1e-4, "{angle}°: tip {tip} want {tip_want}");
        // Spheres at both ends are bound to one bone each and move exactly with it.
        let rest = scenes::arm::spheres(12);
        for (k, bone) in [(0usize, 0usize), (11, 1)] {
            let want = model.transform_point3(bones[bone].transform_point3(rest[k].center.as_vec3()));
            let got = Vec3::new(spheres[k][0], spheres[k][1], spheres[k][2]);
            assert!(got.distance(want) < 1e-4, "{angle}°: sphere {k} at {got}, want {want}");
            assert!((spheres[k][3] - rest[k].radius as f32).abs() < 1e-6, "radius kept");
        }
        let points: Vec<Vec3> = world[..arm_vertices].iter().map(|v| Vec3::from_slice(&v.position[..3])).collect();
        let worst = worst_uncovered(&points, &spheres);
        eprintln!("bend {angle}°: worst uncovered distance {worst:.5}");
        assert!(worst <= COVER_TOLERANCE, "{angle}°: a deformed vertex is {worst} outside every sphere");
        traverse::validate_nodes(&nodes, &spheres, 1e-5).unwrap_or_else(|e| panic!("{angle}°: {e}"));
    }
    assert!(r.set_bones(&[Mat4::IDENTITY]).is_err(), "wrong bone count is an error");
    r.destroy(&gpu);
    gpu.shutdown().expect("clean teardown");
}

#[test]
fn rigid_bunny_spheres_move_and_steady_frames_allocate_nothing() {
    let gpu = engine_tests::gpu();
    let scene = scenes::build("bunny", None).unwrap();
    let rest = scene.blockers.spheres_of(0).unwrap().to_vec();
    assert_eq!(rest.len(), 64, "the bunny's default sphere set");
    let base = scene.instances[0].transform;
    let mut r = Renderer::new(&gpu, &scene, small()).unwrap();
    assert_eq!(r.scene.blockers.sphere_count, 64);
    let pose = |f: u32| {
        Mat4::from_rotation_y(0.3 * f as f32) * Mat4::from_translation(Vec3::new(0.0, 0.1 * f as f32, 0.0)) * base
    };
    r.render(&gpu).unwrap();
    let first = gpu.memory_stats();
    for f in 0..12u32 {
        r.set_instance_transform(0, pose(f)).unwrap();
        r.render(&gpu).unwrap();
        if f % 4 == 0 {
            let (_, spheres, nodes) = read_state(&gpu, &r);
            let scale = base.x_axis.truncate().length();
            for (s, g) in rest.iter().zip(&spheres) {
                let want = pose(f).transform_point3(s.center.as_vec3());
                assert!(Vec3::new(g[0], g[1], g[2]).distance(want) < 1e-5);
                assert!((g[3] - s.radius as f32 * scale).abs() < 1e-6);
            }
            traverse::validate_nodes(&nodes, &spheres, 1e-6).unwrap_or_else(|e| panic!("frame {f}: {e}"));
        }
    }
    // Readbacks allocate staging memory; compare allocations across frames without them.
    let before = gpu.memory_stats();
    for f in 0..20u32 {
        r.set_instance_transform(0, pose(f)).unwrap();
        r.render(&gpu).unwrap();
    }
    let after = gpu.memory_stats();
    assert_eq!(after.allocations_made, before.allocations_made, "animated steady frames allocated device memory");
    assert_eq!(after.allocated_bytes, first.allocated_bytes);
    let timings = r.render(&gpu).unwrap();
    for pass in ["blocker_spheres", "blocker_bvh"] {
        assert!(timings.iter().any(|t| t.name == pass), "{pass} runs every frame: {timings:?}");
    }
    r.destroy(&gpu);
    gpu.shutdown().expect("clean teardown");
}

#[test]
fn scenes_without_blockers_run_no_blocker_pass() {
    let gpu = engine_tests::gpu();
    let mut r = Renderer::new(&gpu, &scenes::build("furnace", None).unwrap(), small()).unwrap();
    assert_eq!(r.scene.blockers.sphere_count, 0);
    let timings = r.render(&gpu).unwrap();
    assert!(timings.iter().all(|t| !t.name.starts_with("blocker")), "{timings:?}");
    r.destroy(&gpu);
    gpu.shutdown().expect("clean teardown");
}
