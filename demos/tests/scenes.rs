//! The scene registry (demos/scenes): every registered scene builds and passes the registry's checks, its
//! motion poses it at a spread of times (CPU side; tests/tests/scenes.rs renders each one), and the binaries take
//! their scene list from it: `--help` lists every name with its summary, an unknown `--scene` is an error naming
//! the registered ones.

use scenes::{self, SCENES};
use std::process::Command;

#[test]
fn every_registered_scene_builds_and_poses() {
    let mut names: Vec<&str> = SCENES.iter().map(|s| s.name).collect();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), SCENES.len(), "scene names are unique");
    for entry in SCENES {
        let scene = scenes::build(entry.name, None).unwrap_or_else(|e| panic!("{}: {e:#}", entry.name));
        scenes::check(entry, &scene).unwrap_or_else(|e| panic!("{e:#}"));
    }
}

#[test]
fn motions_start_at_the_rest_pose() {
    // The turntable starts at the scene as built; the arm starts straight (the static scene is bent 60°).
    let bunny = scenes::build("bunny", None).unwrap();
    let a = scenes::Animation::for_entry(scenes::find("bunny").unwrap(), &bunny).expect("bunny moves");
    assert_eq!(a.pose(0.0).transforms, vec![(0, bunny.instances[0].transform)]);
    let arm = scenes::build("arm", None).unwrap();
    let a = scenes::Animation::for_entry(scenes::find("arm").unwrap(), &arm).expect("arm moves");
    assert_eq!(a.pose(0.0).bones, Some(scenes::arm::bones(0.0)));
    assert!(scenes::find("furnace").unwrap().motion.is_none());
}

#[test]
fn unknown_scenes_are_errors_naming_the_registered_ones() {
    let err = scenes::build("teapot", None).unwrap_err().to_string();
    assert!(err.contains("teapot") && SCENES.iter().all(|s| err.contains(s.name)), "{err}");
    let out = Command::new(env!("CARGO_BIN_EXE_demo")).args(["--scene", "teapot"]).output().expect("demo");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("teapot") && SCENES.iter().all(|s| stderr.contains(s.name)), "{stderr}");
    // The furnace's environment is what it tests: --env is refused, not ignored.
    let err = scenes::build("furnace", Some(std::path::Path::new("sky.exr"))).unwrap_err();
    assert!(format!("{err:#}").contains("--env"), "{err:#}");
}

#[test]
fn demo_help_lists_every_scene_and_motion() {
    let out = Command::new(env!("CARGO_BIN_EXE_demo")).arg("--help").output().expect("demo --help");
    assert!(out.status.success());
    // clap wraps long lines: compare with whitespace collapsed.
    let help = String::from_utf8_lossy(&out.stdout).split_whitespace().collect::<Vec<_>>().join(" ");
    for s in SCENES {
        assert!(
            help.contains(&format!("{}: {}", s.name, s.summary)),
            "--help lacks '{}: {}':\n{help}",
            s.name,
            s.summary
        );
        if let Some(m) = s.motion {
            let listed = help.split(m.summary).nth(1).and_then(|rest| rest.split(')').next()).unwrap_or_default();
            assert!(listed.contains(s.name), "--animate help lacks {} under '{}':\n{help}", s.name, m.summary);
        }
    }
}

#[test]
fn the_registry_check_catches_bad_entries() {
    // The check the registered scenes pass must fail on the mistakes it names.
    fn furnace(_: &scenes::SceneInputs) -> anyhow::Result<engine::scene::Scene> {
        Ok(scenes::furnace::scene(0.5, 1.0))
    }
    fn moves_instance_7(_: &scenes::Rest, t: f32) -> scenes::Pose {
        scenes::Pose { transforms: vec![(7, glam::Mat4::from_rotation_y(t))], bones: None }
    }
    fn never_moves(rest: &scenes::Rest, _: f32) -> scenes::Pose {
        scenes::Pose { transforms: vec![(0, rest.transforms[0])], bones: None }
    }
    fn three_bones(_: &scenes::Rest, _: f32) -> scenes::Pose {
        scenes::Pose { transforms: Vec::new(), bones: Some(vec![glam::Mat4::IDENTITY; 3]) }
    }
    let scene = scenes::furnace::scene(0.5, 1.0);
    let entry = |pose, summary| scenes::SceneEntry {
        name: "bad",
        summary,
        build: furnace,
        motion: Some(scenes::Motion { summary: "moves", pose }),
    };
    for (e, what) in [
        (entry(moves_instance_7, "fine"), "instance 7"),
        (entry(never_moves, "fine"), "never changes"),
        (entry(three_bones, "fine"), "3 bones"),
        (entry(never_moves, "two\nlines"), "one line"),
    ] {
        let err = scenes::check(&e, &scene).expect_err(what).to_string();
        assert!(err.contains(what), "expected '{what}': {err}");
    }
    let mut bad_light = scene.clone();
    bad_light.lights.push(engine::scene::SphereLight {
        center: glam::Vec3::ZERO,
        radius: 0.0,
        radiance: glam::Vec3::ONE,
    });
    let err = scenes::check(&scenes::furnace::SCENE, &bad_light).unwrap_err().to_string();
    assert!(err.contains("bad light"), "{err}");
}

/// `--scene FILE` errors come before the GPU, naming the file: a missing model, an extension that is neither a
/// model nor a scene file, an unknown `--clip`, and `--clip` on a registered scene.
#[test]
fn file_scene_errors_name_the_file() {
    let demo = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_demo")).args(args).output().expect("demo");
        (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (code, err) = demo(&["--scene", "/nonexistent/model.glb"]);
    assert!(code == Some(1) && err.contains("/nonexistent/model.glb: file not found"), "{err}");
    let (code, err) = demo(&["--scene", "model.fbx"]);
    assert!(code == Some(2) && err.contains("model.fbx") && err.contains(".gltf, .glb, .obj or .toml"), "{err}");
    let arm = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/arm.gltf");
    let (code, err) = demo(&["--scene", arm, "--animate", "--clip", "wave", "--spheres", "0"]);
    assert!(code == Some(1) && err.contains(arm) && err.contains("clips: bend, lift, pulse"), "{err}");
    let (code, err) = demo(&["--scene", "bunny", "--animate", "--clip", "wave"]);
    assert!(code == Some(1) && err.contains("--clip applies to file scenes"), "{err}");
}
