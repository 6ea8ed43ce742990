//! Every binary installs a logger: the engine's warnings (dropped triangles, recomputed normals, missing
//! materials, the validation-layer fallback) reach stderr by default, and `RUST_LOG` sets the level. Before, no
//! logger was ever initialised and every `log::warn!` was dropped.

use std::path::PathBuf;
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Every `main` of the workspace (src/main.rs and src/bin/*.rs of every crate) sets the logger up first.
#[test]
fn every_binary_initialises_the_logger() {
    let mut mains = Vec::new();
    let mut stack = vec![root()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap().flatten() {
            let p = e.path();
            let name = p.file_name().unwrap().to_string_lossy().to_string();
            if p.is_dir() {
                if !name.starts_with('.') && name != "target" && name != "out" && name != "docs" {
                    stack.push(p);
                }
            } else if p.extension().is_some_and(|x| x == "rs") {
                let rel = p.strip_prefix(root()).unwrap().to_string_lossy().to_string();
                if rel.ends_with("src/main.rs") || rel.contains("src/bin/") {
                    mains.push((rel, std::fs::read_to_string(&p).unwrap()));
                }
            } else if name == "Cargo.toml" {
                // A `[[bin]]` with its own `path` (tools/fuzz's process-fuzz is src/process.rs).
                for path in bin_paths(&std::fs::read_to_string(&p).unwrap()) {
                    let file = dir.join(path);
                    let rel = file.strip_prefix(root()).unwrap().to_string_lossy().to_string();
                    if !(rel.ends_with("src/main.rs") || rel.contains("src/bin/")) {
                        mains.push((rel, std::fs::read_to_string(&file).unwrap()));
                    }
                }
            }
        }
    }
    assert!(mains.iter().any(|m| m.0.ends_with("tools/fuzz/src/process.rs")), "the [[bin]] paths are read");
    assert!(mains.len() >= 19, "binaries found: {:?}", mains.iter().map(|m| &m.0).collect::<Vec<_>>());
    for (rel, text) in &mains {
        let body = &text[text.find("fn main(").unwrap_or_else(|| panic!("{rel}: no fn main"))..];
        let first = body.lines().skip(1).find(|l| !l.trim_start().starts_with("//")).unwrap_or("");
        assert!(
            first.contains("demos::init_logging()") || first.contains("env_logger::Builder"),
            "{rel}: main does not set up the logger first (first line: {first})"
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
