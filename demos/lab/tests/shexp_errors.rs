//! `shexp_errors` (SHEXP's error decomposition per order) on a tiny frame: it runs, prints both tables for the
//! orders asked, writes its CSV and plot, and its numbers hang together: the exact exp* and HYB of the same log
//! vector are close, the visibility-truncation stage is closer to the truth under the order-n lighting than the
//! log-space stage (the logs' truncation adds error), and bad orders are refused before any GPU work.

use std::process::Command;

fn run(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_shexp_errors")).args(args).output().expect("running shexp_errors")
}

/// The numbers of the table row for order `n` that starts with `| n |` (parenthesised ones included).
fn row(stdout: &str, n: usize, table: usize) -> Vec<f64> {
    let line = stdout
        .lines()
        .filter(|l| l.starts_with(&format!("| {n} |")))
        .nth(table)
        .unwrap_or_else(|| panic!("no row for n = {n} in table {table}:\n{stdout}"));
    line.split(['|', '(', ')', ' ']).filter_map(|t| t.parse::<f64>().ok()).skip(1).collect()
}

#[test]
fn decomposition_runs_and_its_stages_hang_together() {
    let out = std::env::temp_dir().join(format!("shexp-errors-{}", std::process::id()));
    let o = out.to_str().unwrap();
    let r = run(&["--scene", "bunny", "--width", "24", "--height", "18", "--step", "1", "--orders", "4", "--out", o]);
    let stdout = String::from_utf8_lossy(&r.stdout);
    assert!(r.status.success(), "{}\n{stdout}", String::from_utf8_lossy(&r.stderr));
    // Stages: lighting, then (vs truth, vs E_L) for visibility truncation, log space, HYB, OL, PS*-2.
    let stages = row(&stdout, 4, 0);
    assert_eq!(stages.len(), 11, "{stdout}");
    assert!(stages.iter().all(|v| v.is_finite() && *v >= 0.0), "{stages:?}");
    let (vis_trunc, log_space) = (stages[2], stages[4]);
    assert!(vis_trunc < log_space, "the logs' truncation should add error: {stages:?}");
    let exp = row(&stdout, 4, 1);
    assert_eq!(exp.len(), 3, "{stdout}");
    assert!(exp[0] < 5.0 && exp[2] < 5.0, "HYB and PS*-2 should be within a few % of exact exp*: {exp:?}");
    for f in ["errors.csv", "errors.svg"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn per_vertex_receivers_run() {
    let r = run(&[
        "--scene",
        "bunny",
        "--per-vertex",
        "--step",
        "16",
        "--orders",
        "3",
        "--out",
        &std::env::temp_dir().join(format!("shexp-errors-v-{}", std::process::id())).to_string_lossy(),
    ]);
    let stdout = String::from_utf8_lossy(&r.stdout);
    assert!(r.status.success(), "{}\n{stdout}", String::from_utf8_lossy(&r.stderr));
    assert!(stdout.contains("per vertex"), "{stdout}");
    let stages = row(&stdout, 3, 0);
    assert_eq!(stages.len(), 11, "{stdout}");
    assert!(stages.iter().all(|v| v.is_finite() && *v >= 0.0 && *v < 100.0), "{stages:?}");
}

#[test]
fn bad_arguments_are_refused() {
    for (args, needle) in [
        (&["--orders", "2"][..], "not an SH order in 3..=8"),
        (&["--orders", "9"][..], "not an SH order in 3..=8"),
        (&["--step", "0"][..], "must be positive"),
        (&["--width", "0"][..], "must be positive"),
        (&["--env", "/no/such/sky.exr"][..], "sky.exr"),
        (&["--env", "x.exr", "--smooth-sky"][..], "cannot be used with"),
    ] {
        let r = run(args);
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert!(matches!(r.status.code(), Some(1 | 2)), "{args:?}: {:?}\n{stderr}", r.status);
        assert!(stderr.contains(needle) && !stderr.contains("panicked"), "{args:?}: {stderr}");
    }
}
