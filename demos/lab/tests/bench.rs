//! `cargo xtask bench` smoke run (a tiny size on lavapipe; not a timed assertion): the binary measures every
//! technique × rate of a scene and writes CSV, JSON, Markdown and a plot that name the adapter and the commit;
//! a steady frame allocates no device memory; bad arguments are refused before any GPU work.

use lab::bench::{read_csv, COMMIT};
use std::process::Command;

fn bench(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_bench")).args(args).output().expect("running bench")
}

#[test]
fn smoke_run_writes_every_file_with_every_row() {
    let out = std::env::temp_dir().join(format!("bench-smoke-{}", std::process::id()));
    let o = out.to_str().unwrap();
    let run = bench(&["--scene", "bunny", "--size", "16x12", "--frames", "2", "--warmup", "1", "--out", o]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "bench failed: {:?}\n{stderr}", run.status);
    // Progress: one line per row.
    let techniques: Vec<&str> = engine::passes::shade::TECHNIQUES.iter().map(|t| t.name).collect();
    assert_eq!(stderr.lines().filter(|l| l.starts_with('[')).count(), 2 * techniques.len(), "{stderr}");
    let lines = read_csv(&out.join("bench.csv")).expect("the CSV parses");
    for t in &techniques {
        for rate in ["pixel", "vertex"] {
            let total = lines
                .iter()
                .find(|l| l.technique == *t && l.rate == rate && l.pass == "total")
                .unwrap_or_else(|| panic!("no total line for {t} per {rate}"));
            assert!(total.median_ms > 0.0 && total.median_ms.is_finite(), "{total:?}");
            assert!(total.p95_ms >= total.median_ms && total.fps > 0.0, "{total:?}");
            assert_eq!((total.width, total.height, total.frames), (16, 12, 2));
            // The bunny turns (`--animate`): the Monte Carlo reference rebuilds its triangle BVH on the host at
            // every new pose (new buffers and their staging copies); every real-time technique allocates nothing.
            if *t != "reference" {
                assert_eq!(total.steady_allocations, 0, "{t} per {rate}: a steady frame allocated device memory");
            }
            assert!(total.device_mib > 0.0);
            assert!(lines.iter().any(|l| l.technique == *t && l.rate == rate && l.pass.starts_with("shade/")));
        }
    }
    assert!(lines.iter().all(|l| l.commit == COMMIT && !l.adapter.is_empty() && !l.driver.is_empty()));
    let md = std::fs::read_to_string(out.join("bench.md")).unwrap();
    assert!(md.starts_with("Adapter: ") && md.contains(COMMIT), "{md}");
    assert_eq!(md.lines().filter(|l| l.starts_with("| bunny |")).count(), 2 * techniques.len(), "{md}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("bench.json")).unwrap()).unwrap();
    assert_eq!(json["rows"].as_array().unwrap().len(), 2 * techniques.len());
    assert_eq!(json["commit"], COMMIT);
    assert!(std::fs::read_to_string(out.join("bench-frames.svg")).unwrap().starts_with("<svg"));
    std::fs::remove_dir_all(&out).unwrap();
}

/// A technique spec that the technique refuses at creation (an option out of range) is listed under "Not
/// measured" with its reason, and the next technique still gets a renderer (here the refused one comes first).
#[test]
fn a_refused_technique_is_listed_and_the_rest_measured() {
    let out = std::env::temp_dir().join(format!("bench-refused-{}", std::process::id()));
    let o = out.to_str().unwrap();
    let args = [
        "--scene",
        "sphere",
        "--technique",
        "isg:patches=999",
        "--technique",
        "none",
        "--rate",
        "pixel",
        "--size",
        "8x6",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--out",
        o,
    ];
    let run = bench(&args);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    let md = std::fs::read_to_string(out.join("bench.md")).unwrap();
    assert!(md.contains("Not measured:") && md.contains("- sphere isg:patches=999 per pixel 8×6:"), "{md}");
    assert!(md.contains("patches"), "the reason names the option: {md}");
    assert_eq!(md.lines().filter(|l| l.starts_with("| sphere | none | pixel |")).count(), 1, "{md}");
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn bad_arguments_are_refused_before_the_gpu() {
    let missing = std::env::temp_dir().join("bench-no-such-earlier-run.csv");
    for (args, says) in [
        (vec!["--size", "0x12"], "each side must be 1..=16384"),
        (vec!["--size", "big"], "expected WIDTHxHEIGHT"),
        (vec!["--frames", "0"], "frames"),
        (vec!["--scene", "nosuch"], "nosuch"),
        (vec!["--rate", "sometimes"], "sometimes"),
        (vec!["--compare", missing.to_str().unwrap()], "bench-no-such-earlier-run.csv"),
        (vec!["--technique", "nosuch", "--size", "8x8"], "nosuch"),
    ] {
        let t0 = std::time::Instant::now();
        let run = bench(&args);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{args:?} was accepted");
        assert!(stderr.contains(says), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert!(t0.elapsed().as_secs_f64() < 30.0, "{args:?} took {:?}", t0.elapsed());
    }
}
