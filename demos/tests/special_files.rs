//! Issue 38, items 1–2 and "Also": every file the demo reads, given as a special file or size, at the process
//! level. Kinds: a FIFO (blocked the open forever), an endless file (a link to /dev/zero: read without limit until
//! the process aborted), a folder, a symbolic-link loop, an empty file and a 2 GiB + 1 byte sparse file (over every
//! size limit: refused from its length before a byte is read). Places: `--scene` (.obj, .gltf, .glb, .toml),
//! `--env` (.exr, .hdr), an OBJ's `mtllib`, a glTF's buffer `uri`, and a scene file's `environment.file`,
//! `material_map.file` and `sphere_files`.
//!
//! Each run is bounded: killed after [`TIME_LIMIT`], with its address space capped at [`MEMORY_LIMIT_KIB`]
//! (`ulimit -v`), so an endless read ends as an abort the test sees instead of exhausting the machine. Each must
//! exit with status 1 and one `error:` line naming the file (no panic text), or, for the files that are valid
//! (an empty `.mtl`), reach the GPU set-up, which is made to fail (no Vulkan driver): nothing renders.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The longest a run may take: loading the tiny inputs takes well under a second.
const TIME_LIMIT: Duration = Duration::from_secs(30);
/// Address space of a run: 1 GiB (the demo refuses these files from the metadata; reading the sparse file or an
/// endless one would need more).
const MEMORY_LIMIT_KIB: u64 = 1 << 20;
/// What the demo prints when a scene loaded and only the (absent) Vulkan driver stopped it (one or the other,
/// by loader version).
const NO_DEVICE: &[&str] = &["no usable Vulkan device", "vkCreateInstance"];

/// The special file kinds, made at `path`.
const KINDS: &[&str] = &["fifo", "endless", "folder", "loop", "empty", "sparse"];

fn make_special(kind: &str, path: &Path) {
    let _ = std::fs::remove_file(path);
    let _ = std::fs::remove_dir_all(path);
    match kind {
        "fifo" => assert!(Command::new("mkfifo").arg(path).status().expect("mkfifo").success()),
        "endless" => std::os::unix::fs::symlink("/dev/zero", path).expect("symlink"),
        "folder" => std::fs::create_dir_all(path).expect("folder"),
        "loop" => {
            let other = path.with_extension("loop-partner");
            let _ = std::fs::remove_file(&other);
            std::os::unix::fs::symlink(&other, path).expect("symlink");
            std::os::unix::fs::symlink(path, &other).expect("symlink");
        }
        "empty" => std::fs::write(path, b"").expect("empty file"),
        "sparse" => {
            let f = std::fs::File::create(path).expect("sparse file");
            f.set_len((2u64 << 30) + 1).expect("2 GiB + 1 sparse");
        }
        _ => unreachable!("kind {kind}"),
    }
}

/// A place where the demo reads a file: the file name to replace with a special file, the support files to write
/// beside it, and the demo's arguments (`{dir}` is the folder).
struct Place {
    what: &'static str,
    special: &'static str,
    support: &'static [(&'static str, &'static str)],
    args: &'static [&'static str],
}

const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

const PLACES: &[Place] = &[
    Place { what: "--scene .obj", special: "x.obj", support: &[], args: &["--scene", "{dir}/x.obj"] },
    Place { what: "--scene .gltf", special: "x.gltf", support: &[], args: &["--scene", "{dir}/x.gltf"] },
    Place { what: "--scene .glb", special: "x.glb", support: &[], args: &["--scene", "{dir}/x.glb"] },
    Place { what: "--scene .toml", special: "x.toml", support: &[], args: &["--scene", "{dir}/x.toml"] },
    Place {
        what: "--env .exr",
        special: "x.exr",
        support: &[("tri.obj", TRI)],
        args: &["--scene", "{dir}/tri.obj", "--env", "{dir}/x.exr"],
    },
    Place {
        what: "--env .hdr",
        special: "x.hdr",
        support: &[("tri.obj", TRI)],
        args: &["--scene", "{dir}/tri.obj", "--env", "{dir}/x.hdr"],
    },
    Place {
        what: "mtllib",
        special: "x.mtl",
        support: &[("m.obj", "mtllib x.mtl\nusemtl a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")],
        args: &["--scene", "{dir}/m.obj"],
    },
    Place {
        what: "glTF buffer uri",
        special: "x.bin",
        support: &[(
            "b.gltf",
            r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":36,"uri":"x.bin"}],
               "bufferViews":[{"buffer":0,"byteLength":36}],
               "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],
               "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]}"#,
        )],
        args: &["--scene", "{dir}/b.gltf"],
    },
    Place {
        what: "environment.file",
        special: "x.exr",
        support: &[
            ("tri.obj", TRI),
            ("e.toml", "environment = { file = \"x.exr\" }\n[[model]]\nfile = \"tri.obj\"\nspheres = 0\n"),
        ],
        args: &["--scene", "{dir}/e.toml"],
    },
    Place {
        what: "material_map.file",
        special: "x.png",
        support: &[
            ("tri.obj", TRI),
            (
                "p.toml",
                "[[model]]\nfile = \"tri.obj\"\nspheres = 0\nmaterial = { brdf = \"phong:e=10\" }\n\
                 material_map = { file = \"x.png\", material = { brdf = \"phong:e=100\" } }\n",
            ),
        ],
        args: &["--scene", "{dir}/p.toml"],
    },
    Place {
        what: "sphere_files",
        special: "x.json",
        support: &[("tri.obj", TRI), ("s.toml", "[[model]]\nfile = \"tri.obj\"\nsphere_files = [\"x.json\"]\n")],
        args: &["--scene", "{dir}/s.toml"],
    },
];

/// Run the demo under the time and memory bounds: (exit code or None for a signal, stderr, timed out).
fn run_bounded(args: &[String]) -> (Option<i32>, String, bool) {
    let mut c = Command::new("sh");
    c.arg("-c")
        .arg(format!("ulimit -v {MEMORY_LIMIT_KIB} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_demo"))
        .args(args)
        .args(["--width", "8", "--height", "6", "--technique", "none"])
        .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .env_remove("ENGINE_DEVICE")
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    let mut child = c.spawn().expect("running demo");
    let t0 = Instant::now();
    let mut stderr = child.stderr.take().expect("stderr");
    // Read stderr on a thread so that a chatty child never blocks on a full pipe.
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut stderr, &mut s);
        s
    });
    let (status, timed_out) = loop {
        if let Some(s) = child.try_wait().expect("waiting for demo") {
            break (s, false);
        }
        if t0.elapsed() > TIME_LIMIT {
            let _ = child.kill();
            break (child.wait().expect("waiting for demo"), true);
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    (status.code(), reader.join().unwrap_or_default(), timed_out)
}

#[test]
fn special_files_are_refused_everywhere_within_time_and_memory() {
    let root = std::env::temp_dir().join(format!("demo-special-files-{}", std::process::id()));
    let mut failures = Vec::new();
    for (p, place) in PLACES.iter().enumerate() {
        for kind in KINDS {
            let dir: PathBuf = root.join(format!("{p}-{kind}"));
            std::fs::create_dir_all(&dir).expect("temp folder");
            for (name, text) in place.support {
                std::fs::write(dir.join(name), text).expect("support file");
            }
            let special = dir.join(place.special);
            make_special(kind, &special);
            let args: Vec<String> = place.args.iter().map(|a| a.replace("{dir}", &dir.display().to_string())).collect();
            let t0 = Instant::now();
            let (code, stderr, timed_out) = run_bounded(&args);
            let what = format!("{} as {kind} ({:.1} s)", place.what, t0.elapsed().as_secs_f64());
            let names_file = stderr.contains(place.special);
            let verdict = if timed_out {
                Some("did not finish (a blocked or endless read)")
            } else if code.is_none() {
                Some("ended by a signal (an abort: memory exhausted?)")
            } else if stderr.contains("panicked at") {
                Some("printed panic text")
            } else if code != Some(1) {
                Some("exit status is not 1")
            } else if stderr.lines().filter(|l| l.starts_with("error: ")).count() != 1 {
                Some("does not print one `error:` line")
            } else if !names_file && !NO_DEVICE.iter().any(|n| stderr.contains(n)) {
                Some("the error does not name the file")
            } else if kind != &"empty" && !names_file {
                Some("a special file was accepted")
            } else {
                None
            };
            eprintln!("{what}: {}", stderr.trim());
            if let Some(v) = verdict {
                failures.push(format!("{what}: {v}: exit {code:?}\n{stderr}"));
            }
        }
    }
    let _ = std::fs::remove_dir_all(&root);
    assert!(
        failures.is_empty(),
        "{} of {} runs failed:\n{}",
        failures.len(),
        PLACES.len() * KINDS.len(),
        failures.join("\n")
    );
}
