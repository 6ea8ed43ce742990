//! The `blocker_bvh` pass (GPU LBVH over spheres) against the CPU reference build
//! (engine_blockers::bvh) and the bvh.glsl traversal against its f64 twin (engine_blockers::traverse).
//!
//! For every sphere set: the node array read back passes `traverse::validate_nodes` (2n − 1 nodes,
//! parent links, every node and every leaf reached exactly once, leaves equal to the input, every child
//! inside its parent within an f32 tolerance), its depth is ≤ 63, and traversals of the GPU-built tree on
//! the GPU (shaders-glsl/tests/bvh_traverse.comp) give the same answers as the CPU-built tree: the
//! spheres containing random points and the spheres meeting random cones. The cut by angle is compared
//! with its f64 twin on the same nodes. Queries whose answer is decided within rounding of a boundary
//! (|d − r| below 1e-5 relative, or a cone angle margin below 2e-5 rad) are skipped and counted; most must remain.

use engine::blockers::bvh::{GpuBvhNode, SphereBvh};
use engine::blockers::geom::{angle_between, subtended_half_angle, Cone, Sphere};
use engine::blockers::traverse;
use engine::gpu::{Binding, BufferDesc, ComputePipeline, Gpu};
use engine::math::rng::Pcg32;
use engine::passes::blocker_bvh::{node_buffer_size, BlockerBvhPass};
use glam::DVec3;

/// Per-query record of the traversal kernel (shaders-glsl/tests/bvh_traverse.comp `Query`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Query {
    a: [f32; 4],
    b: [f32; 4],
    c: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct TraversePush {
    query_count: u32,
    sphere_count: u32,
    mode: u32,
    cap: u32,
}

// The kernel's structs against the compiled kernel (engine::gpu::layout_check; see struct_layouts.rs).
#[test]
fn kernel_structs_match_the_shader() {
    use engine::gpu::layout_check::check_all;
    let compiler = engine::gpu::ShaderCompiler::new(engine::gpu::default_shader_root()).expect("shaderc");
    let hosts = [
        engine::layout_check!(Query, "tests/bvh_traverse.comp", struct "Query", [a, b, c]),
        engine::layout_check!(
            TraversePush,
            "tests/bvh_traverse.comp",
            push_constants,
            [query_count, sphere_count, mode, cap]
        ),
    ];
    if let Err(e) = check_all(&compiler, &hosts) {
        panic!("{e}");
    }
}

fn build_on_gpu(gpu: &Gpu, pass: &BlockerBvhPass, spheres: &[[f32; 4]]) -> Vec<GpuBvhNode> {
    let n = spheres.len() as u32;
    let sb = gpu.upload_buffer("test-spheres", BufferDesc::gpu_only(16), spheres).unwrap();
    let nb = gpu.create_buffer("test-nodes", BufferDesc::gpu_only(node_buffer_size(n))).unwrap();
    let mut frame = gpu.create_frame().unwrap();
    gpu.run_frame(&mut frame, None, None, |rec| pass.record(rec, &sb, &nb, n)).unwrap();
    let mut nodes = gpu.read_buffer::<GpuBvhNode>(&nb).unwrap();
    nodes.truncate((2 * n as usize).saturating_sub(1));
    gpu.destroy_frame(frame);
    gpu.destroy_buffer(sb);
    gpu.destroy_buffer(nb);
    nodes
}

/// Runs the traversal kernel; returns per query (entries, overflowed).
fn traverse_on_gpu(
    gpu: &Gpu,
    pipe: &ComputePipeline,
    nodes: &[GpuBvhNode],
    sphere_count: u32,
    queries: &[Query],
    mode: u32,
) -> Vec<(Vec<u32>, bool)> {
    let cap = nodes.len().max(1) as u32;
    let qb = gpu.upload_buffer("test-queries", BufferDesc::gpu_only(16), queries).unwrap();
    let nb = gpu.upload_buffer("test-nodes", BufferDesc::gpu_only(32), nodes).unwrap();
    let hb = gpu.create_buffer("test-hits", BufferDesc::gpu_only(4 * (cap as u64 + 2) * queries.len() as u64)).unwrap();
    let push = TraversePush { query_count: queries.len() as u32, sphere_count, mode, cap };
    let mut frame = gpu.create_frame().unwrap();
    gpu.run_frame(&mut frame, None, None, |rec| {
        rec.begin_pass("traverse");
        rec.dispatch(
            pipe,
            &[Binding::buffer("Queries", &qb), Binding::buffer("BvhNodes", &nb), Binding::buffer("Hits", &hb)],
            bytemuck::bytes_of(&push),
            [queries.len() as u32, 1, 1],
        )
    })
    .unwrap();
    let hits = gpu.read_buffer::<u32>(&hb).unwrap();
    gpu.destroy_frame(frame);
    for b in [qb, nb, hb] {
        gpu.destroy_buffer(b);
    }
    (0..queries.len())
        .map(|q| {
            let base = q * (cap as usize + 2);
            let count = hits[base] as usize;
            assert!(count <= cap as usize, "query {q}: {count} entries, capacity {cap}");
            (hits[base + 2..base + 2 + count].to_vec(), hits[base + 1] != 0)
        })
        .collect()
}

fn f64_spheres(s: &[[f32; 4]]) -> Vec<Sphere> {
    s.iter().map(|a| Sphere::from_array(a.map(f64::from))).collect()
}

fn random_set(rng: &mut Pcg32, n: usize, zero_radius_share: f64) -> Vec<[f32; 4]> {
    (0..n)
        .map(|_| {
            let r = if rng.uniform(0.0, 1.0) < zero_radius_share { 0.0 } else { rng.uniform(0.05, 0.8) };
            [rng.uniform(-5.0, 5.0), rng.uniform(-5.0, 5.0), rng.uniform(-5.0, 5.0), r].map(|x| x as f32)
        })
        .collect()
}

/// Margin (relative) below which a query's answer is decided by rounding.
const AMBIGUOUS: f64 = 1e-5;

fn point_ambiguous(spheres: &[Sphere], p: DVec3) -> bool {
    spheres.iter().any(|s| (p.distance(s.center) - s.radius).abs() < AMBIGUOUS * (1.0 + s.radius))
}

fn cone_ambiguous(spheres: &[Sphere], cone: &Cone) -> bool {
    spheres.iter().any(|s| {
        let v = s.center - cone.apex;
        let d = v.length();
        if (d - s.radius).abs() < AMBIGUOUS * (1.0 + s.radius) {
            return true;
        }
        d > s.radius
            && (angle_between(cone.axis, v) - cone.half_angle - subtended_half_angle(cone.apex, s)).abs() < 2e-5
    })
}

fn cut_ambiguous(nodes: &[GpuBvhNode], receiver: &Sphere, sin_theta: f64, cone: &Cone) -> bool {
    let ns: Vec<Sphere> = nodes.iter().map(traverse::node_sphere).collect();
    cone_ambiguous(&ns, cone)
        || ns.iter().any(|s| {
            let m = sin_theta * (receiver.center.distance(s.center) - receiver.radius) - s.radius;
            m.abs() < AMBIGUOUS * (1.0 + s.radius)
        })
}

fn check_set(
    gpu: &Gpu,
    pass: &BlockerBvhPass,
    pipe: &ComputePipeline,
    name: &str,
    spheres32: &[[f32; 4]],
    rng: &mut Pcg32,
) {
    let n = spheres32.len();
    let nodes = build_on_gpu(gpu, pass, spheres32);
    // The sort: a permutation, ordered by (code, index) like the CPU build's sort.
    let sorted = pass.read_sorted(gpu, n as u32).unwrap();
    let mut perm: Vec<u32> = sorted.iter().map(|p| p.1).collect();
    assert!(sorted.windows(2).all(|w| w[0] < w[1]), "{name}: not sorted by (code, index): {sorted:?}");
    perm.sort_unstable();
    assert_eq!(perm, (0..n as u32).collect::<Vec<_>>(), "{name}: sort values are not a permutation");
    let scale = spheres32.iter().map(|s| s[0].abs().max(s[1].abs()).max(s[2].abs()) + s[3]).fold(1.0f32, f32::max);
    // f32 tolerance: a few ulps of the largest coordinate (the refit also grows parents by 2^-21).
    let tol = 8.0 * f32::EPSILON as f64 * scale as f64;
    let depth = traverse::validate_nodes(&nodes, spheres32, tol)
        .unwrap_or_else(|e| panic!("{name}: {e}\n{spheres32:?}\n{nodes:#?}"));
    assert!(depth <= 63, "{name}: depth {depth}");
    let spheres = f64_spheres(spheres32);
    let cpu = SphereBvh::build(&spheres).unwrap();

    let queries = 96;
    let mut points = Vec::new();
    let mut cones = Vec::new();
    let mut cuts = Vec::new();
    for _ in 0..queries {
        let p = DVec3::new(rng.uniform(-6.0, 6.0), rng.uniform(-6.0, 6.0), rng.uniform(-6.0, 6.0));
        points.push(p);
        let cone = Cone::new(p * 1.5, DVec3::from_array(rng.unit_vector()), rng.uniform(0.0, 1.0));
        cones.push(cone);
        let receiver = Sphere::new(p * 2.0, rng.uniform(0.0, 0.5));
        cuts.push((receiver, rng.uniform(0.05, 0.6f64).sin(), cone));
    }
    let to_query = |a: [f64; 4], b: [f64; 4], c: [f64; 4]| Query {
        a: a.map(|x| x as f32),
        b: b.map(|x| x as f32),
        c: c.map(|x| x as f32),
    };
    let q_points: Vec<Query> = points.iter().map(|p| to_query([p.x, p.y, p.z, 0.0], [0.0; 4], [0.0; 4])).collect();
    let q_cones: Vec<Query> = cones
        .iter()
        .map(|c| to_query([c.apex.x, c.apex.y, c.apex.z, 0.0], [c.axis.x, c.axis.y, c.axis.z, c.half_angle], [0.0; 4]))
        .collect();
    let q_cuts: Vec<Query> = cuts
        .iter()
        .map(|(r, s, c)| {
            to_query([c.apex.x, c.apex.y, c.apex.z, *s], [c.axis.x, c.axis.y, c.axis.z, c.half_angle], r.to_array())
        })
        .collect();
    // The f64 twin must see the f32 inputs the GPU saw.
    let f32_cone = |q: &Query| {
        let v = |a: [f32; 4]| DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64);
        Cone { apex: v(q.a), axis: v(q.b), half_angle: q.b[3] as f64 }
    };
    let gpu_points = traverse_on_gpu(gpu, pipe, &nodes, n as u32, &q_points, 0);
    let gpu_cones = traverse_on_gpu(gpu, pipe, &nodes, n as u32, &q_cones, 1);
    let gpu_cuts = traverse_on_gpu(gpu, pipe, &nodes, n as u32, &q_cuts, 2);
    let mut checked = [0usize; 3];
    for i in 0..queries {
        let p = DVec3::new(q_points[i].a[0] as f64, q_points[i].a[1] as f64, q_points[i].a[2] as f64);
        if !point_ambiguous(&spheres, p) {
            let mut got = gpu_points[i].0.clone();
            got.sort_unstable();
            assert_eq!(got, cpu.spheres_containing(p), "{name}: point {p}");
            assert!(!gpu_points[i].1);
            checked[0] += 1;
        }
        let cone = f32_cone(&q_cones[i]);
        if !cone_ambiguous(&spheres, &cone) {
            let mut got = gpu_cones[i].0.clone();
            got.sort_unstable();
            assert_eq!(got, cpu.cone_query(&cone), "{name}: cone {cone:?}");
            assert!(!gpu_cones[i].1);
            checked[1] += 1;
        }
        let q = &q_cuts[i];
        let cone = f32_cone(q);
        let receiver = Sphere::from_array(q.c.map(f64::from));
        let sin_theta = q.a[3] as f64;
        if !cut_ambiguous(&nodes, &receiver, sin_theta, &cone) {
            let twin = traverse::cut(&nodes, n as u32, &receiver, sin_theta, &cone, traverse::STACK_SIZE);
            assert_eq!(gpu_cuts[i].0, twin.nodes, "{name}: cut {i}");
            assert_eq!(gpu_cuts[i].1, twin.overflowed);
            checked[2] += 1;
        }
    }
    eprintln!("{name}: n = {n}, depth {depth}, checked point/cone/cut queries {checked:?} of {queries}");
    for c in checked {
        assert!(c >= queries * 3 / 4, "{name}: too many ambiguous queries ({checked:?} of {queries} checked)");
    }
}

#[test]
fn gpu_build_matches_cpu_reference() {
    let gpu = engine_tests::gpu();
    let pass = BlockerBvhPass::new(&gpu, 3000).unwrap();
    let pipe = gpu.create_compute_pipeline("tests/bvh_traverse.comp", &[]).unwrap();
    let mut rng = Pcg32::new(2024, 11);
    for n in [1usize, 2, 3, 64, 1000, 3000] {
        let set = random_set(&mut rng, n, 0.0);
        check_set(&gpu, &pass, &pipe, &format!("random {n}"), &set, &mut rng);
    }
    // Coincident centres: equal Morton codes everywhere (ties broken by index), with different radii.
    let coincident: Vec<[f32; 4]> = (0..40).map(|i| [1.25, -0.5, 2.0, 0.1 + 0.02 * i as f32]).collect();
    check_set(&gpu, &pass, &pipe, "coincident", &coincident, &mut rng);
    // Duplicates of a random set, and a third of the radii zero.
    let mut dup = random_set(&mut rng, 150, 0.33);
    dup.extend(dup.clone());
    check_set(&gpu, &pass, &pipe, "duplicates + zero radii", &dup, &mut rng);
    // All radii zero, all in one plane (zero extent on one axis).
    let flat: Vec<[f32; 4]> = random_set(&mut rng, 100, 1.0).into_iter().map(|s| [s[0], 0.5, s[2], 0.0]).collect();
    check_set(&gpu, &pass, &pipe, "flat, zero radii", &flat, &mut rng);
    gpu.destroy_compute_pipeline(pipe);
    pass.destroy(&gpu);
    gpu.shutdown().expect("clean teardown");
}

#[test]
fn bad_spheres_are_sanitized_and_capacity_is_checked() {
    let gpu = engine_tests::gpu();
    let pass = BlockerBvhPass::new(&gpu, 16).unwrap();
    let mut spheres =
        vec![[0.0f32, 0.0, 0.0, 1.0], [2.0, 0.0, 0.0, 0.5], [f32::NAN, 0.0, 0.0, 1.0], [1.0, 1.0, 1.0, -2.0]];
    spheres.push([0.0, 3.0, 0.0, f32::INFINITY]);
    let nodes = build_on_gpu(&gpu, &pass, &spheres);
    // The bad spheres become zero-radius leaves at the lower corner of the bounds of the finite centres.
    let mut sanitized = spheres.clone();
    for s in &mut sanitized[2..] {
        *s = [0.0, 0.0, 0.0, 0.0];
    }
    traverse::validate_nodes(&nodes, &sanitized, 1e-5).unwrap();
    assert!(nodes.iter().all(|n| n.radius.is_finite() && n.center.iter().all(|c| c.is_finite())));
    // Too many spheres for the scratch: an error, not a GPU fault.
    let sb = gpu.create_buffer("s", BufferDesc::gpu_only(16 * 32)).unwrap();
    let nb = gpu.create_buffer("n", BufferDesc::gpu_only(node_buffer_size(32))).unwrap();
    let mut frame = gpu.create_frame().unwrap();
    assert!(gpu.run_frame(&mut frame, None, None, |rec| pass.record(rec, &sb, &nb, 32)).is_err());
    // No spheres: nothing dispatched, no error.
    gpu.run_frame(&mut frame, None, None, |rec| pass.record(rec, &sb, &nb, 0)).unwrap();
    gpu.destroy_frame(frame);
    gpu.destroy_buffer(sb);
    gpu.destroy_buffer(nb);
    pass.destroy(&gpu);
    gpu.shutdown().expect("clean teardown");
}
