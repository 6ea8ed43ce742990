//! The `battle` scene on the GPU (64×48, validation on), posed by its clips at t = 1 s (the troll's club coming
//! down, the wizard's arms raised): isg and shexp frames are finite, and the ground around the characters' feet is
//! darker against `none` than the open ground away from every character, rock and column: the skinned spheres,
//! posed through the bone matrices, cast their shadows where the characters stand. (CPU side:
//! demos/tests/battle.rs.)

use engine::renderer::RenderSettings;
use engine_tests::{assert_finite, gpu, render_with_gbuffer, rgb, Receiver};
use scenes::battle;

const W: u32 = 64;
const H: u32 = 48;

fn settings(technique: &str) -> RenderSettings {
    RenderSettings { width: W, height: H, technique: technique.into(), ..Default::default() }
}

fn luminance(hdr: &[f32], i: usize) -> f64 {
    let [r, g, b] = rgb(hdr, i);
    0.2126 * r + 0.7152 * g + 0.0722 * b
}

/// The technique / none luminance ratio on ground pixels within 0.45 m (horizontally) of either character's
/// feet, and on ground pixels more than 1.4 m from every other instance's origin; with the pixel counts.
fn ground_ratios(scene: &engine::scene::Scene, lit: &[f32], none: &[f32], receivers: &[Receiver]) -> [(f64, usize); 2] {
    let ground = scene.materials.len() - 1;
    let feet = [battle::TROLL_AT, battle::WIZARD_AT].map(|p| p.as_dvec3());
    let others: Vec<glam::DVec3> =
        scene.instances[..scene.instances.len() - 1].iter().map(|i| i.transform.w_axis.truncate().as_dvec3()).collect();
    let flat = |p: glam::DVec3, q: glam::DVec3| ((p.x - q.x).powi(2) + (p.z - q.z).powi(2)).sqrt();
    let mut sums = [(0.0, 0.0, 0); 2];
    for (i, r) in receivers.iter().enumerate() {
        let Some((p, _, material)) = r else { continue };
        if *material != ground {
            continue;
        }
        let bucket = if feet.iter().any(|f| flat(*p, *f) < 0.45) {
            0
        } else if others.iter().all(|o| flat(*p, *o) > 1.4) {
            1
        } else {
            continue;
        };
        sums[bucket].0 += luminance(lit, i);
        sums[bucket].1 += luminance(none, i);
        sums[bucket].2 += 1;
    }
    sums.map(|(a, b, n)| (a / b, n))
}

#[test]
fn battle_shadows_gather_at_the_characters_feet() {
    let gpu = gpu();
    let clock = std::time::Instant::now();
    let mut scene = scenes::build("battle", None).unwrap();
    let entry = scenes::find("battle").unwrap();
    let pose = scenes::Animation::for_entry(entry, &scene).expect("battle moves").pose(1.0);
    for (i, m) in pose.transforms {
        scene.instances[i].transform = m;
    }
    scene.blockers.bones = pose.bones.expect("the clips move bones");
    let (none, receivers) = render_with_gbuffer(&gpu, &scene, settings("none"));
    assert_finite(&none, "none");
    for technique in ["isg", "shexp"] {
        let (lit, _) = render_with_gbuffer(&gpu, &scene, settings(technique));
        assert_finite(&lit, technique);
        let [(near, n_near), (far, n_far)] = ground_ratios(&scene, &lit, &none, &receivers);
        eprintln!("{technique} / none on the ground: {near:.3} at the feet ({n_near} px), {far:.3} away ({n_far} px)");
        assert!(n_near > 15 && n_far > 40, "{technique}: ground pixels at the feet {n_near} / away {n_far}");
        // The characters hide a good part of the sky and of the lights from the ground they stand on.
        assert!(near < far - 0.1, "{technique}: at the feet {near} vs away {far}");
        assert!(far < 1.0 + 1e-3, "{technique}: shadows only darken: {far}");
    }
    eprintln!("3 frames in {:.1} s", clock.elapsed().as_secs_f64());
    gpu.shutdown().expect("clean teardown");
}
