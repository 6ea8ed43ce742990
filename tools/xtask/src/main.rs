//! `cargo xtask`: set-up, demo, test, bless, spheres, tables, report, bench.
//!
//! Set-up installs what a fresh Debian/Ubuntu machine lacks (Vulkan loader, lavapipe, shaderc,
//! validation layers, Xvfb and xwd for the window test, Chromium for the results page's test) with apt when root; otherwise it prints the command and fails.
//! This crate depends on nothing native, so it builds before those packages exist.

use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use std::process::Command;

mod bench;
mod fuzz;
mod report;
mod soak;
mod tables;

const APT_PACKAGES: &[&str] = &[
    "mesa-vulkan-drivers",
    "libvulkan1",
    "libvulkan-dev",
    "libshaderc-dev",
    "glslc",
    "vulkan-validationlayers",
    "xvfb",
    "x11-apps",
    // The results page's browser test (tools/xtask/tests/results_page.rs) drives it headless.
    "chromium",
    // The sweep-as-jobs test runs a job file with GNU parallel (demos/lab/tests/jobs.rs, docs/sweeps.md).
    "parallel",
    // The Python module's tests make a venv (python3 -m venv needs it on Debian's python3).
    "python3-venv",
];

/// The checkout to work on: the one `cargo xtask` runs in (cargo sets CARGO_MANIFEST_DIR for the process it runs),
/// else the one this binary was built from. A target folder shared by two checkouts can hold an xtask built in the
/// other one (cargo sees the same sources and does not rebuild it), whose compile-time path would build and test
/// the other checkout.
pub(crate) fn root() -> PathBuf {
    std::env::var_os("CARGO_MANIFEST_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")))
        .join("../..")
}

/// The help text: every subcommand with what it does.
const USAGE: &str = "usage: cargo xtask <command> [args]
commands:
  demo [demo args]   set up, build (release) and render the default scene to out/ (see `cargo xtask demo --help`)
  test [cargo args]  set up, then check formatting and lints and run every test (validation layers on)
  bless              re-render the reference images of the image tests
  setup              only install what is missing
  spheres MESH ...   fit a sphere set to a mesh (engine-blockers' `spheres` tool)
  tables [--check]   regenerate the binary math tables in assets/tables (or check them)
  lobes-weights [--check]  fit the lobes light leaf weights into assets/tables/lobes_weights.txt (or check it)
  report [math|...]  measurement reports into out/report (see `cargo xtask report --help`)
  bench [bench args] per-pass GPU times of every scene × technique × rate into out/bench (`bench --help`)
  bench-package      the bench as a folder + .tar.gz for a machine without Rust (`bench-package --help`)
  soak [--frames N]  N animated frames (default 10000), every technique in turn: memory must stay flat (--help)
  fuzz TARGET|all    mutation-fuzz a loader (obj gltf glb exr hdr spheres) [--runs N] [--seconds S]
  help, -h, --help   print this text";

/// A usage error: the text on stderr, exit status 2 (what command-line tools use for bad usage).
fn usage_error(message: &str) -> ! {
    eprintln!("xtask: {message}\n{USAGE}");
    std::process::exit(2)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(cmd) = args.first() else { usage_error("no command given") };
    let rest = &args[1..];
    let result = match cmd.as_str() {
        "setup" => setup(),
        "demo" => setup().and_then(|_| demo(rest)),
        "test" => setup().and_then(|_| test(rest)),
        "bless" => setup().and_then(|_| bless()),
        "spheres" => spheres(rest),
        "tables" => tables::run(rest),
        "lobes-weights" => {
            let mut c = cargo();
            c.args(["run", "--release", "--quiet", "-p", "lab", "--bin", "lobes_weights", "--"]).args(rest);
            run(c)
        }
        "report" => setup().and_then(|_| report::run(rest)),
        "bench" => setup().and_then(|_| bench::bench(rest)),
        "bench-package" => setup().and_then(|_| bench::package(rest)),
        "soak" => setup().and_then(|_| soak::run(rest)),
        "fuzz" => fuzz::run(rest),
        // Asking for help is not an error: the text on stdout, status 0.
        "-h" | "--help" | "help" => {
            println!("{USAGE}");
            Ok(())
        }
        other => usage_error(&format!("unknown command '{other}'")),
    };
    if let Err(e) = result {
        eprintln!("xtask: {e:#}");
        std::process::exit(1);
    }
}

fn is_installed(pkg: &str) -> bool {
    Command::new("dpkg-query")
        .args(["-W", "-f=${Status}", pkg])
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).contains("install ok installed"))
        .unwrap_or(false)
}

fn is_root() -> bool {
    Command::new("id").arg("-u").output().map(|o| String::from_utf8_lossy(&o.stdout).trim() == "0").unwrap_or(false)
}

/// Install missing apt packages (when root), and point shaderc-sys at the static library.
fn setup() -> Result<()> {
    let has_apt = Path::new("/usr/bin/apt-get").exists() && Path::new("/usr/bin/dpkg-query").exists();
    if !has_apt {
        bail!(
            "this is not a Debian/Ubuntu machine with apt. Install by hand: the Vulkan loader, a Vulkan driver \
             (Mesa lavapipe works without a GPU), shaderc with libshaderc_combined.a, the Khronos validation layer \
             and Xvfb; then set SHADERC_LIB_DIR to the folder of libshaderc_combined.a"
        );
    }
    let missing: Vec<&str> = APT_PACKAGES.iter().copied().filter(|p| !is_installed(p)).collect();
    if !missing.is_empty() {
        let cmd = format!("apt-get update && apt-get install -y --no-install-recommends {}", missing.join(" "));
        if !is_root() {
            bail!("missing packages: {}. Run as root:\n  sudo sh -c '{cmd}'", missing.join(", "));
        }
        eprintln!("xtask: installing {}", missing.join(" "));
        let ok = Command::new("sh")
            .arg("-c")
            .arg(&cmd)
            .env("DEBIAN_FRONTEND", "noninteractive")
            .status()
            .context("running apt-get")?
            .success();
        if !ok {
            bail!("apt-get failed; run by hand: {cmd}");
        }
    }
    if std::env::var_os("SHADERC_LIB_DIR").is_none() {
        let multiarch = Command::new("gcc")
            .arg("-print-multiarch")
            .output()
            .ok()
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
            .filter(|s| !s.is_empty())
            .unwrap_or_else(|| "x86_64-linux-gnu".into());
        let dir = format!("/usr/lib/{multiarch}");
        if !Path::new(&dir).join("libshaderc_combined.a").exists() {
            bail!("{dir}/libshaderc_combined.a not found even though libshaderc-dev is installed; set SHADERC_LIB_DIR");
        }
        // SAFETY: single-threaded here; children inherit it.
        unsafe { std::env::set_var("SHADERC_LIB_DIR", dir) };
    }
    Ok(())
}

pub(crate) fn cargo() -> Command {
    let mut c = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    c.current_dir(root());
    c
}

pub(crate) fn run(mut c: Command) -> Result<()> {
    let desc = format!("{c:?}");
    let status = c.status().with_context(|| format!("running {desc}"))?;
    if !status.success() {
        bail!("{desc} failed ({status})");
    }
    Ok(())
}

fn demo(rest: &[String]) -> Result<()> {
    let mut c = cargo();
    c.args(["run", "--release", "--quiet", "-p", "demos", "--bin", "demo", "--"]).args(rest);
    run(c)
}

fn test(rest: &[String]) -> Result<()> {
    let t0 = std::time::Instant::now();
    let mut phases: Vec<(&str, f64)> = Vec::new();
    let mut lap = |name, since: &mut std::time::Instant| {
        phases.push((name, since.elapsed().as_secs_f64()));
        *since = std::time::Instant::now();
    };
    let mut since = std::time::Instant::now();
    // Formatting first: it fails fast. A toolchain without the rustfmt/clippy components gets them from rustup
    // when it can; otherwise they are skipped with a warning (the tests still run).
    if has_cargo_tool("fmt", "rustfmt") {
        let mut fmt = cargo();
        fmt.args(["fmt", "--all", "--", "--check"]);
        run(fmt).context("code is not formatted: run `cargo fmt --all`")?;
    }
    lap("fmt", &mut since);
    // The lints ride along with the test build: clippy-driver stands in for rustc on the workspace's own crates
    // (RUSTC_WORKSPACE_WRAPPER, what `cargo clippy` itself sets), with warnings as errors. The dependencies are
    // then compiled once, for the tests, instead of a second time in check mode for a separate `cargo clippy`
    // (docs/suite-time.md). Both commands below get the same environment, so the second builds nothing.
    let lints = clippy_driver();
    let with_env = |c: &mut Command| {
        c.env("ENGINE_VALIDATION", "1");
        if let Some(driver) = &lints {
            c.env("RUSTC_WORKSPACE_WRAPPER", driver)
                .env("CLIPPY_ARGS", "-D__CLIPPY_HACKERY__warnings__CLIPPY_HACKERY__");
        }
    };
    let mut build = cargo();
    with_env(&mut build);
    build.args(["test", "--workspace", "--all-targets", "--no-run"]).args(rest);
    run(build).context(if lints.is_some() { "the build or clippy failed" } else { "the build failed" })?;
    lap("build and lints", &mut since);
    // Validation layers required in every GPU test; any validation error fails teardown.
    let mut c = cargo();
    with_env(&mut c);
    // xtask's own tests (tools/xtask/tests: --help) are part of the suite.
    c.args(["test", "--workspace"]).args(rest);
    run(c)?;
    lap("tests", &mut since);
    // The Python module's tests, built with the same environment so that the engine's crates are reused.
    python_tests(&with_env)?;
    lap("python", &mut since);
    let table: Vec<String> = phases.iter().map(|(n, s)| format!("{n} {s:.0} s")).collect();
    eprintln!("xtask: all tests passed in {:.0} s ({})", t0.elapsed().as_secs_f64(), table.join(", "));
    Ok(())
}

/// The clippy driver to wrap the workspace's crates with, when the clippy component is there (installed by
/// rustup once if missing): rustup's path of it, else `clippy-driver` on the PATH.
fn clippy_driver() -> Option<PathBuf> {
    if !has_cargo_tool("clippy", "clippy") {
        return None;
    }
    let by_rustup = Command::new("rustup")
        .args(["which", "clippy-driver"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| PathBuf::from(String::from_utf8_lossy(&o.stdout).trim()));
    Some(by_rustup.unwrap_or_else(|| PathBuf::from("clippy-driver")))
}

/// The Python module's test tools, pinned (PyPI); a venv made before a change of pins is updated.
const PYTHON_TEST_TOOLS: &[&str] = &["maturin==1.16.0", "numpy==2.4.6", "pytest==9.2.0"];

/// The Python module's tests (python/tests): a venv under the target folder with [`PYTHON_TEST_TOOLS`], the module
/// built into it by `maturin develop` (the dev profile, in the workspace's target folder, so the engine's
/// compiled crates are reused), then pytest with validation layers required.
fn python_tests(with_env: &dyn Fn(&mut Command)) -> Result<()> {
    let t0 = std::time::Instant::now();
    let target = std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root().join("target"), PathBuf::from);
    let venv = target.join("python-venv");
    let bin = venv.join("bin");
    if !bin.join("python").exists() {
        let mut c = Command::new("python3");
        c.args(["-m", "venv"]).arg(&venv);
        run(c).context("creating the Python venv (Debian: apt-get install python3-venv; `cargo xtask setup` does)")?;
    }
    let stamp = venv.join("softshadows-test-tools.txt");
    let pins = PYTHON_TEST_TOOLS.join("\n");
    if std::fs::read_to_string(&stamp).ok().as_deref() != Some(pins.as_str()) {
        let mut c = Command::new(bin.join("python"));
        c.args(["-m", "pip", "install", "--quiet", "--disable-pip-version-check"]).args(PYTHON_TEST_TOOLS);
        run(c).context("installing the Python test tools from PyPI")?;
        std::fs::write(&stamp, &pins).with_context(|| format!("writing {}", stamp.display()))?;
    }
    let path = std::env::join_paths(
        std::iter::once(bin.clone()).chain(std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default())),
    )?;
    let mut c = Command::new(bin.join("maturin"));
    with_env(&mut c);
    c.current_dir(root()).env("VIRTUAL_ENV", &venv).env("PATH", &path).env("CARGO_TARGET_DIR", &target).args([
        "develop",
        "--quiet",
        "--manifest-path",
        "python/Cargo.toml",
    ]);
    run(c).context("building the Python module (maturin develop)")?;
    let built = t0.elapsed().as_secs_f64();
    let mut c = Command::new(bin.join("python"));
    c.current_dir(root()).env("ENGINE_VALIDATION", "1").args(["-m", "pytest", "-q", "python/tests"]);
    run(c).context("the Python module's tests")?;
    eprintln!("xtask: Python module tests in {:.0} s ({built:.0} s venv and build)", t0.elapsed().as_secs_f64());
    Ok(())
}

/// Whether `cargo <sub>` works, installing the rustup component once if it is missing.
fn has_cargo_tool(sub: &str, component: &str) -> bool {
    let works = || cargo().args([sub, "--version"]).output().map(|o| o.status.success()).unwrap_or(false);
    if works() {
        return true;
    }
    eprintln!("xtask: `cargo {sub}` is missing; trying `rustup component add {component}`");
    let added = Command::new("rustup").args(["component", "add", component]).status().map(|s| s.success());
    if matches!(added, Ok(true)) && works() {
        return true;
    }
    eprintln!("xtask: warning: skipping `cargo {sub}` (component {component} unavailable)");
    false
}

/// Re-render the image tests' references, then check them with a normal run. A blessing test writes
/// its reference and fails ("NOT compared": it compared nothing), so the first run's status says
/// nothing; the second run, without ENGINE_BLESS, is the test and decides. Refused under CI (as the
/// tests refuse ENGINE_BLESS there, engine_tests::reference_mode).
fn bless() -> Result<()> {
    if std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "0" && !v.eq_ignore_ascii_case("false")) {
        bail!("`cargo xtask bless` is refused under CI: bless on a developer machine and commit the references");
    }
    let image_tests = || {
        let mut c = cargo();
        c.env("ENGINE_VALIDATION", "1").env_remove("ENGINE_BLESS");
        c.args(["test", "-p", "engine-tests", "--test", "image"]);
        c
    };
    let mut write = image_tests();
    write.env("ENGINE_BLESS", "1");
    let status = write.status().context("running the image tests with ENGINE_BLESS=1")?;
    eprintln!("xtask: references written (that run fails by design: {status}); checking them with a normal run");
    run(image_tests()).context("the image tests fail against the references just written")?;
    eprintln!("xtask: references blessed and checked");
    Ok(())
}

fn spheres(rest: &[String]) -> Result<()> {
    let mut c = cargo();
    c.args(["run", "--release", "--quiet", "-p", "engine-blockers", "--bin", "spheres", "--"]).args(rest);
    run(c)
}
