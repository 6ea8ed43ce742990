//! `demo` options that mean nothing or cannot be met (issue 14, defects 5–8): each is honoured exactly or
//! refused with a message naming it (exit status ≠ 0, never a signal or a panic), before any GPU work where the
//! arguments alone decide. docs/bad-input.md lists the same cases.
//!
//! - 5: `ENGINE_DEVICE` chooses the adapter when `--device` is not given; `--device` wins over it.
//! - 6: `--spp` outside the reference, `--spp 0`, beyond the maximum, `--frames 0`, `--capture 0`, `--exposure`
//!   NaN, infinite, zero or negative, a technique key given twice, `--name ""` or a path, options that only make
//!   sense together; `--spp N` gives exactly N samples and long runs report progress; `--env` is loaded by every
//!   scene that uses an environment map and refused by the one that does not (a missing file is an error).
//! - 7: an unusable `--out`/`--export` is refused before the GPU is set up; an error after the set-up prints the
//!   error alone (nothing leaked, no validation complaint).
//! - 8: `--help` lists every registered technique (the scenes: demos/tests/scenes.rs).

use scenes::SCENES;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// What the demo prints once it starts setting up the GPU: absent when an error came from the arguments alone.
const GPU_SET_UP: &str = "preparing scene";

fn demo(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_demo"));
    c.env("ENGINE_VALIDATION", "1").env_remove("ENGINE_DEVICE").env_remove("DEMO_PROGRESS_S").args(args);
    c
}

fn run(mut c: Command) -> (Output, String, String) {
    let out = c.output().expect("running demo");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    (out, stdout, stderr)
}

fn temp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("demo-bad-options-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp folder");
    d
}

/// The run failed cleanly with a message containing every needle: exit status 1 (our errors) or 2 (clap's
/// usage errors), no panic, no leak or validation complaint.
fn assert_refused(out: &Output, stderr: &str, what: &str, needles: &[&str]) {
    // `code()` is None when a signal ended the process.
    assert!(matches!(out.status.code(), Some(1 | 2)), "{what}: {:?}\n{stderr}", out.status);
    assert!(!stderr.contains("panicked"), "{what}: panic\n{stderr}");
    assert!(!stderr.contains("leaked") && !stderr.contains("validation error"), "{what}: unclean\n{stderr}");
    for n in needles {
        assert!(stderr.contains(n), "{what}: the message lacks '{n}':\n{stderr}");
    }
}

/// Refused from the arguments alone: before the GPU is set up.
fn assert_refused_early(args: &[&str], needles: &[&str]) {
    let out = temp("early");
    let mut c = demo(args);
    if !args.contains(&"--out") && !args.contains(&"--export") {
        c.arg("--out").arg(&out);
    }
    let (o, _, stderr) = run(c);
    let what = format!("demo {args:?}");
    assert_refused(&o, &stderr, &what, needles);
    assert!(!stderr.contains(GPU_SET_UP), "{what}: refused only after the GPU was set up:\n{stderr}");
    let _ = std::fs::remove_dir_all(&out);
}

const TINY: &[&str] = &["--width", "8", "--height", "6"];

#[test]
fn meaningless_or_impossible_options_are_refused_before_the_gpu() {
    let cases: &[(&[&str], &[&str])] = &[
        (&["--technique", "none", "--spp", "16"], &["--spp", "reference only"]),
        (&["--technique", "isg", "--spp", "16"], &["--spp", "reference only"]),
        (&["--technique", "reference", "--spp", "0"], &["--spp", "0"]),
        (&["--technique", "reference", "--spp", "65537"], &["--spp", "65536"]),
        (&["--technique", "reference", "--spp", "4294967295"], &["--spp", "65536"]),
        (&["--technique", "reference", "--spp", "64", "--frames", "3"], &["--frames", "--spp"]),
        (&["--technique", "reference", "--spp", "64", "--capture", "3"], &["--capture", "--spp"]),
        (&["--scene", "arm", "--technique", "reference", "--spp", "64", "--animate"], &["--spp", "--animate"]),
        (&["--frames", "0"], &["--frames", "0"]),
        (&["--capture", "0"], &["--capture", "0"]),
        (&["--exposure", "nan"], &["--exposure", "NaN"]),
        (&["--exposure", "inf"], &["--exposure", "inf"]),
        (&["--exposure", "-1"], &["--exposure", "-1"]),
        (&["--exposure", "0"], &["--exposure", "0"]),
        (&["--env-rotation", "nan"], &["--env-rotation", "not a finite number"]),
        (&["--env-rotation", "1e40"], &["--env-rotation", "not a finite number"]),
        (&["--env-spin", "nan"], &["--env-spin", "not a finite number"]),
        (&["--env-spin", "30", "--capture", "2"], &["--env-spin", "--capture"]),
        (&["--technique", "reference", "--spp", "64", "--env-spin", "30"], &["--env-spin", "--spp"]),
        (&["--technique", "isg:patches=4,patches=8"], &["patches", "more than once"]),
        (&["--brdf", "blinn-phong:s=10,s=20"], &["'s'", "more than once"]),
        (&["--name", ""], &["--name", "not a file name"]),
        (&["--name", "../escape"], &["--name", "not a file name"]),
        (&["--exit-after", "5"], &["--exit-after", "--window"]),
        (&["--memory", "--capture", "2"], &["--memory", "--capture"]),
        (&["--ground", "sideways"], &["--ground", "none, auto or engine"]),
        (&["--camera", ""], &["--camera", "auto"]),
        (&["--ground", "none"], &["--ground applies to file scenes"]),
        (&["--camera", "auto"], &["--camera applies to file scenes"]),
    ];
    for (args, needles) in cases {
        let mut all = TINY.to_vec();
        all.extend_from_slice(args);
        assert_refused_early(&all, needles);
    }
}

/// Issue 38, item 6: options that were refused without naming the option or its range, refused only after the
/// frame rendered, or accepted silently. Each is refused before the GPU, naming the option and what it accepts;
/// clap's usage errors exit 2 (as the README's table says), ours 1.
#[test]
fn options_name_themselves_and_their_range() {
    let long_name = "n".repeat(300);
    let cases: &[(&[&str], &[&str], i32)] = &[
        (&["--width", "-1"], &["--width", "-1 is not in 1..=16384"], 2),
        (&["--height", "-7"], &["--height", "-7 is not in 1..=16384"], 2),
        (&["--width", "0"], &["--width", "0 is not in 1..=16384"], 2),
        (&["--width", "99999"], &["--width", "99999 is not in 1..=16384"], 2),
        (&["--name", &long_name], &["--name", "300 bytes", "at most 251"], 2),
        (&["--frames", "1", "--exit-after", "1"], &["--exit-after", "--window"], 2),
        (&["--capture", "1", "--exit-after", "1"], &["--exit-after", "--window"], 2),
        (&["--env-rotation", "1e38"], &["--env-rotation", "[-100000, 100000]"], 2),
        (&["--env-rotation", "-1e38"], &["--env-rotation", "[-100000, 100000]"], 2),
        (&["--env-spin", "1e38"], &["--env-spin", "[-100000, 100000]"], 2),
        (&["--exposure", "1e-45"], &["--exposure", "[1e-6, 1e6]"], 2),
        (&["--device", ""], &["--device", "a value is required"], 2),
        (&["--technique", "shexp:theta_min=90,theta_max=0"], &["--technique", "shexp", "theta_min=90", "below 90"], 1),
        (&["--technique", "shexp:theta_min=30,theta_max=20"], &["--technique: shexp: theta_min=30", "theta_max=20"], 1),
    ];
    for (args, needles, code) in cases {
        let out = temp("ranges");
        let (o, _, stderr) = run({
            let mut c = demo(&[&["--scene", "sheet"][..], args].concat());
            if !args.contains(&"--technique") {
                c.args(["--technique", "none"]);
            }
            c.arg("--out").arg(&out);
            c
        });
        let what = format!("demo {args:?}");
        assert_refused(&o, &stderr, &what, needles);
        assert_eq!(o.status.code(), Some(*code), "{what}: exit status\n{stderr}");
        assert!(!stderr.contains(GPU_SET_UP), "{what}: refused only after the GPU was set up:\n{stderr}");
        let _ = std::fs::remove_dir_all(&out);
    }
    // DEMO_PROGRESS_S that is not a number of seconds: an error naming it, before the GPU.
    for bad in ["abc", "-1", "nan", "1e9"] {
        let (o, _, stderr) = run({
            let mut c = demo(&["--scene", "sheet", "--technique", "none", "--width", "8", "--height", "6"]);
            c.env("DEMO_PROGRESS_S", bad).arg("--out").arg(temp("progress"));
            c
        });
        assert_refused(&o, &stderr, bad, &[&format!("DEMO_PROGRESS_S={bad}"), "not a number of seconds"]);
        assert!(!stderr.contains(GPU_SET_UP), "DEMO_PROGRESS_S={bad}: refused only after the GPU was set up");
    }
}

/// Issue 38, item 8: a usage error or a spec error quoting a 100 kB value prints a short excerpt of it.
#[test]
fn errors_quote_huge_values_as_excerpts() {
    let huge = "k".repeat(100_000);
    let technique = format!("isg:{huge}=1");
    let brdf = format!("{huge}:s=1");
    let cases: Vec<Vec<&str>> = vec![
        vec!["--technique", &technique],
        vec!["--brdf", &brdf],
        vec!["--exposure", &huge],
        vec!["--env-rotation", &huge],
        vec!["--name", &huge],
        vec!["--scene", &huge],
    ];
    for args in cases {
        let (o, _, stderr) = run(demo(&[&["--width", "8", "--height", "6"][..], &args].concat()));
        assert_refused(&o, &stderr, args[0], &[args[0].trim_start_matches("--"), "bytes in all"]);
        assert!(stderr.len() < 2000, "{}: {} bytes of message:\n{}", args[0], stderr.len(), &stderr[..2000]);
    }
}

#[test]
fn env_is_loaded_or_refused_by_every_scene() {
    // A missing file is an error naming it (the furnace refuses --env itself), through the binary.
    for s in SCENES {
        let missing = "/nonexistent/sky-7f3a.exr";
        let needle = if s.name == "furnace" { "--env" } else { missing };
        assert_refused_early(
            &[TINY, &["--scene", s.name, "--env", missing, "--technique", "none"]].concat(),
            &[needle],
        );
    }
    // A real file replaces the scene's environment exactly (CPU side: the scene as built holds its texels).
    let dir = temp("env");
    let path = dir.join("grey.exr");
    let (w, h) = (8u32, 4u32);
    let texels: Vec<f32> = (0..w * h).flat_map(|i| [0.25, 0.5, 0.125 + i as f32 / 64.0, 1.0]).collect();
    engine::output::write_exr(&path, w, h, &texels).expect("writing the test environment");
    for s in SCENES {
        match scenes::build(s.name, Some(&path)) {
            Ok(scene) => {
                let env = &scene.environment;
                assert_eq!((env.width, env.height), (w as usize, h as usize), "{}: --env not loaded", s.name);
                for (i, t) in env.texels.iter().enumerate() {
                    assert_eq!(t[..], texels[4 * i..4 * i + 3], "{}: texel {i}", s.name);
                }
            }
            Err(e) => assert!(format!("{e:#}").contains("--env"), "{}: {e:#}", s.name),
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn spp_is_honoured_exactly_with_progress() {
    let out = temp("spp");
    for (spp, progress) in [("1", &[][..]), ("65", &["33 of 65 samples"][..]), ("130", &["44 of 130", "87 of 130"][..])]
    {
        let mut c =
            demo(&[TINY, &["--scene", "furnace", "--technique", "reference", "--spp", spp, "--name", spp]].concat());
        c.arg("--out").arg(&out).env("DEMO_PROGRESS_S", "0");
        let (o, stdout, stderr) = run(c);
        assert!(o.status.success(), "--spp {spp}: {:?}\n{stderr}", o.status);
        let line = format!("reference: {spp} samples per item");
        assert!(stdout.contains(&line), "--spp {spp}: stdout lacks '{line}':\n{stdout}");
        for p in progress {
            assert!(
                stderr.lines().any(|l| l.starts_with("frame ") && l.contains(p)),
                "--spp {spp}: no '{p}':\n{stderr}"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn engine_device_is_honoured_and_device_wins() {
    const NO_SUCH: &str = "NoSuchGPU-env-5c1d";
    let out = temp("device");
    let (o, _, stderr) = run({
        let mut c = demo(&[TINY, &["--technique", "none", "--frames", "1"]].concat());
        c.arg("--out").arg(&out).env("ENGINE_DEVICE", NO_SUCH);
        c
    });
    assert_refused(&o, &stderr, "ENGINE_DEVICE", &[&format!("ENGINE_DEVICE={NO_SUCH}")]);
    // The adapter this machine has, asked for by name: the argument wins over the variable.
    let gpu = engine::gpu::Gpu::new(&engine::gpu::GpuDesc { verbose: false, ..Default::default() }).expect("a device");
    let name = gpu.info.name.clone();
    gpu.shutdown().expect("teardown");
    let (o, _, stderr) = run({
        let mut c = demo(&[TINY, &["--technique", "none", "--frames", "1", "--device", &name]].concat());
        c.arg("--out").arg(&out).env("ENGINE_DEVICE", NO_SUCH);
        c
    });
    assert!(o.status.success(), "--device {name} with ENGINE_DEVICE={NO_SUCH}: {:?}\n{stderr}", o.status);
    assert!(stderr.contains(&name), "{stderr}");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn unusable_outputs_are_refused_before_the_gpu() {
    let dir = temp("out");
    let file = dir.join("a-file");
    std::fs::write(&file, b"x").unwrap();
    let file_s = file.to_str().unwrap();
    let under_file = file.join("sub");
    let under_file_s = under_file.to_str().unwrap();
    // <out>/<name>.png already a folder.
    std::fs::create_dir_all(dir.join("taken.png")).unwrap();
    let dir_s = dir.to_str().unwrap();
    let cases: &[(&[&str], &[&str])] = &[
        (&["--out", file_s], &["--out", file_s]),
        (&["--out", under_file_s], &["--out", under_file_s]),
        (&["--out", "/proc/demo-cannot-write-here"], &["--out", "/proc/demo-cannot-write-here"]),
        (&["--out", dir_s, "--name", "taken"], &["taken.png", "is a folder"]),
        (&["--capture", "2", "--out", file_s], &["--out", file_s]),
        (&["--export", file_s], &["--export", file_s]),
    ];
    for (args, needles) in cases {
        assert_refused_early(&[TINY, &["--technique", "none"], args].concat(), needles);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// An error after the GPU is set up: the message alone (the renderer is released first), one `error:` line.
fn assert_error_alone(args: &[&str], needle: &str) {
    let (o, _, stderr) = run(demo(args));
    let what = format!("demo {args:?}");
    assert_refused(&o, &stderr, &what, &[needle, GPU_SET_UP]);
    let errors = stderr.lines().filter(|l| l.starts_with("error:")).count();
    assert_eq!(errors, 1, "{what}: {errors} error lines:\n{stderr}");
    let after: Vec<&str> = stderr.lines().skip_while(|l| !l.starts_with("prepared in")).skip(1).collect();
    assert!(after.len() == 1 && after[0].starts_with("error:"), "{what}: more than the error after set-up:\n{stderr}");
}

#[test]
fn errors_after_gpu_set_up_print_alone() {
    let dir = temp("late");
    // The Mitsuba export with Mitsuba's own BSDFs refuses a Cook-Torrance material; it runs once the renderer
    // exists (the export's resolution is the render's, which depends on the adapter).
    let export = dir.join("export");
    assert_error_alone(
        &[
            TINY,
            &["--scene", "furnace", "--technique", "none", "--brdf", "cook-torrance", "--export-bsdf", "builtin"],
            &["--export"],
            &[export.to_str().unwrap()],
        ]
        .concat(),
        "not Blinn-Phong",
    );
    // SHEXP receiver clusters of one pixel at 1920×1080 would need 6 GiB of cut lists: refused at the first
    // frame's recording, before any list is allocated.
    assert_error_alone(
        &["--technique", "shexp:cluster=1", "--width", "1920", "--height", "1080", "--out", dir.to_str().unwrap()],
        "use a larger cluster=T",
    );
    // A full disk: the image write fails after every frame rendered.
    if Path::new("/dev/full").exists() {
        std::os::unix::fs::symlink("/dev/full", dir.join("full.exr")).unwrap();
        assert_error_alone(
            &[
                TINY,
                &["--scene", "furnace", "--technique", "none", "--frames", "1", "--name", "full", "--out"],
                &[dir.to_str().unwrap()],
            ]
            .concat(),
            "full.exr",
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn help_lists_every_registered_technique() {
    let out = Command::new(env!("CARGO_BIN_EXE_demo")).arg("--help").output().expect("demo --help");
    assert!(out.status.success());
    // clap wraps long lines: compare with whitespace collapsed.
    let help = String::from_utf8_lossy(&out.stdout).split_whitespace().collect::<Vec<_>>().join(" ");
    for t in engine::passes::shade::TECHNIQUES {
        let line = format!("{} {}", t.name, t.summary);
        assert!(help.contains(&line), "--help lacks technique '{line}':\n{help}");
        for o in t.options {
            assert!(help.contains(&format!("{}=", o.key)), "--help lacks {}'s option {}", t.name, o.key);
        }
    }
    let registry = engine::passes::shade::techniques_help().split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(help.contains(&registry), "--help does not hold techniques_help() whole");
    for s in SCENES {
        assert!(help.contains(s.name), "--help lacks scene {}", s.name);
    }
}
