//! Technique `shexp` on lavapipe: the GPU pass against its f64 twin (engine::passes::shade::shexp::cpu)
//! per receiver, for each exp method at order 4 and for orders 3 and 6, on hard blocker sets:
//! dozens of overlapping spheres (‖f̂‖ ≥ 20), receivers inside one and several spheres, tiny spheres
//! (θ ≈ 1e-4 and 1e-3); no NaN or inf anywhere.

use engine::blockers::geom::blocker_for_receiver;
use engine::blockers::Sphere;
use engine::math::sh::{circle_log_zonal, zh_rotate, ShTensor};
use engine::passes::shade::shexp::cpu::Twin;
use engine::passes::shade::shexp::{ExpChoice, ShexpOptions};
use engine::renderer::RenderSettings;
use engine::scene::Scene;
use engine_tests::{assert_finite, render_with_gbuffer, rgb};
use glam::{DVec3, Vec3};

const W: u32 = 40;
const H: u32 = 30;

/// sphere_over_plane under the sphere scene's sky, with `local` blocker spheres in the ball's object
/// space (the ball: centre `C`, radius `R`); returns the scene and the world-space spheres.
fn scene_with(local: Vec<Sphere>) -> (Scene, Vec<Sphere>) {
    const C: Vec3 = Vec3::new(0.1, 0.6, -0.1);
    const R: f32 = 0.45;
    let mut scene = engine_tests::fixtures::sphere_over_plane(scenes::sphere::sky(), 0.7, C, R);
    let world = local.iter().map(|s| Sphere::new(C.as_dvec3() + s.center * R as f64, s.radius * R as f64)).collect();
    scene.blockers.spheres[1] = Some(local);
    (scene, world)
}

/// GPU vs twin relative errors (per channel, relative to max(|twin|, 1e-3 · the scene's scale)) over
/// every `step`-th receiver; also the largest ‖f̂‖ the twin saw.
fn compare(gpu: &engine::gpu::Gpu, scene: &Scene, world: &[Sphere], spec: &str, o: &ShexpOptions) -> (Vec<f64>, f64) {
    let planes = scene.blockers.planes.clone();
    let settings = RenderSettings { width: W, height: H, technique: spec.into(), ..Default::default() };
    let (hdr, g) = render_with_gbuffer(gpu, scene, settings);
    assert_finite(&hdr, spec);
    assert!(hdr.iter().all(|v| *v >= 0.0), "{spec}: negative radiance");
    let twin = Twin::new(o, &scene.environment).expect("twin tables");
    let albedo = [0.7, 0.8];
    let mut errs = Vec::new();
    let mut max_norm: f64 = 0.0;
    for (i, px) in g.iter().enumerate().step_by(3) {
        let Some((p, n, m)) = *px else { continue };
        let (f, _) = twin.log_visibility(p, n, world);
        max_norm = max_norm.max(f[1..].iter().map(|v| v * v).sum::<f64>().sqrt());
        let (want, free) = twin.shade_diffuse(p, n, [albedo[m]; 3], world, &planes);
        let got = rgb(&hdr, i);
        for c in 0..3 {
            let scale = (albedo[m] * free[c]).abs().max(1e-6);
            errs.push((got[c] - want[c]).abs() / scale);
        }
    }
    errs.sort_by(f64::total_cmp);
    (errs, max_norm)
}

fn check(errs: &[f64], spec: &str, what: &str, p95_bound: f64, max_bound: f64) {
    assert!(errs.len() > 300, "{spec} {what}: too few receivers ({})", errs.len());
    let (p95, max) = (errs[errs.len() * 95 / 100], errs[errs.len() - 1]);
    eprintln!("{spec} ({what}): {} samples, error / unshadowed: 95th percentile {p95:.2e}, max {max:.2e}", errs.len());
    assert!(p95 < p95_bound && max < max_bound, "{spec} ({what}): p95 {p95}, max {max}");
}

// One sphere (the ball itself: its own receivers lie on it), every exp method, order 4, and the
// orders 3 and 6: the GPU equals the twin to f32 rounding of the tables, the Γ loop and the exp.
#[test]
fn gpu_matches_the_f64_twin() {
    let gpu = engine_tests::gpu();
    let (scene, world) = scene_with(vec![Sphere::new(DVec3::ZERO, 1.0)]);
    for (spec, exp, order) in [
        ("shexp:theta_max=0,cluster=0", ExpChoice::Hyb, 4),
        ("shexp:theta_max=0,exp=ol,cluster=0", ExpChoice::Ol, 4),
        ("shexp:theta_max=0,exp=ps,p=2,cluster=0", ExpChoice::PsStar, 4),
        ("shexp:theta_max=0,order=3,cluster=0", ExpChoice::Hyb, 3),
        ("shexp:theta_max=0,order=6,cluster=0", ExpChoice::Hyb, 6),
    ] {
        let o = ShexpOptions { order, exp, theta_max_deg: 0.0, ..ShexpOptions::default() };
        let (errs, _) = compare(&gpu, &scene, &world, spec, &o);
        // Measured: p95 ≤ 1.3e-6, max ≤ 2.3e-6 of the unshadowed value.
        check(&errs, spec, "one sphere", 1e-5, 1e-4);
    }
    // The ground as a half-space plane blocker too (its visibility multiplies the ball's receivers').
    let mut with_plane = scene.clone();
    with_plane.blockers.planes = vec![engine::blockers::BlockerPlane::half_space(DVec3::ZERO, DVec3::Y)];
    // accumulate=product (the product baseline): the ball's circle times the half-space's, in the same order
    // on both sides (truncated products are not associative: one sphere and one plane keep it exact).
    for (spec, order, large_product, accumulate_product) in [
        ("shexp:theta_max=0,cluster=0", 4, true, false),
        ("shexp:theta_max=0,order=6,cluster=0", 6, true, false),
        ("shexp:theta_max=0,large=log,cluster=0", 4, false, false),
        ("shexp:theta_max=0,accumulate=product,cluster=0", 4, true, true),
    ] {
        let o =
            ShexpOptions { order, theta_max_deg: 0.0, large_product, accumulate_product, ..ShexpOptions::default() };
        let (errs, _) = compare(&gpu, &with_plane, &world, spec, &o);
        check(&errs, spec, "one sphere and a half-space", 1e-5, 1e-4);
    }
    gpu.shutdown().expect("clean teardown");
}

// Hard cases against the twin: 40 overlapping spheres around and through the ball (receivers inside
// several at once, ‖f̂‖ ≥ 20 at the plane under them), and tiny spheres (θ ≈ 1e-4 .. 1e-3 from the
// plane) that must darken by their solid angle and not more.
#[test]
fn hard_blocker_sets_match_the_twin() {
    let gpu = engine_tests::gpu();
    let overlapping: Vec<Sphere> = (0..40)
        .map(|i| {
            let t = i as f64 * 0.61;
            Sphere::new(DVec3::new(0.5 * t.cos(), -1.2 + 0.06 * i as f64, 0.5 * t.sin()), 0.6)
        })
        .collect();
    let tiny: Vec<Sphere> = (0..30)
        .map(|i| {
            let t = i as f64 * 0.9;
            Sphere::new(DVec3::new(1.2 * t.cos(), -0.8, 1.2 * t.sin()), if i % 2 == 0 { 1e-4 } else { 1e-3 })
        })
        .collect();
    // The tiny spheres' summed log against the exact eigen log of each circle (the table's small-angle
    // limit; the old θ-linear table was ×6.2 too large at θ = 1e-3, ×61.6 at 1e-4).
    {
        let (scene, world) = scene_with(tiny.clone());
        let o = ShexpOptions::default();
        let twin = Twin::new(&o, &scene.environment).expect("twin tables");
        let tensor = ShTensor::new(4);
        let mut checked = 0;
        for x in [-0.6, -0.2, 0.0, 0.3, 0.7] {
            let (p, n) = (DVec3::new(x, 0.0, 0.1), DVec3::Y);
            let (f, _) = twin.log_visibility(p, n, &world);
            let mut want = [0.0; 16];
            for s in &world {
                let Some(b) = blocker_for_receiver(p, n, s) else { continue };
                let theta = (b.radius / b.center.distance(p)).asin();
                let z = zh_rotate(&circle_log_zonal(&tensor, theta), (b.center - p).to_array());
                want.iter_mut().zip(&z).for_each(|(a, v)| *a += v);
            }
            assert!(want[0] < 0.0);
            let rel = (f[0] - want[0]).abs() / want[0].abs();
            eprintln!("tiny spheres at x = {x}: DC log {:.4e}, exact {:.4e} (relative {rel:.1e})", f[0], want[0]);
            assert!(rel < 1e-3, "tiny spheres: DC log {} vs exact {}", f[0], want[0]);
            checked += 1;
        }
        assert_eq!(checked, 5);
    }
    for (local, what, min_norm) in [(overlapping, "40 overlapping spheres", 20.0), (tiny, "30 tiny spheres", 0.0)] {
        let (scene, world) = scene_with(local);
        // large=log: every sphere in the log (with large=product the GPU's BVH order and the twin's
        // list order would pick different spheres once more than four are large).
        // The first two cut per receiver; the third takes the same leaves from 16×16-pixel clusters' cuts
        // (θ_max = 0: every node is opened, W = 1); the fourth applies the §6.2 rule without the α scale
        // (many of these spheres straddle the receivers' tangent planes).
        for (spec, exp, alpha_scale) in [
            ("shexp:theta_max=0,large=log,cluster=0", ExpChoice::Hyb, true),
            ("shexp:theta_max=0,large=log,exp=ps,cluster=0", ExpChoice::PsStar, true),
            ("shexp:theta_max=0,large=log,cluster=16", ExpChoice::Hyb, true),
            ("shexp:theta_max=0,large=log,cluster=0,alpha_scale=off", ExpChoice::Hyb, false),
        ] {
            let o =
                ShexpOptions { exp, theta_max_deg: 0.0, large_product: false, alpha_scale, ..ShexpOptions::default() };
            let (errs, max_norm) = compare(&gpu, &scene, &world, spec, &o);
            eprintln!("{what}: largest ‖f̂‖ at a receiver {max_norm:.1}");
            assert!(max_norm >= min_norm, "{what}: ‖f̂‖ only reached {max_norm}");
            // Measured: p95 ≤ 6.7e-6, max ≤ 1.2e-5 (40 spheres, ‖f̂‖ 28.5, 7 squarings); ≤ 3.3e-7 (tiny).
            check(&errs, spec, what, 5e-5, 2e-4);
        }
    }
    gpu.shutdown().expect("clean teardown");
}

/// 27 small spheres filling the ball (3 × 3 × 3), so that the BVH has nodes to take whole seen from the ground.
fn cube_of_spheres() -> Vec<Sphere> {
    (0..27)
        .map(|i| {
            let (x, y, z) = ((i % 3) as f64 - 1.0, ((i / 3) % 3) as f64 - 1.0, (i / 9) as f64 - 1.0);
            Sphere::new(DVec3::new(x, y, z) * 0.55, 0.38)
        })
        .collect()
}

// Receiver clusters (SHEXP §6.3): 4×4-pixel tiles, one θ_max cut per tile from its bounding sphere, ratio
// vectors W at its central point. The GPU against the twin's cluster pass (same node array, read back) and
// per-pixel accumulation; then W's effect: the clustered image with W is closer to the leaves-only one
// (θ_max = 0, no node taken whole) than without W (nodes block as their bounding spheres).
#[test]
fn receiver_clusters_match_the_twin_and_ratio_vectors_help() {
    let gpu = engine_tests::gpu();
    let (scene, _) = scene_with(cube_of_spheres());
    const T: usize = 4;
    let spec = format!("shexp:cluster={T}");
    let o = ShexpOptions { cluster: T as u32, ..ShexpOptions::default() };
    let settings = RenderSettings { width: W, height: H, technique: spec.clone(), ..Default::default() };
    let (hdr, g, bvh) = engine_tests::render_with_bvh(&gpu, &scene, settings);
    assert_finite(&hdr, &spec);
    let twin = Twin::new(&o, &scene.environment).expect("twin tables");
    let planes = scene.blockers.planes.clone();
    let albedo = [0.7, 0.8];
    let (w, h) = (W as usize, H as usize);
    let mut errs = Vec::new();
    let (mut whole, mut entries, mut scaled) = (0, 0, 0);
    for ty in 0..h.div_ceil(T) {
        for tx in 0..w.div_ceil(T) {
            let pixels: Vec<usize> = (0..T * T)
                .map(|k| (tx * T + k % T, ty * T + k / T))
                .filter(|&(x, y)| x < w && y < h)
                .map(|(x, y)| y * w + x)
                .filter(|&i| g[i].is_some())
                .collect();
            let items: Vec<DVec3> = pixels.iter().map(|&i| g[i].unwrap().0).collect();
            let cut = twin.cluster_cut(&bvh.nodes, bvh.spheres.len() as u32, &items).expect("no overflow here");
            entries += cut.entries.len();
            whole += cut.entries.iter().filter(|(_, w)| w[0] != 1.0).count();
            scaled += cut.entries.iter().filter(|(_, w)| (w[0] - 1.0).abs() > 0.05).count();
            for &i in &pixels {
                let (p, n, m) = g[i].unwrap();
                let (v, count) = twin.visibility_clustered(p, n, &cut, &planes);
                let (want, free) = twin.shade_diffuse_with(&v, count, n, [albedo[m]; 3]);
                let got = rgb(&hdr, i);
                for c in 0..3 {
                    errs.push((got[c] - want[c]).abs() / (albedo[m] * free[c]).abs().max(1e-6));
                }
            }
        }
    }
    eprintln!("clusters: {entries} cut entries, {whole} nodes with W ≠ 1 ({scaled} by more than 5 %)");
    assert!(scaled >= 10, "the test must exercise ratio vectors: only {scaled} nodes scaled");
    errs.sort_by(f64::total_cmp);
    // Measured: p95 1.9e-6, max 4.4e-6 of the unshadowed value.
    check(&errs, &spec, "4×4 clusters", 1e-5, 1e-4);

    // W's effect, against the leaves-only image.
    let image = |spec: &str| {
        let settings = RenderSettings { width: W, height: H, technique: spec.into(), ..Default::default() };
        engine_tests::render_with_gbuffer(&gpu, &scene, settings).0
    };
    let leaves = image("shexp:theta_max=0");
    let rmse = |a: &[f32]| {
        let (num, den) = a
            .iter()
            .zip(&leaves)
            .enumerate()
            .filter(|(i, _)| i % 4 != 3)
            .fold((0.0, 0.0), |(n, d), (_, (x, y))| (n + (*x as f64 - *y as f64).powi(2), d + (*y as f64).powi(2)));
        (num / den).sqrt()
    };
    let (with_w, without_w, per_receiver) =
        (rmse(&hdr), rmse(&image("shexp:cluster=4,ratio_vectors=off")), rmse(&image("shexp")));
    eprintln!(
        "relative RMSE against leaves only: clusters with W {:.3} %, without W {:.3} %, a cut per receiver {:.3} %",
        100.0 * with_w,
        100.0 * without_w,
        100.0 * per_receiver
    );
    assert!(with_w < 0.6 * without_w, "ratio vectors should bring the cut close to its leaves");
    gpu.shutdown().expect("clean teardown");
}

/// What the vertex-cluster twin tests read back after a frame of `r`: the world vertices, the GPU's BVH nodes
/// and its sphere count, and the technique's vertex clusters of at most `max_size` with their pixel reach.
struct ClusterFrame {
    world: Vec<engine::resources::layout::GpuVertex>,
    nodes: Vec<engine::blockers::bvh::GpuBvhNode>,
    spheres: u32,
    clusters: engine::passes::shade::shexp::vertex_clusters::VertexClusters,
    reach: Vec<f32>,
}

fn read_cluster_frame(
    gpu: &engine::gpu::Gpu,
    r: &engine::renderer::Renderer,
    max_size: usize,
    lloyd: bool,
) -> ClusterFrame {
    let g = &r.scene.geometry;
    let mut world: Vec<engine::resources::layout::GpuVertex> = gpu.read_buffer(&g.world_vertices).expect("vertices");
    world.truncate(g.vertex_count as usize);
    let n = r.scene.blockers.sphere_count;
    let mut nodes = gpu.read_buffer::<engine::blockers::bvh::GpuBvhNode>(&r.scene.blockers.bvh_nodes).expect("nodes");
    nodes.truncate((2 * n as usize).saturating_sub(1));
    let (clusters, reach) = engine::passes::shade::shexp::scene_clusters(gpu, g, max_size, lloyd).expect("clusters");
    ClusterFrame { world, nodes, spheres: n, clusters, reach }
}

// Receiver clusters per vertex: spatial groups of at most T² vertices of one instance (vertex_clusters.rs, from
// the vertex buffer under the instances' transforms), one cut per group. The GPU's per-vertex radiance
// against the twin's cluster pass over the same groups (the technique's partition function on the same
// buffers), at every 3rd vertex.
#[test]
fn per_vertex_clusters_match_the_twin() {
    use engine::renderer::Renderer;
    use engine::resources::layout::GpuVertex;
    let gpu = engine_tests::gpu();
    let (scene, _) = scene_with(cube_of_spheres());
    const T: u32 = 4;
    let spec = format!("shexp:cluster={T}");
    let settings =
        RenderSettings { width: W, height: H, technique: spec.clone(), per_vertex: true, ..Default::default() };
    let mut r = Renderer::new(&gpu, &scene, settings).expect("renderer");
    r.render(&gpu).expect("frame");
    let radiance: Vec<[f32; 4]> = gpu.read_buffer(&r.scene.geometry.vertex_radiance).expect("radiance");
    let ClusterFrame { world, nodes, spheres: n, clusters, .. } = read_cluster_frame(&gpu, &r, (T * T) as usize, false);
    r.destroy(&gpu);
    assert!(clusters.count() > 10, "{} clusters", clusters.count());
    let o = ShexpOptions { cluster: T, ..ShexpOptions::default() };
    let twin = Twin::new(&o, &scene.environment).expect("twin tables");
    let eye = scene.camera.eye.as_dvec3();
    let p_of = |v: &GpuVertex| Vec3::from_array(v.position).as_dvec3();
    let mut errs = Vec::new();
    let mut whole = 0;
    for c in 0..clusters.count() {
        let members = &clusters.items[clusters.offsets[c] as usize..clusters.offsets[c + 1] as usize];
        let items: Vec<DVec3> = members.iter().map(|&v| p_of(&world[v as usize])).collect();
        let cut = twin.cluster_cut(&nodes, n, &items).expect("no overflow here");
        whole += cut.entries.iter().filter(|(_, w)| w[0] != 1.0).count();
        for &v in members.iter().step_by(3) {
            let x = &world[v as usize];
            let p = p_of(x);
            let view = (eye - p).normalize();
            let nv = Vec3::from_array(x.normal).as_dvec3().to_array();
            let (ns, _) = engine::math::shading::shading_normals(nv, nv, view.to_array());
            let nn = DVec3::from_array(ns);
            let albedo = [0.7, 0.8][x.material as usize];
            let (vis, k) = twin.visibility_clustered(p, nn, &cut, &scene.blockers.planes);
            let (want, free) = twin.shade_diffuse_with(&vis, k, nn, [albedo; 3]);
            let got = radiance[v as usize];
            for ch in 0..3 {
                errs.push((got[ch] as f64 - want[ch]).abs() / (albedo * free[ch]).abs().max(1e-6));
            }
        }
    }
    assert!(whole >= 10, "the test must exercise nodes taken whole: {whole}");
    errs.sort_by(f64::total_cmp);
    // Measured: p95 5.2e-7, max 1.6e-5 of the unshadowed value.
    check(&errs, &spec, "per-vertex clusters", 1e-5, 1e-4);
    gpu.shutdown().expect("clean teardown");
}

// World-space receiver clusters per pixel (pixel_clusters=world): a pixel joins the vertex cluster of its
// triangle's first vertex (the G-buffer's geometric w), whose bounding sphere grows by the cluster's reach.
// The GPU's pixels against the twin's cluster pass over the same vertex clusters, grown by the same reach.
#[test]
fn world_pixel_clusters_match_the_twin() {
    use engine::renderer::Renderer;
    let gpu = engine_tests::gpu();
    let (scene, _) = scene_with(cube_of_spheres());
    const T: u32 = 4;
    let spec = format!("shexp:cluster={T},pixel_clusters=world,vertex_clusters=lloyd");
    let settings = RenderSettings { width: W, height: H, technique: spec.clone(), ..Default::default() };
    let mut r = Renderer::new(&gpu, &scene, settings).expect("renderer");
    r.render(&gpu).expect("frame");
    let hdr = r.read_radiance(&gpu).expect("radiance");
    assert_finite(&hdr, &spec);
    let image = |i| gpu.read_image_rgba32f(i).expect("g-buffer");
    let (pos, nrm, geo) = (image(&r.gbuffer.position), image(&r.gbuffer.normal), image(&r.gbuffer.geometric));
    let ClusterFrame { world, nodes, spheres: n, clusters, reach } =
        read_cluster_frame(&gpu, &r, (T * T) as usize, true);
    r.destroy(&gpu);
    let o = ShexpOptions { cluster: T, world_pixel_clusters: true, lloyd: true, ..ShexpOptions::default() };
    let twin = Twin::new(&o, &scene.environment).expect("twin tables");
    let cuts: Vec<_> = (0..clusters.count())
        .map(|c| {
            let members = &clusters.items[clusters.offsets[c] as usize..clusters.offsets[c + 1] as usize];
            let items: Vec<DVec3> =
                members.iter().map(|&v| Vec3::from_array(world[v as usize].position).as_dvec3()).collect();
            twin.cluster_cut_grown(&nodes, n, &items, reach[c] as f64).expect("no overflow here")
        })
        .collect();
    let albedo = [0.7, 0.8];
    let (mut errs, mut outside, mut covered) = (Vec::new(), 0, 0);
    for i in 0..(W * H) as usize {
        let px = &pos[4 * i..4 * i + 4];
        if px[3] < 0.5 {
            continue;
        }
        covered += 1;
        let p = DVec3::new(px[0] as f64, px[1] as f64, px[2] as f64);
        let nn = DVec3::new(nrm[4 * i] as f64, nrm[4 * i + 1] as f64, nrm[4 * i + 2] as f64).normalize();
        let m = (px[3] - 0.5) as usize;
        let vertex = geo[4 * i + 3];
        assert!(
            vertex >= 0.0 && vertex.fract() == 0.0 && (vertex as usize) < world.len(),
            "pixel {i}: vertex {vertex}"
        );
        let c = clusters.cluster_of[vertex as usize] as usize;
        let cut = &cuts[c];
        let d = p.distance(cut.receiver.center);
        assert!(d <= cut.receiver.radius * (1.0 + 1e-5) + 1e-5, "pixel {i} lies outside its grown cluster sphere");
        if d > cut.receiver.radius - reach[c] as f64 {
            outside += 1;
        }
        let (v, count) = twin.visibility_clustered(p, nn, cut, &scene.blockers.planes);
        let (want, free) = twin.shade_diffuse_with(&v, count, nn, [albedo[m]; 3]);
        let got = rgb(&hdr, i);
        for ch in 0..3 {
            errs.push((got[ch] - want[ch]).abs() / (albedo[m] * free[ch]).abs().max(1e-6));
        }
    }
    eprintln!(
        "{covered} pixels in {} world clusters, {outside} of them outside their cluster's vertices' sphere",
        cuts.len()
    );
    assert!(outside > 0, "the test must exercise the reach");
    errs.sort_by(f64::total_cmp);
    check(&errs, &spec, "world pixel clusters", 1e-5, 1e-4);
    gpu.shutdown().expect("clean teardown");
}

// theta_min (tiny blockers dropped, SHEXP §7): the shader's cut drops whole nodes subtending less than
// θ_min, the twin drops leaf spheres; with θ_min between the two sizes of the tiny set, the twin's log
// equals the log of the larger spheres alone, and the GPU equals the twin.
#[test]
fn theta_min_drops_tiny_blockers_on_both_sides() {
    let tiny: Vec<Sphere> = (0..30)
        .map(|i| {
            let t = i as f64 * 0.9;
            Sphere::new(DVec3::new(1.2 * t.cos(), -0.8, 1.2 * t.sin()), if i % 2 == 0 { 1e-4 } else { 1e-3 })
        })
        .collect();
    let (scene, world) = scene_with(tiny);
    let o = ShexpOptions { theta_max_deg: 0.0, theta_min_deg: 0.015, large_product: false, ..ShexpOptions::default() };
    let twin = Twin::new(&o, &scene.environment).expect("twin tables");
    let all = Twin::new(&ShexpOptions { theta_min_deg: 0.0, ..o.clone() }, &scene.environment).expect("twin tables");
    let larger: Vec<Sphere> = world.iter().filter(|s| s.radius > 1e-4).cloned().collect();
    for x in [-0.6, -0.2, 0.0, 0.3, 0.7] {
        let (p, n) = (DVec3::new(x, 0.0, 0.1), DVec3::Y);
        let (f, count) = twin.log_visibility(p, n, &world);
        let (want, want_count) = all.log_visibility(p, n, &larger);
        let (f_all, count_all) = all.log_visibility(p, n, &world);
        assert_eq!((count, count_all), (want_count, 30), "x = {x}: blockers kept");
        assert!(f.iter().zip(&want).all(|(a, b)| (a - b).abs() <= 1e-12 * b.abs().max(1.0)), "x = {x}");
        assert!(f_all[0] < f[0], "x = {x}: the dropped spheres carried log visibility");
    }
    let gpu = engine_tests::gpu();
    let spec = "shexp:theta_max=0,large=log,theta_min=0.015";
    let (errs, _) = compare(&gpu, &scene, &world, spec, &o);
    check(&errs, spec, "theta_min=0.015 over 30 tiny spheres", 5e-5, 2e-4);
    gpu.shutdown().expect("clean teardown");
}

// A sphere crossing the receiver's tangent plane as it moves (the §6.2 shrink rule, f64 twin, no
// GPU): the shading changes by at most a small bound between neighbouring steps. A sphere that
// passes through the receiver switches rules where the receiver enters and leaves it (S' outside,
// shrunk about its centre or eliminated inside): that jump is measured and bounded separately, and
// with the paper's α scale (alpha_scale=on) it must be gone.
#[test]
fn sphere_crossing_the_tangent_plane_is_continuous() {
    let env = engine::math::envmap::LatLongMap::constant(32, 16, [1.0; 3]);
    let base = ShexpOptions { large_product: false, alpha_scale: false, ..ShexpOptions::default() };
    let twin = Twin::new(&base, &env).expect("twin tables");
    let scaled = Twin::new(&ShexpOptions { alpha_scale: true, ..base }, &env).expect("twin tables");
    let (p, n) = (DVec3::ZERO, DVec3::Y);
    let path_with = |twin: &Twin, r: f64| -> Vec<f64> {
        (0..=160)
            .map(|k| {
                let y = -0.8 + 1.6 * k as f64 / 160.0;
                let s = Sphere::new(DVec3::new(0.0, y, 0.5), r);
                let (v, free) = twin.shade_diffuse(p, n, [1.0; 3], &[s], &[]);
                assert!(v[1].is_finite());
                v[1] / free[1]
            })
            .collect()
    };
    let max_jump = |v: &[f64]| v.windows(2).map(|w| (w[1] - w[0]).abs()).fold(0.0, f64::max);
    let outside = path_with(&twin, 0.3);
    let inside = path_with(&twin, 0.6);
    let (jo, ji) = (max_jump(&outside), max_jump(&inside));
    let (jo_a, ji_a) = (max_jump(&path_with(&scaled, 0.3)), max_jump(&path_with(&scaled, 0.6)));
    let darkest = outside.iter().cloned().fold(1.0, f64::min);
    eprintln!("tangent-plane crossing: largest step {jo:.2e} (r = 0.3, darkest {darkest:.3}); through the receiver (r = 0.6) {ji:.2e}");
    eprintln!("with the α scale: {jo_a:.2e} (r = 0.3), {ji_a:.2e} (r = 0.6)");
    // Measured: 4.9e-3 per step (Δy = 0.01) at r = 0.3; 0.155 where the receiver enters the r = 0.6 sphere.
    assert!(darkest < 0.95, "the sphere shadows the receiver on its path");
    assert!(jo < 1e-2, "jump {jo}");
    assert!(ji < 0.2, "jump {ji} where the receiver enters the sphere");
    assert!(jo_a < 1e-2 && ji_a < 2e-2, "with the α scale: {jo_a}, {ji_a}");
}

// A measurement helper, not a check (ignored): writes the environment `SHEXP_ENV` (default the
// courtyard) band-limited to order `SHEXP_ORDER` (default 4) with the default window cos(π/2 · l/2n),
// reconstructed at 256 × 128 and clamped at 0, to `SHEXP_BANDLIMITED_OUT`, so that `compare --env`
// renders the reference under the same lighting as `shexp:h=64` (window ≈ 1 on the already windowed
// map): only the visibility error remains (issue 18, "whole pipeline vs the reference under the same
// order-n windowed lighting").
#[test]
#[ignore]
fn write_band_limited_environment() {
    use engine::math::sh::{eval, project_latlong, Window};
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let src =
        std::env::var("SHEXP_ENV").map(std::path::PathBuf::from).unwrap_or(root.join("assets/envmaps/courtyard.exr"));
    let n: usize = std::env::var("SHEXP_ORDER").ok().and_then(|s| s.parse().ok()).unwrap_or(4);
    let out = std::env::var("SHEXP_BANDLIMITED_OUT").expect("set SHEXP_BANDLIMITED_OUT");
    let env = engine::scene::load_environment(&src).expect("environment");
    let sh = project_latlong(&env, n, Window::cosine_default(n));
    let (w, h) = (256u32, 128u32);
    let map = engine::math::envmap::LatLongMap::constant(w as usize, h as usize, [0.0; 3]);
    let mut rgba = Vec::with_capacity((w * h * 4) as usize);
    for row in 0..h as usize {
        for col in 0..w as usize {
            let y = eval(n, map.texel_direction(col, row));
            for c in sh.iter() {
                rgba.push(c.iter().zip(&y).map(|(a, b)| a * b).sum::<f64>().max(0.0) as f32);
            }
            rgba.push(1.0);
        }
    }
    engine::output::write_exr(std::path::Path::new(&out), w, h, &rgba).expect("write");
    eprintln!("wrote {out}: {} band-limited to order {n}", src.display());
}

// bake=on (§7: static receivers keep their visibility), per vertex on `chess` (pieces slide one at a time):
// a vertex whose cluster's cut (spheres and W) equals the last frame's and which has not moved reuses its
// visibility vector. (1) A second frame of an unchanged scene marks every cluster unchanged and gives the same
// image; (2) after a piece moves, and (3) two frames after the environment turns, the image equals that of
// `bake=off` at the same pose bit for bit; (3)'s second frame reuses every cluster. (In (2) none is reused: every cluster's cut on the
// board holds the moving piece, whole or in a node taken whole, so its spheres or W change.)
#[test]
fn bake_reuses_unchanged_clusters_and_changes_nothing() {
    use engine::renderer::Renderer;
    let gpu = engine_tests::gpu();
    let loaded = scenes::load("chess", None, &Default::default()).expect("chess");
    let animation = loaded.animation.clone().expect("chess moves");
    let make = |spec: &str| {
        let settings =
            RenderSettings { width: 24, height: 18, technique: spec.into(), per_vertex: true, ..Default::default() };
        Renderer::new(&gpu, &loaded.scene, settings).expect("renderer")
    };
    let radiance = |r: &Renderer| -> Vec<[f32; 4]> {
        let g = &r.scene.geometry;
        let mut v: Vec<[f32; 4]> = gpu.read_buffer(&g.vertex_radiance).expect("radiance");
        v.truncate(g.vertex_count as usize);
        v
    };
    // "… per frame, … ; U % of the clusters unchanged since the frame before …"
    let unchanged = |r: &mut Renderer| -> f64 {
        let line = r.technique_report(&gpu).expect("report").counts.join(" ");
        let head = &line[..line.find(" % of the clusters unchanged").unwrap_or_else(|| panic!("{line}"))];
        head.split_whitespace().last().unwrap().parse().unwrap()
    };
    let mut on = make("shexp:bake=on");
    let mut off = make("shexp");
    // A time at which a piece slides (1.5 s) and one a little later.
    for r in [&mut on, &mut off] {
        animation.apply(r, 1.5).expect("pose");
        r.render(&gpu).expect("frame");
    }
    let first = radiance(&on);
    assert_eq!(first, radiance(&off), "the first frame computes everything");
    let _ = unchanged(&mut on);
    on.render(&gpu).expect("frame");
    let u1 = unchanged(&mut on);
    assert_eq!(radiance(&on), first, "an unchanged frame gives the same image");
    assert!(u1 > 99.9, "every cluster unchanged on a still frame: {u1} %");
    for r in [&mut on, &mut off] {
        animation.apply(r, 1.6).expect("pose");
        r.render(&gpu).expect("frame");
    }
    let u2 = unchanged(&mut on);
    let moved = radiance(&on);
    assert_ne!(moved, first, "the piece moved");
    assert_eq!(moved, radiance(&off), "after a piece moved: bake=on equals bake=off");
    // An environment turn makes the technique afresh (Renderer::set_environment_rotation): its first frame
    // computes everything, the next still frame reuses everything, under the turned lighting.
    for r in [&mut on, &mut off] {
        r.set_environment_rotation(&gpu, 90.0).expect("turn");
        r.render(&gpu).expect("frame");
        r.render(&gpu).expect("frame");
    }
    let u3 = unchanged(&mut on);
    assert_eq!(radiance(&on), radiance(&off), "after the environment turned: bake=on equals bake=off");
    assert_ne!(radiance(&on), moved, "the lighting turned");
    eprintln!(
        "bake: unchanged clusters {u1:.1} % (still), {u2:.1} % (a piece moved), {u3:.1} % (two frames after a turn)"
    );
    assert!(u3 > 49.9, "the second frame after the turn reuses every cluster: {u3} % over both frames");
    on.destroy(&gpu);
    off.destroy(&gpu);

    // Per pixel (records per pixel, the clusters are the screen tiles): the same checks on the image.
    let make_px = |spec: &str| {
        let settings = RenderSettings { width: 48, height: 36, technique: spec.into(), ..Default::default() };
        Renderer::new(&gpu, &loaded.scene, settings).expect("renderer")
    };
    let (mut on, mut off) = (make_px("shexp:bake=on"), make_px("shexp"));
    for r in [&mut on, &mut off] {
        animation.apply(r, 1.5).expect("pose");
        r.render(&gpu).expect("frame");
    }
    let first = on.read_radiance(&gpu).expect("image");
    let _ = unchanged(&mut on);
    on.render(&gpu).expect("frame");
    let p1 = unchanged(&mut on);
    assert_eq!(on.read_radiance(&gpu).expect("image"), first, "per pixel: an unchanged frame gives the same image");
    assert!(p1 > 99.9, "per pixel: every tile unchanged on a still frame: {p1} %");
    for r in [&mut on, &mut off] {
        animation.apply(r, 1.6).expect("pose");
        r.render(&gpu).expect("frame");
    }
    let moved = on.read_radiance(&gpu).expect("image");
    assert_ne!(moved, first, "per pixel: the piece moved");
    assert_eq!(moved, off.read_radiance(&gpu).expect("image"), "per pixel: bake=on equals bake=off");
    eprintln!("bake per pixel: unchanged tiles {p1:.1} % (still)");
    on.destroy(&gpu);
    off.destroy(&gpu);
    gpu.shutdown().expect("clean teardown");
}
