//! The environment-lights settings from the user's side: scene-file keys (`[environment] lights`, …), the
//! `--env-lights*` options and `demo --env-lights-preview` (no GPU). The decomposition itself is tested in
//! engine-math (env_lights) and with the renderer in tests/tests/env_lights.rs.

use engine::math::env_lights::EnvLightParams;
use scenes::user::parse_scene_file;
use std::process::Command;

fn params(environment: &str) -> Result<EnvLightParams, String> {
    let text = format!("[[model]]\nfile = \"m.obj\"\n\n[environment]\n{environment}\n");
    let spec = parse_scene_file(&text).map_err(|e| format!("{e:#}"))?;
    spec.environment.expect("an [environment] table").env_lights().map_err(|e| format!("{e:#}"))
}

#[test]
fn scene_file_keys_set_and_check_the_split() {
    let d = EnvLightParams::default();
    assert_eq!(params("intensity = 1").unwrap(), d, "no key: the defaults");
    assert_eq!(params("lights = 3").unwrap().max_lights, 3);
    assert_eq!(params("lights = 0").unwrap().max_lights, 0);
    assert_eq!(params("lights = false").unwrap().max_lights, 0, "false: no lights");
    assert_eq!(params("lights = true").unwrap(), d, "true: the default count");
    let p = params("light_threshold = 8\nlight_share = 2.5\nlight_radius = 30").unwrap();
    assert_eq!(p.threshold, 8.0);
    assert!((p.min_share - 0.025).abs() < 1e-12 && (p.max_radius - 30f64.to_radians()).abs() < 1e-12);
    for (bad, needles) in [
        ("lights = 17", &["environment.lights", "17", "0..=16"][..]),
        ("lights = -1", &["environment.lights", "-1"]),
        ("light_threshold = 1", &["environment.light_threshold", "(1, 1e6]"]),
        ("light_threshold = nan", &["environment.light_threshold"]),
        ("light_share = 0", &["environment.light_share", "(0, 100]"]),
        ("light_radius = 91", &["environment.light_radius", "(0, 90]"]),
        ("lights = \"many\"", &["lights"]),
        ("light_count = 3", &["light_count"]),
    ] {
        let e = params(bad).expect_err(bad);
        for n in needles {
            assert!(e.contains(n), "{bad}: '{e}' lacks '{n}'");
        }
    }
}

fn demo(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_demo"))
        .env("ENGINE_VALIDATION", "1")
        .env_remove("ENGINE_DEVICE")
        .args(args)
        .output()
        .expect("running demo");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn options_are_range_checked_and_the_preview_needs_no_gpu() {
    for (args, needle) in [
        (&["--env-lights", "17"][..], "--env-lights"),
        (&["--env-lights", "-1"], "--env-lights"),
        (&["--env-light-threshold", "1"], "--env-light-threshold"),
        (&["--env-light-share", "0"], "--env-light-share"),
        (&["--env-light-radius", "nan"], "--env-light-radius"),
        (&["--env-lights-preview", "--window"], "--window"),
    ] {
        let (code, _, stderr) = demo(args);
        assert_eq!(code, Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(needle) && !stderr.contains("panicked"), "{args:?}: {stderr}");
    }
    let out = std::env::temp_dir().join(format!("env-lights-preview-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let o = out.to_str().expect("utf-8 temp path");
    let (code, stdout, stderr) =
        demo(&["--scene", "battle", "--env-lights-preview", "--env-lights", "8", "--out", o, "--name", "b"]);
    assert_eq!(code, Some(0), "{stderr}");
    // The sunset holds two qualifying regions: the split stops early and says so.
    assert!(stdout.contains("light 0:") && stdout.contains("8 asked for, 2 found"), "{stdout}");
    assert!(!stderr.contains("preparing scene"), "the preview set up the GPU: {stderr}");
    let (w, h, _) = engine::output::read_png(&out.join("b-env-lights.png")).expect("the preview picture");
    assert_eq!((w, h), (512, 512), "the map over its residual");
    let _ = std::fs::remove_dir_all(&out);
}
