//! Every binary installs a logger: the engine's warnings (dropped triangles, recomputed normals, missing
//! materials, the validation-layer fallback) reach stderr by default, and `RUST_LOG` sets the level. Before, no
//! logger was ever initialised and every `log::warn!` was dropped.

use std::path::PathBuf;
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Every `main` of the workspace (src/main.rs and src/bin/*.rs of every crate, and `[[bin]]` paths) whose crate
/// can log (it depends on the engine, whose passes and loaders warn) calls the one logger set-up,
/// `scenes::init_logging()`, first. The crates below the engine (engine-math, engine-blockers) and the
/// native-free xtask and math-report log nothing, and install no logger: no copy of the set-up exists anywhere.
#[test]
fn every_binary_initialises_the_logger() {
    let mut mains = Vec::new();
    let mut stack = vec![root()];
    while let Some(dir) = stack.pop() {
        let manifest = std::fs::read_to_string(dir.join("Cargo.toml")).unwrap_or_default();
        // The crate that owns a file: the nearest folder above it with a Cargo.toml.
        let logs = ["engine = ", "scenes = ", "lab = "].iter().any(|d| manifest.contains(d));
        for e in std::fs::read_dir(&dir).unwrap().flatten() {
            let p = e.path();
            let name = p.file_name().unwrap().to_string_lossy().to_string();
            if p.is_dir() {
                if !name.starts_with('.') && name != "target" && name != "out" && name != "docs" {
                    stack.push(p);
                }
            } else if name == "Cargo.toml" && manifest.contains("[package]") {
                let crate_logs = logs;
                let mut files: Vec<PathBuf> = bin_paths(&manifest).into_iter().map(|b| dir.join(b)).collect();
                files.push(dir.join("src/main.rs"));
                if let Ok(bins) = std::fs::read_dir(dir.join("src/bin")) {
                    files.extend(bins.flatten().map(|b| b.path()).filter(|b| b.extension().is_some_and(|x| x == "rs")));
                }
                for file in files.into_iter().filter(|f| f.exists()) {
                    let rel = file.strip_prefix(root()).unwrap().to_string_lossy().to_string();
                    if !mains.iter().any(|(r, _, _): &(String, String, bool)| *r == rel) {
                        mains.push((rel, std::fs::read_to_string(&file).unwrap(), crate_logs));
                    }
                }
            }
        }
    }
    assert!(mains.iter().any(|m| m.0.ends_with("tools/fuzz/src/process.rs")), "the [[bin]] paths are read");
    assert!(mains.iter().any(|m| m.0.ends_with("demos/lab/src/bin/compare.rs")), "src/bin is read");
    assert!(mains.len() >= 19, "binaries found: {:?}", mains.iter().map(|m| &m.0).collect::<Vec<_>>());
    for (rel, text, logs) in &mains {
        assert!(!text.contains("env_logger::"), "{rel}: a copy of the logger set-up (call scenes::init_logging)");
        if !logs {
            continue;
        }
        let body = &text[text.find("fn main(").unwrap_or_else(|| panic!("{rel}: no fn main"))..];
        let first = body.lines().skip(1).find(|l| !l.trim_start().starts_with("//")).unwrap_or("");
        assert!(
            first.contains("scenes::init_logging()"),
            "{rel}: main does not call scenes::init_logging() first (first line: {first})"
        );
    }
}

/// The `path = "…"` of every `[[bin]]` table of a Cargo.toml.
fn bin_paths(toml: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut in_bin = false;
    for line in toml.lines().map(str::trim) {
        if line.starts_with('[') {
            in_bin = line == "[[bin]]";
        } else if let Some(v) = line.strip_prefix("path").map(str::trim_start).and_then(|r| r.strip_prefix('=')) {
            if in_bin {
                out.push(v.trim().trim_matches('"').to_string());
            }
        }
    }
    out
}

/// The demo on an OBJ whose .mtl is missing: the loader's warning is shown with RUST_LOG unset, hidden with
/// RUST_LOG=error.
#[test]
fn warnings_are_shown_by_default_and_rust_log_is_honoured() {
    let dir = std::env::temp_dir().join(format!("logging-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let obj = dir.join("lone.obj");
    std::fs::write(&obj, "mtllib nowhere.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl x\nf 1 2 3\n").unwrap();
    let run = |rust_log: Option<&str>| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_demo"));
        c.args(["--scene", obj.to_str().unwrap(), "--technique", "none", "--spheres", "0"])
            .args(["--width", "8", "--height", "6", "--frames", "1", "--out", dir.to_str().unwrap()])
            .env_remove("RUST_LOG");
        if let Some(level) = rust_log {
            c.env("RUST_LOG", level);
        }
        let out = c.output().expect("running demo");
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        assert!(out.status.success(), "demo failed: {stderr}");
        stderr
    };
    let default = run(None);
    assert!(
        default.contains("WARN") && default.contains("materials not loaded"),
        "the missing .mtl warning is not shown by default:\n{default}"
    );
    let quiet = run(Some("error"));
    assert!(!quiet.contains("materials not loaded"), "RUST_LOG=error still shows the warning:\n{quiet}");
    let _ = std::fs::remove_dir_all(&dir);
}
