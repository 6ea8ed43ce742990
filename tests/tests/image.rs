//! Image tests of the default scene (and the others below) against the references in tests/references/, by FLIP
//! mean.
//! A missing reference fails; `cargo xtask bless` (ENGINE_BLESS=1) writes it: a blessing run fails
//! ("NOT compared") and is refused under CI (engine_tests::reference_mode). On failure
//! `-actual.png` and `-diff.png` are written next to the reference.

use engine::renderer::RenderSettings;
use std::path::PathBuf;

// FLIP mean 0.02: renders are deterministic on one driver (lavapipe gives identical images run to
// run); the margin absorbs other drivers' rounding in texture filtering and transcendentals,
// which stays below 0.01 in FLIP terms, while a wrong light, material or orientation gives > 0.1.
const FLIP_MEAN_THRESHOLD: f32 = 0.02;

fn references() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("references")
}

fn rgb(rgba: &[u8]) -> Vec<u8> {
    rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect()
}

/// Compare a tone-mapped render with `references/<name>.png` by FLIP mean (or write it when
/// blessing); on failure write `<name>-actual.png` and `<name>-diff.png` beside it.
fn check_against_reference(name: &str, w: u32, h: u32, ldr: &[u8], threshold: f32) {
    let reference = references().join(format!("{name}.png"));
    if engine_tests::reference_mode() == engine_tests::ReferenceMode::Bless {
        engine::output::write_png(&reference, w, h, ldr).expect("write reference");
        engine_tests::blessed(&reference);
    }
    let (rw, rh, ref_rgba) = engine::output::read_png(&reference)
        .unwrap_or_else(|e| panic!("missing reference image ({e}); run `cargo xtask bless` to create it"));
    assert_eq!((rw, rh), (w, h), "reference size differs");
    let test_img = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(ldr));
    let ref_img = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(&ref_rgba));
    let err = nv_flip::flip(ref_img, test_img, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let mean = nv_flip::FlipPool::from_image(&err).mean();
    eprintln!("{name}: FLIP mean {mean:.4} (threshold {threshold})");
    if mean > threshold {
        let actual = references().join(format!("{name}-actual.png"));
        let diff = references().join(format!("{name}-diff.png"));
        engine::output::write_png(&actual, w, h, ldr).ok();
        let d = err.apply_color_lut(&nv_flip::magma_lut()).to_vec();
        let d: Vec<u8> = d.chunks_exact(3).flat_map(|p| [p[0], p[1], p[2], 255]).collect();
        engine::output::write_png(&diff, w, h, &d).ok();
        panic!("{name}: FLIP mean {mean} > {threshold}; wrote {} and {}", actual.display(), diff.display());
    }
}

/// [`check_against_reference`] for several images; when blessing, every reference is written before the
/// first check ends the blessing run.
fn check_all_against_references(images: &[(String, Vec<u8>)], w: u32, h: u32) {
    if engine_tests::reference_mode() == engine_tests::ReferenceMode::Bless {
        for (name, ldr) in images {
            engine::output::write_png(&references().join(format!("{name}.png")), w, h, ldr).expect("write reference");
        }
    }
    for (name, ldr) in images {
        check_against_reference(name, w, h, ldr, FLIP_MEAN_THRESHOLD);
    }
}

#[test]
fn default_scene_matches_reference() {
    let gpu = engine_tests::gpu();
    let scene = scenes::build("bunny", None).expect("default scene");
    let (w, h) = (128, 96);
    let settings = RenderSettings { width: w, height: h, technique: "none".into(), ..Default::default() };
    let (hdr, ldr) = engine_tests::render(&gpu, &scene, settings);
    gpu.shutdown().expect("clean teardown");
    assert!(hdr.iter().all(|v| v.is_finite()), "non-finite pixel in the default scene");
    check_against_reference("default", w, h, &ldr, FLIP_MEAN_THRESHOLD);
}

// The bunny scene with technique `isg` (soft shadows, default settings). Same threshold and reason
// as the default scene: a reference written on one driver, compared on another.
#[test]
fn isg_bunny_matches_reference() {
    let gpu = engine_tests::gpu();
    let scene = scenes::build("bunny", None).expect("default scene");
    let (w, h) = (128, 96);
    let settings = RenderSettings { width: w, height: h, technique: "isg".into(), ..Default::default() };
    let (hdr, ldr) = engine_tests::render(&gpu, &scene, settings);
    gpu.shutdown().expect("clean teardown");
    assert!(hdr.iter().all(|v| v.is_finite()), "non-finite pixel in the isg bunny");
    check_against_reference("isg-bunny", w, h, &ldr, FLIP_MEAN_THRESHOLD);
}

#[test]
fn default_scene_shows_the_environment() {
    // The bunny's lit side is brighter than its shaded side, and the ground is tinted by the
    // environment (not grey): checked on the linear image.
    let gpu = engine_tests::gpu();
    let scene = scenes::build("bunny", None).expect("default scene");
    let (w, h) = (128u32, 96u32);
    let (hdr, _) = engine_tests::render(
        &gpu,
        &scene,
        RenderSettings { width: w, height: h, technique: "none".into(), ..Default::default() },
    );
    gpu.shutdown().expect("clean teardown");
    let px = |x: u32, y: u32| {
        let i = ((y * w + x) * 4) as usize;
        [hdr[i], hdr[i + 1], hdr[i + 2]]
    };
    // Ground near the bottom centre: its colour differs between channels (environment tint).
    let g = px(w / 2, h - 4);
    assert!(g.iter().all(|c| *c > 0.0), "ground is black: {g:?}");
    let spread = g.iter().cloned().fold(f32::MIN, f32::max) / g.iter().cloned().fold(f32::MAX, f32::min);
    assert!(spread > 1.02, "ground is untinted grey: {g:?}");
    // Luminance varies across the bunny (lit vs shaded side).
    let lum: Vec<f32> = (30..98).map(|x| px(x, h / 2)).map(|c| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]).collect();
    let (lo, hi) = lum.iter().fold((f32::MAX, f32::MIN), |(l, m), v| (l.min(*v), m.max(*v)));
    assert!(hi > 1.3 * lo, "no lighting variation across the bunny: {lo}..{hi}");
}

// Every registered technique at its defaults on the `lamp` scene (the bunny, its 64 blocker spheres, the
// dimmed courtyard and two spherical lights), 64×48: a technique is image-tested by being registered
// (its reference is `technique-<name>-lamp.png`, written by `cargo xtask bless`). Same threshold and
// reason as above; the reference technique renders one deterministic frame (4 samples per pixel).
#[test]
fn every_technique_on_the_lamp_scene_matches_its_reference() {
    let gpu = engine_tests::gpu();
    let scene = scenes::build("lamp", None).expect("lamp scene");
    let (w, h) = (64, 48);
    let mut images = Vec::new();
    for entry in engine::passes::shade::TECHNIQUES {
        let settings = RenderSettings { width: w, height: h, technique: entry.name.into(), ..Default::default() };
        let (hdr, ldr) = engine_tests::render(&gpu, &scene, settings);
        assert!(hdr.iter().all(|v| v.is_finite()), "{}: non-finite pixel", entry.name);
        images.push((format!("technique-{}-lamp", entry.name), ldr));
    }
    gpu.shutdown().expect("clean teardown");
    check_all_against_references(&images, w, h);
}

/// The demo scenes × every registered technique at 48 × 36, posed at a moment of their animation (chess: a
/// piece in mid-slide; battle: the troll's club raised, the wizard casting; cloth: 0.25 s into the fall, before
/// contact: the drape after contact is sensitive to f32 rounding and would not be a fair image test across
/// drivers). References `scene-<scene>-<technique>.png`; same threshold and reason as above (the
/// reference technique renders one deterministic frame of 4 samples per pixel).
#[test]
fn demo_scenes_with_every_technique_match_their_references() {
    let gpu = engine_tests::gpu();
    let (w, h) = (48, 36);
    let mut images = Vec::new();
    for (name, t) in [("chess", 1.5f32), ("battle", 0.8), ("cloth", 0.25)] {
        let loaded = scenes::load(name, None, &Default::default()).expect("scene");
        for entry in engine::passes::shade::TECHNIQUES {
            let settings = RenderSettings { width: w, height: h, technique: entry.name.into(), ..Default::default() };
            let mut r = engine::renderer::Renderer::new(&gpu, &loaded.scene, settings).expect("renderer");
            let animation = loaded.animation.as_ref().expect("the demo scenes are animated");
            animation.apply(&mut r, t).expect("pose");
            let t0 = std::time::Instant::now();
            r.render(&gpu).unwrap_or_else(|e| panic!("{name} × {}: frame: {e}", entry.name));
            eprintln!("{name} × {}: frame {:.2} s", entry.name, t0.elapsed().as_secs_f64());
            let hdr = r.read_radiance(&gpu).expect("radiance");
            let ldr = r.read_ldr(&gpu).expect("ldr");
            r.destroy(&gpu);
            assert!(hdr.iter().all(|v| v.is_finite()), "{name} × {}: non-finite pixel", entry.name);
            images.push((format!("scene-{name}-{}", entry.name), ldr));
        }
    }
    gpu.shutdown().expect("clean teardown");
    check_all_against_references(&images, w, h);
}
