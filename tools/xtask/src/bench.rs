//! `cargo xtask bench [bench args]`: build the `bench` binary (release) and run it (demos/lab/src/bench.rs).
//! `cargo xtask bench-package [--out DIR]`: the bench as a folder and a `.tar.gz` that runs on a Linux x86-64
//! machine with a Vulkan driver but no Rust toolchain and no network: `./run.sh [bench args]`.

use crate::{cargo, root, run};
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use std::process::Command;

pub fn bench(rest: &[String]) -> Result<()> {
    let mut c = cargo();
    c.args(["run", "--release", "--quiet", "-p", "lab", "--bin", "bench", "--"]).args(rest);
    run(c)
}

/// What the package's `run.sh` does: point the engine at the packaged shaders and assets, keep the SPIR-V cache
/// inside the package, use the machine's Vulkan loader or else the bundled one, then run the bench.
const RUN_SH: &str = r#"#!/bin/sh
# The engine's bench, packaged by `cargo xtask bench-package`. Needs a Vulkan driver (ICD); the Vulkan loader is
# bundled in lib/ for machines that lack one. Usage: ./run.sh [bench options]   (./run.sh --help)
# Results go to ./out/bench unless --out is given. `./run.sh demo [demo options]` runs the demo instead.
set -e
here=$(cd "$(dirname "$0")" && pwd)
export ENGINE_SHADER_ROOT="$here/shaders-glsl"
export ENGINE_ASSETS="$here/assets"
export ENGINE_SHADER_CACHE="${ENGINE_SHADER_CACHE:-$here/shader-cache}"
if ! { ldconfig -p 2>/dev/null || /sbin/ldconfig -p 2>/dev/null; } | grep -q 'libvulkan\.so\.1'; then
    if [ -e "$here/lib/libvulkan.so.1" ]; then
        export LD_LIBRARY_PATH="$here/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
    else
        echo "run.sh: no Vulkan loader (libvulkan.so.1) on this machine and none bundled" >&2
        exit 1
    fi
fi
if [ "$1" = "demo" ]; then
    shift
    exec "$here/bin/demo" "$@"
fi
cd "$here"
exec "$here/bin/bench" "$@"
"#;

pub fn package(rest: &[String]) -> Result<()> {
    let mut out = root().join("out/bench-package");
    let mut it = rest.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--out" => out = PathBuf::from(it.next().context("--out needs a folder")?),
            "-h" | "--help" => {
                println!(
                    "usage: cargo xtask bench-package [--out DIR]\n  writes DIR/engine-bench/ (bin/bench, bin/demo, \
                     shaders-glsl/, assets/, lib/libvulkan.so.1, run.sh) and DIR/engine-bench.tar.gz"
                );
                return Ok(());
            }
            other => bail!("bench-package: unknown argument '{other}' (try --help)"),
        }
    }
    let mut build = cargo();
    build.args(["build", "--release", "--quiet", "-p", "lab", "-p", "demos", "--bin", "bench", "--bin", "demo"]);
    run(build)?;
    let target = std::env::var_os("CARGO_TARGET_DIR").map(PathBuf::from).unwrap_or_else(|| root().join("target"));
    let dir = out.join("engine-bench");
    if dir.exists() {
        std::fs::remove_dir_all(&dir).with_context(|| format!("removing the old {}", dir.display()))?;
    }
    for sub in ["bin", "lib"] {
        std::fs::create_dir_all(dir.join(sub)).with_context(|| format!("creating {}", dir.join(sub).display()))?;
    }
    for bin in ["bench", "demo"] {
        let to = dir.join("bin").join(bin);
        copy(&target.join("release").join(bin), &to)?;
        // The release profile keeps line tables for profilers (~90 MB a binary); the package drops them.
        match Command::new("strip").arg("--strip-debug").arg(&to).status() {
            Ok(s) if s.success() => {}
            _ => {
                eprintln!("xtask: warning: `strip --strip-debug {}` failed; the package keeps debug info", to.display())
            }
        }
    }
    copy_tree(&root().join("shaders-glsl"), &dir.join("shaders-glsl"))?;
    copy_tree(&root().join("assets"), &dir.join("assets"))?;
    match vulkan_loader() {
        Some(p) => copy(&p, &dir.join("lib/libvulkan.so.1"))?,
        None => eprintln!("xtask: warning: no libvulkan.so.1 found here to bundle; the target machine needs its own"),
    }
    let run_sh = dir.join("run.sh");
    std::fs::write(&run_sh, RUN_SH).with_context(|| format!("writing {}", run_sh.display()))?;
    set_executable(&run_sh)?;
    let tarball = out.join("engine-bench.tar.gz");
    let ok = Command::new("tar")
        .arg("-czf")
        .arg(&tarball)
        .arg("-C")
        .arg(&out)
        .arg("engine-bench")
        .status()
        .context("running tar")?
        .success();
    if !ok {
        bail!("tar failed writing {}", tarball.display());
    }
    println!("wrote {} and {}", dir.display(), tarball.display());
    println!("on the other machine: tar xzf engine-bench.tar.gz && engine-bench/run.sh   (run.sh --help for options)");
    Ok(())
}

/// The Vulkan loader this machine uses, resolved through its symlinks.
fn vulkan_loader() -> Option<PathBuf> {
    let listed = Command::new("/sbin/ldconfig").arg("-p").output().ok()?;
    let text = String::from_utf8_lossy(&listed.stdout);
    let line = text.lines().find(|l| l.trim_start().starts_with("libvulkan.so.1 ") && l.contains("x86-64"))?;
    let path = PathBuf::from(line.rsplit("=> ").next()?.trim());
    std::fs::canonicalize(path).ok()
}

fn copy(from: &Path, to: &Path) -> Result<()> {
    std::fs::copy(from, to).with_context(|| format!("copying {} to {}", from.display(), to.display()))?;
    Ok(())
}

fn copy_tree(from: &Path, to: &Path) -> Result<()> {
    std::fs::create_dir_all(to).with_context(|| format!("creating {}", to.display()))?;
    for e in std::fs::read_dir(from).with_context(|| format!("reading {}", from.display()))? {
        let e = e?;
        let (src, dst) = (e.path(), to.join(e.file_name()));
        if e.file_type()?.is_dir() {
            copy_tree(&src, &dst)?;
        } else {
            copy(&src, &dst)?;
        }
    }
    Ok(())
}

#[cfg(unix)]
fn set_executable(p: &Path) -> Result<()> {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(p, std::fs::Permissions::from_mode(0o755))
        .with_context(|| format!("chmod {}", p.display()))
}

#[cfg(not(unix))]
fn set_executable(_: &Path) -> Result<()> {
    Ok(())
}
