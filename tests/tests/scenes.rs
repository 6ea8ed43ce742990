//! Every registered demo scene (demos/scenes) renders: a 32×24 frame at its rest pose and one posed by its
//! motion, finite and not blank, validation on, no leaks (the CPU checks are demos/tests/scenes.rs).

use engine::renderer::{RenderSettings, Renderer};
use engine_tests::{assert_finite, gpu};

#[test]
fn every_registered_scene_renders() {
    let gpu = gpu();
    let settings = RenderSettings { width: 32, height: 24, ..Default::default() };
    for entry in scenes::SCENES {
        let scene = scenes::build(entry.name, None).unwrap_or_else(|e| panic!("{}: {e:#}", entry.name));
        let mut r = Renderer::new(&gpu, &scene, settings.clone()).unwrap_or_else(|e| panic!("{}: {e}", entry.name));
        let mut frames = vec![(0.0, r.render(&gpu).and_then(|_| r.read_radiance(&gpu)))];
        if let Some(a) = scenes::Animation::for_entry(entry, &scene) {
            let t = 1.5;
            a.apply(&mut r, t).unwrap_or_else(|e| panic!("{}: pose at {t} s: {e}", entry.name));
            frames.push((t, r.render(&gpu).and_then(|_| r.read_radiance(&gpu))));
        }
        r.destroy(&gpu);
        for (t, hdr) in frames {
            let hdr = hdr.unwrap_or_else(|e| panic!("{} at {t} s: {e}", entry.name));
            assert_finite(&hdr, entry.name);
            let lit = hdr.chunks_exact(4).filter(|p| p[0] + p[1] + p[2] > 0.0).count();
            assert!(lit > 32 * 24 / 10, "{} at {t} s: only {lit} lit pixels", entry.name);
        }
    }
    gpu.shutdown().expect("clean teardown");
}
