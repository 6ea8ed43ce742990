//! Blocker tiles (engine::passes::shade::tiles): starting each pixel's BVH traversals from its tile's culled
//! list renders the same image as starting from the root, for every technique that traverses per pixel; a tile
//! whose list overflows falls back to the root and renders the same image too; the lists the GPU builds are
//! the f64 twin's; and the counters see the traversal shrink.

use engine::passes::shade::tiles::{cpu, TileCounts, TILE_SIDE};
use engine::renderer::{RenderSettings, Renderer};
use engine::scene::Scene;
use engine_tests::gpu;

const W: u32 = 64;
const H: u32 = 48;

fn crowd(count: u32) -> Scene {
    scenes::build(&format!("crowd:count={count}"), None).expect("crowd")
}

/// Radiance and tile counts of one frame of `technique` on `scene`.
fn frame(gpu: &engine::gpu::Gpu, scene: &Scene, technique: &str) -> (Vec<f32>, TileCounts) {
    let settings = RenderSettings { width: W, height: H, technique: technique.into(), ..Default::default() };
    let mut r = Renderer::new(gpu, scene, settings).unwrap_or_else(|e| panic!("{technique}: {e}"));
    r.render(gpu).unwrap_or_else(|e| panic!("{technique}: {e}"));
    let hdr = r.read_radiance(gpu).expect("radiance");
    let counts = r.tile_counts(gpu).expect("counts").expect("a BVH technique has tile counts");
    r.destroy(gpu);
    (hdr, counts)
}

/// The largest difference between two images relative to the larger value (0 for equal images).
fn largest_difference(a: &[f32], b: &[f32]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (*x as f64 - *y as f64).abs() / (x.abs().max(y.abs()) as f64).max(1e-3))
        .fold(0.0, f64::max)
}

/// tiles=on (the default), tiles=off and tile_cap=1 (every tile falls back to the root) render the same crowd,
/// and the tile lists shorten what each pixel tests.
#[test]
fn tile_lists_render_the_same_image_as_the_root_and_so_does_their_fallback() {
    let g = gpu();
    let scene = crowd(4);
    for t in ["isg", "lobes", "shexp:cluster=0", "shexp"] {
        let sep = if t.contains(':') { "," } else { ":" };
        let (on, c_on) = frame(&g, &scene, t);
        let (off, c_off) = frame(&g, &scene, &format!("{t}{sep}tiles=off"));
        let (full, c_full) = frame(&g, &scene, &format!("{t}{sep}tile_cap=1"));
        eprintln!("{t}: on {}\n  off {}\n  cap 1 {}", c_on.line(), c_off.line(), c_full.line());
        let d = largest_difference(&on, &off);
        assert!(d <= 1e-4, "{t}: tiles=on differs from tiles=off by {d:.2e}");
        let d = largest_difference(&full, &off);
        assert!(d <= 1e-4, "{t}: tile_cap=1 differs from tiles=off by {d:.2e}");
        assert!(c_on.frames == 1 && c_on.tiles > 0 && c_on.fell_back == 0, "{t}: {c_on:?}");
        assert!(c_off.frames == 0, "{t}: tiles=off built lists: {c_off:?}");
        assert!(c_full.fell_back > 0 && c_full.list_max == 1, "{t}: tile_cap=1 did not fall back: {c_full:?}");
        assert_eq!(c_on.pixels, c_off.pixels, "{t}");
        if t != "shexp" {
            // shexp's default per pixel reads its receiver clusters' cuts: only their fallback traverses.
            assert!(
                c_on.pixel_mean < c_off.pixel_mean,
                "{t}: the lists did not shorten the traversals: {c_on:?} {c_off:?}"
            );
            assert!((c_full.pixel_mean - c_off.pixel_mean).abs() < 1e-9, "{t}: the fallback is the root traversal");
        }
    }
    g.shutdown().expect("clean shutdown");
}

/// The lists the GPU builds have the lengths the f64 twin gives from the same G-buffer and BVH, without and with
/// the level of detail.
#[test]
fn gpu_tile_lists_match_the_twin() {
    let g = gpu();
    let scene = crowd(4);
    for lod_deg in [0.0f64, 15.0] {
        twin_case(&g, &scene, lod_deg);
    }
    g.shutdown().expect("clean shutdown");
}

fn twin_case(g: &engine::gpu::Gpu, scene: &Scene, lod_deg: f64) {
    let technique = format!("isg:tile_lod={lod_deg}");
    let settings = RenderSettings { width: W, height: H, technique: technique.clone(), ..Default::default() };
    let (_, receivers, bvh) = engine_tests::render_with_bvh(g, scene, settings);
    let (_, counts) = frame(g, scene, &technique);
    let o = engine::passes::shade::isg::IsgOptions::default();
    let sin_t = engine::passes::shade::tiles::sin_take_whole(engine::passes::shade::isg::take_whole_bound(&o)) as f64;
    let sin_lod = lod_deg.to_radians().sin();
    let nodes: Vec<cpu::Node> = bvh
        .nodes
        .iter()
        .map(|n| cpu::Node {
            center: n.center.map(f64::from),
            radius: n.radius as f64,
            children: (n.left != u32::MAX).then_some((n.left, n.right)),
        })
        .collect();
    let (tx, ty) = (W.div_ceil(TILE_SIDE), H.div_ceil(TILE_SIDE));
    let (mut tiles, mut sum, mut max) = (0u64, 0u64, 0u64);
    for t in 0..tx * ty {
        let (x0, y0) = ((t % tx) * TILE_SIDE, (t / tx) * TILE_SIDE);
        let inside: Vec<([f64; 3], [f64; 3])> = (y0..(y0 + TILE_SIDE).min(H))
            .flat_map(|y| (x0..(x0 + TILE_SIDE).min(W)).map(move |x| (y * W + x) as usize))
            .filter_map(|i| receivers[i].map(|(p, n, _)| (p.to_array(), n.to_array())))
            .collect();
        let Some(b) = cpu::bounds(&inside) else { continue };
        let list = cpu::tile_list(&nodes, &b, sin_t, sin_lod, 512).expect("fits");
        tiles += 1;
        sum += list.len() as u64;
        max = max.max(list.len() as u64);
    }
    let mean = sum as f64 / tiles as f64;
    eprintln!("tile_lod={lod_deg}: twin: {tiles} tiles, mean {mean:.2}, longest {max}; gpu: {}", counts.line());
    assert_eq!(counts.tiles, tiles);
    // The shader's rounding margins (cull.comp) cull a little less and open a little less: a node or two apart.
    assert!((counts.list_mean - mean).abs() <= 0.05 * mean + 0.5, "gpu {} vs twin {mean}", counts.list_mean);
    assert!(counts.list_max.abs_diff(max) <= 2, "gpu {} vs twin {max}", counts.list_max);
}

/// The level of detail (tile_lod, an approximation) tests fewer nodes per pixel than the exact lists and keeps the
/// image close to them on a crowd, with every value finite. It acts only above a technique's own take-whole angle
/// (`shexp`'s θ_max is 25°: at 30° it changed nothing here), so `isg` and `lobes` are tested.
#[test]
fn the_level_of_detail_tests_fewer_nodes_and_stays_close() {
    let g = gpu();
    let scene = crowd(16);
    for t in ["isg", "lobes"] {
        let sep = if t.contains(':') { "," } else { ":" };
        let (exact, c_exact) = frame(&g, &scene, t);
        let (lod, c_lod) = frame(&g, &scene, &format!("{t}{sep}tile_lod=30"));
        engine_tests::assert_finite(&lod, t);
        let e = engine_tests::relative_rmse(&lod, &exact, |_| true);
        eprintln!(
            "{t}: tile_lod=30 vs exact: relative RMSE {:.3} %; exact {}; lod {}",
            100.0 * e,
            c_exact.line(),
            c_lod.line()
        );
        assert!(c_lod.pixel_mean < c_exact.pixel_mean, "{t}: {c_lod:?} vs {c_exact:?}");
        assert!(e < 0.06, "{t}: tile_lod=30 moved the image by {:.2} %", 100.0 * e);
    }
    g.shutdown().expect("clean shutdown");
}

/// The bounded reach (option reach, an approximation) drops far blockers: fewer nodes per pixel than unbounded, the
/// same image with the tile lists as without them (the tile pass culls only what lies beyond the reach of its
/// whole tile), and every value finite.
#[test]
fn the_reach_cuts_the_work_and_the_tiles_keep_it_exact() {
    let g = gpu();
    let scene = crowd(16);
    for t in ["isg", "shexp:cluster=0", "shexp", "lobes"] {
        let sep = if t.contains(':') { "," } else { ":" };
        let (full, c_full) = frame(&g, &scene, t);
        let (near, c_near) = frame(&g, &scene, &format!("{t}{sep}reach=2"));
        let (near_off, _) = frame(&g, &scene, &format!("{t}{sep}reach=2,tiles=off"));
        engine_tests::assert_finite(&near, t);
        let e = engine_tests::relative_rmse(&near, &full, |_| true);
        eprintln!(
            "{t}: reach=2 vs unbounded: relative RMSE {:.3} %; unbounded {}; reach {}",
            100.0 * e,
            c_full.line(),
            c_near.line()
        );
        let d = largest_difference(&near, &near_off);
        assert!(d <= 1e-4, "{t}: with reach=2, tiles=on differs from tiles=off by {d:.2e}");
        if t != "shexp" {
            assert!(c_near.pixel_mean < c_full.pixel_mean, "{t}: {c_near:?} vs {c_full:?}");
        }
        assert!(e > 0.0, "{t}: reach=2 changed nothing on a 16-character crowd");
    }
    g.shutdown().expect("clean shutdown");
}
