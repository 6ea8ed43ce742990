//! `demo --animate`: the arm bends and the bunny turns; the posed frames differ from the static ones
//! and render cleanly (validation on, no leaks).

use std::process::{Command, Stdio};

fn render(scene: &str, extra: &[&str], name: &str, out: &std::path::Path) -> Vec<u8> {
    let status = Command::new(env!("CARGO_BIN_EXE_demo"))
        .env("ENGINE_VALIDATION", "1")
        .args(["--scene", scene, "--technique", "none", "--width", "48", "--height", "32", "--name", name, "--out"])
        .arg(out)
        .args(extra)
        .stdout(Stdio::null())
        .status()
        .expect("running demo");
    assert!(status.success(), "demo --scene {scene} {extra:?} failed");
    engine::output::read_png(&out.join(format!("{name}.png"))).expect("png").2
}

#[test]
fn animated_frames_differ_from_the_static_pose() {
    let out = std::env::temp_dir().join(format!("engine-animate-test-{}", std::process::id()));
    std::fs::create_dir_all(&out).unwrap();
    for (scene, frames) in [("arm", "1"), ("bunny", "16")] {
        let still = render(scene, &["--frames", "1"], &format!("{scene}-still"), &out);
        let moved = render(scene, &["--frames", frames, "--animate"], &format!("{scene}-moved"), &out);
        let differing = still.chunks_exact(4).zip(moved.chunks_exact(4)).filter(|(a, b)| a != b).count();
        // The arm starts straight (the static scene is bent 60°); the bunny has turned 0.25 rad by frame 16.
        assert!(differing > 20, "{scene}: only {differing} pixels changed under --animate");
    }
    let _ = std::fs::remove_dir_all(&out);
}
