//! The fuzz targets in the test suite: every seed loads, every regression input in corpus/ is refused with an
//! error (no panic, allocation or time over the bounds), and a short bounded mutation run per loader finds
//! nothing. Long runs: `cargo xtask fuzz TARGET --runs N`.

use engine_fuzz::{check, corpus, execute, CountingAlloc, Driver, TARGETS};
use std::time::Duration;

#[global_allocator]
static ALLOC: CountingAlloc = CountingAlloc;

/// Seconds of mutation per target in the suite (six targets: ~12 s in all).
const SUITE_SECONDS: f64 = 2.0;

fn work_dir(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("engine-fuzz-test-{}-{name}", std::process::id()))
}

#[test]
fn every_seed_loads() {
    engine_fuzz::quiet_panics();
    for t in TARGETS {
        let dir = work_dir(&format!("seeds-{}", t.name));
        std::fs::create_dir_all(&dir).unwrap();
        let seeds = (t.seeds)();
        assert!(!seeds.is_empty(), "{}: no seeds", t.name);
        for (i, s) in seeds.iter().enumerate() {
            let p = dir.join(format!("seed{i}.{}", t.ext));
            std::fs::write(&p, s).unwrap();
            let r = (t.run)(&p);
            assert!(r.is_ok(), "{} seed {i} does not load: {:?}", t.name, r);
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn regression_corpus_is_refused_within_bounds() {
    assert!(engine_fuzz::counting(), "the counting allocator is not installed");
    let mut total = 0;
    for t in TARGETS {
        let dir = work_dir(&format!("corpus-{}", t.name));
        std::fs::create_dir_all(&dir).unwrap();
        for (path, bytes) in corpus(t).unwrap() {
            let p = dir.join(format!("input.{}", t.ext));
            std::fs::write(&p, &bytes).unwrap();
            let o = execute(t, &p);
            assert!(check(&o).is_none(), "{}: {:?} {:?}", path.display(), check(&o), o);
            assert!(!o.loaded, "{}: loads; a regression input is one the loader must refuse", path.display());
            total += 1;
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
    assert!(total >= 5, "only {total} regression inputs");
}

#[test]
fn a_short_run_of_every_target_finds_nothing() {
    for t in TARGETS {
        let dir = work_dir(&format!("run-{}", t.name));
        let mut d = Driver::new(t, &dir, 0x5eed).unwrap();
        let stats = d.run(u64::MAX, Some(Duration::from_secs_f64(SUITE_SECONDS)), |_| {}).unwrap();
        eprintln!("{}", stats.summary(t.name));
        assert!(stats.executions >= 20, "{}: {} executions", t.name, stats.executions);
        assert!(stats.loaded > 0 && stats.rejected > 0, "{}: {stats:?}", t.name);
        assert!(stats.findings.is_empty(), "{}: {:?} (inputs kept in {})", t.name, stats.findings, dir.display());
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// The loaders contain parser panics quietly (engine::io::catch_quiet, which no panic hook sees): the driver
/// still counts them, through engine::io's counter.
#[test]
fn quietly_contained_panics_are_counted() {
    let t = engine_fuzz::target("gltf").expect("gltf target");
    let (path, bytes) = corpus(t)
        .unwrap()
        .into_iter()
        .find(|(p, _)| p.ends_with("accessor-index-out-of-range.gltf"))
        .expect("the corpus input the gltf crate panics on");
    let dir = work_dir("quiet");
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("input.gltf");
    std::fs::write(&p, bytes).unwrap();
    let o = execute(t, &p);
    assert!(o.escaped.is_none() && !o.loaded, "{}: {o:?}", path.display());
    assert!(o.contained_panics >= 1, "{}: the contained panic was not counted: {o:?}", path.display());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The command line is clap's: a malformed value is a usage error (exit 2) naming the option and the value.
#[test]
fn command_line_errors_name_the_option() {
    let run = |args: &[&str]| std::process::Command::new(env!("CARGO_BIN_EXE_fuzz")).args(args).output().unwrap();
    let o = run(&["obj", "--runs", "abc"]);
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("invalid value 'abc' for '--runs <RUNS>'"), "{err}");
    let o = run(&["obj", "--seconds", "0"]);
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("'--seconds <SECONDS>'") && err.contains("> 0"), "{err}");
    let o = run(&["--help"]);
    assert!(o.status.success() && String::from_utf8_lossy(&o.stdout).contains("targets: obj"));
}

/// process-fuzz's command line is clap's too: a malformed or out-of-range value, an unknown place or option is a
/// usage error (exit 2) naming it, before any run; `--help` lists the places.
#[test]
fn process_fuzz_command_line_errors_name_the_option() {
    let run = |args: &[&str]| {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_process-fuzz")).args(args).output().unwrap();
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stderr).to_string(),
            String::from_utf8_lossy(&o.stdout).to_string(),
        )
    };
    let demo = env!("CARGO_BIN_EXE_fuzz");
    for (args, named) in [
        (vec!["--demo", demo, "--runs", "abc"], "'--runs <RUNS>'"),
        (vec!["--demo", demo, "--timeout", "0"], "'--timeout <TIMEOUT>'"),
        (vec!["--demo", demo, "--memory-mib", "8"], "'--memory-mib <MEMORY_MIB>'"),
        (vec!["--demo", demo, "--only", "nowhere"], "'--only <ONLY>'"),
        (vec!["--demo", demo, "--bogus", "1"], "--bogus"),
        (vec!["--runs", "1"], "--demo"),
    ] {
        let (code, err, _) = run(&args);
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(err.contains(named), "{args:?}: {err}");
    }
    let (code, _, out) = run(&["--help"]);
    assert_eq!(code, Some(0));
    assert!(out.contains("places: obj"), "{out}");
}
