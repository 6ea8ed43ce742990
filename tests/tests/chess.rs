//! The `chess` scene on the GPU (48×36, validation on): ISG's sphere shadows darken the squares around the pieces'
//! feet against `none`, no pixel is NaN or infinite, and the animated pose (instance transforms uploaded to a
//! renderer built at the rest pose) renders the same image as a renderer built at that pose: the blocker spheres
//! follow the pieces. (CPU side: demos/tests/chess.rs.)

use engine::renderer::{RenderSettings, Renderer};
use engine_tests::{assert_finite, gpu, relative_rmse, render_with_gbuffer, rgb, Receiver};
use scenes::chess::{self, SQUARE};

const W: u32 = 48;
const H: u32 = 36;

fn settings(technique: &str) -> RenderSettings {
    RenderSettings { width: W, height: H, technique: technique.into(), ..Default::default() }
}

fn luminance(hdr: &[f32], i: usize) -> f64 {
    let [r, g, b] = rgb(hdr, i);
    0.2126 * r + 0.7152 * g + 0.0722 * b
}

/// Squares (materials 2 and 3) by their distance to the nearest piece's axis: the isg / none luminance ratio
/// within 0.75 squares of a piece and beyond 1.5 squares, with the pixel counts.
fn board_ratios(scene: &engine::scene::Scene, isg: &[f32], none: &[f32], receivers: &[Receiver]) -> [(f64, usize); 2] {
    let feet: Vec<glam::DVec3> =
        scene.instances[..32].iter().map(|i| i.transform.w_axis.truncate().as_dvec3()).collect();
    let mut sums = [(0.0, 0.0, 0); 2];
    for (i, r) in receivers.iter().enumerate() {
        let Some((p, _, material)) = r else { continue };
        if !(2..=3).contains(material) {
            continue;
        }
        let d = feet.iter().map(|f| ((p.x - f.x).powi(2) + (p.z - f.z).powi(2)).sqrt()).fold(f64::MAX, f64::min);
        let bucket = if d < 0.75 * SQUARE as f64 {
            0
        } else if d > 1.5 * SQUARE as f64 {
            1
        } else {
            continue;
        };
        sums[bucket].0 += luminance(isg, i);
        sums[bucket].1 += luminance(none, i);
        sums[bucket].2 += 1;
    }
    sums.map(|(a, b, n)| (a / b, n))
}

/// One test, so that the renderers are built once each (lavapipe takes seconds per ISG renderer and frame with
/// 308 spheres).
#[test]
fn sphere_shadows_darken_the_board_and_follow_the_moving_pieces() {
    let gpu = gpu();
    let clock = std::time::Instant::now();
    let scene = scenes::build("chess", None).unwrap();
    let (none, receivers) = render_with_gbuffer(&gpu, &scene, settings("none"));
    assert_finite(&none, "none");
    let entry = scenes::find("chess").unwrap();
    let anim = scenes::Animation::for_entry(entry, &scene).expect("chess moves");
    // The final position: 12 pieces captured and carried beside the board, most others moved.
    let t = chess::PERIOD - 1.0;
    let mut posed = scene.clone();
    for (i, m) in anim.pose(t).transforms {
        posed.instances[i].transform = m;
    }
    let mut r = Renderer::new(&gpu, &scene, settings("isg")).unwrap();
    r.render(&gpu).unwrap();
    let rest = r.read_radiance(&gpu).unwrap();
    anim.apply(&mut r, t).unwrap();
    r.render(&gpu).unwrap();
    let animated = r.read_radiance(&gpu).unwrap();
    r.destroy(&gpu);
    let (built, _) = render_with_gbuffer(&gpu, &posed, settings("isg"));
    for (img, what) in [(&rest, "rest"), (&animated, "animated"), (&built, "built posed")] {
        assert_finite(img, what);
    }
    eprintln!("4 frames, 3 renderers in {:.1} s", clock.elapsed().as_secs_f64());

    // Around the feet the pieces hide much of the sky; in the empty middle of the board only the low sky.
    let [(near, n_near), (far, n_far)] = board_ratios(&scene, &rest, &none, &receivers);
    eprintln!("isg / none on the squares: {near:.3} near the pieces ({n_near} px), {far:.3} away ({n_far} px)");
    assert!(n_near > 40 && n_far > 40, "board pixels near {n_near} / far {n_far} from the pieces");
    assert!(near < 0.8, "isg / none near the pieces: {near}");
    assert!(near < far - 0.1, "near {near} vs away {far}");
    assert!(far < 1.0 + 1e-3, "shadows only darken: {far}");

    // Moved pieces change the image; the spheres moved with them: the frame posed through the renderer
    // equals the frame of a renderer built at that pose (were the spheres left at rest, the shadows would
    // differ).
    let changed =
        (0..(W * H) as usize).filter(|&i| (luminance(&animated, i) - luminance(&rest, i)).abs() > 0.01).count();
    let same = relative_rmse(&animated, &built, |_| true);
    eprintln!("t = {t}: {changed} pixels changed from the rest pose; animated vs built at the pose: {same:.2e}");
    assert!(changed > 50, "t = {t}: only {changed} pixels moved");
    assert!(same < 1e-4, "t = {t}: the animated frame differs from the scene built at that pose ({same})");
    gpu.shutdown().expect("clean teardown");
}
