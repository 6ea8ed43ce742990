//! The tiny sweep run as jobs (docs/sweeps.md): `report --emit-jobs` writes one command per point, xargs -P 2 runs
//! them, a point killed mid-run leaves nothing under its key, two finished points lost are reported missing by
//! `report --merge` (which fails, or writes what there is with --allow-missing), re-running the job file (GNU
//! parallel) and one line through the Slurm array script (SLURM_ARRAY_TASK_ID set by hand) runs only those, and
//! the merge then gives the single-process run's tables: the same rows in the same order, the errors and
//! regions.csv identical (the references are seeded and converge against the same images), only times differ.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

const REPORT: &str = env!("CARGO_BIN_EXE_report");

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn sh(script: &str) -> Output {
    let out = Command::new("sh").arg("-c").arg(script).output().expect("sh");
    eprintln!("$ {script}\n{}", String::from_utf8_lossy(&out.stderr));
    out
}

fn ok(script: &str) -> String {
    let out = sh(script);
    assert!(out.status.success(), "{script}: {:?}", out.status);
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The finished point folders (not the temporary ones, which start with a dot).
fn finished(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir.join("points"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with('.'))
        .collect();
    v.sort();
    v
}

fn records(path: &Path) -> Vec<Vec<String>> {
    csv::ReaderBuilder::new()
        .has_headers(false)
        .from_path(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .records()
        .map(|r| r.unwrap().iter().map(str::to_string).collect())
        .collect()
}

#[test]
fn tiny_sweep_as_jobs_merges_to_the_single_process_tables() {
    let t = std::env::temp_dir().join(format!("report-jobs-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&t);
    std::fs::create_dir_all(&t).unwrap();
    let jobs = t.join("jobs.txt");
    let q = |p: &Path| format!("'{}'", p.display());

    // Emit: one reference job per scene, one technique job per scene × shading × technique.
    ok(&format!("{REPORT} --tiny --emit-jobs {}", q(&jobs)));
    let refs_file = PathBuf::from(format!("{}.references", jobs.display()));
    let refs = std::fs::read_to_string(&refs_file).unwrap();
    let techs = std::fs::read_to_string(&jobs).unwrap();
    let sweep = lab::report::load_sweep(&lab::report::default_config(), "tiny").unwrap();
    let points = lab::report::jobs::points(&sweep);
    assert_eq!(refs.lines().count(), sweep.scenes.len());
    assert_eq!(refs.lines().count() + techs.lines().count(), points.len());
    assert!(techs.lines().all(|l| l.contains(" --point ") && l.contains("--sweep tiny")), "{techs}");

    // The references first, then one technique point killed mid-run: nothing is left under its key.
    ok(&format!("xargs -d '\\n' -P 2 -I CMD sh -c CMD < {}", q(&refs_file)));
    assert_eq!(finished(&t).len(), sweep.scenes.len());
    let victim = techs.lines().nth(1).unwrap();
    let mut child = Command::new("sh").arg("-c").arg(format!("exec {victim}")).stderr(Stdio::null()).spawn().unwrap();
    let started = std::time::Instant::now();
    while !std::fs::read_dir(t.join("points"))
        .unwrap()
        .any(|e| e.unwrap().file_name().to_string_lossy().starts_with('.'))
    {
        assert!(started.elapsed().as_secs() < 120, "the point never started");
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    std::thread::sleep(std::time::Duration::from_millis(500));
    let killed_early = child.try_wait().unwrap().is_none();
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(killed_early, "the point finished before it could be killed: kill it sooner");
    assert_eq!(finished(&t).len(), sweep.scenes.len(), "a killed point must leave no finished folder");

    // Every technique point with xargs -P 2 (the killed one runs again from the start).
    ok(&format!("xargs -d '\\n' -P 2 -I CMD sh -c CMD < {}", q(&jobs)));
    let all = finished(&t);
    assert_eq!(all.len(), points.len());

    // Two finished points lost: the merge names them and fails; --allow-missing writes what there is.
    let lost = [&points[2], &points[points.len() - 1]];
    for p in lost {
        std::fs::remove_dir_all(lab::report::jobs::point_dir(&t, &sweep, p)).unwrap();
    }
    let merged = t.join("merged");
    let out = sh(&format!("{REPORT} --tiny --merge {} --out {}", q(&t), q(&merged)));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "a merge with missing points must fail");
    for p in lost {
        assert!(stderr.contains(&format!("missing: {}", p.spec())), "{stderr}");
    }
    assert!(stderr.contains(&format!("2 of {} points missing", points.len())), "{stderr}");
    ok(&format!("{REPORT} --tiny --merge {} --out {} --allow-missing", q(&t), q(&merged)));
    let partial = records(&merged.join("results.csv"));

    // Re-run: one lost point through the Slurm array script (its line, by hand), the other with GNU parallel
    // over the whole file, which skips every finished point.
    let line =
        techs.lines().position(|l| l.ends_with(&format!("'{}'", lost[0].spec())) || l.ends_with(&lost[0].spec()));
    let line = line.expect("the lost point's job line") + 1;
    let script = root().join("tools/sweeps/slurm-array.sh");
    ok(&format!("SLURM_ARRAY_TASK_ID={line} sh {} {}", q(&script), q(&jobs)));
    let none = sh(&format!("SLURM_ARRAY_TASK_ID=999 sh {} {}", q(&script), q(&jobs)));
    assert!(!none.status.success(), "a task id past the file's end must fail");
    let log = ok(&format!("parallel --will-cite -j 2 < {}", q(&jobs)));
    assert_eq!(log.matches("skipped").count(), techs.lines().count() - 1, "{log}");
    assert_eq!(finished(&t), all, "the same content keys again");
    ok(&format!("{REPORT} --tiny --merge {} --out {}", q(&t), q(&merged)));

    // The single-process run of the same sweep.
    let single = t.join("single");
    ok(&format!("{REPORT} --tiny --out {}", q(&single)));
    let a = records(&single.join("results.csv"));
    let b = records(&merged.join("results.csv"));
    assert_eq!(a.len(), b.len());
    assert_eq!(partial.len() + 2, b.len(), "the partial merge lacks the two lost technique points' rows only");
    let header = &a[0];
    let mut max_time_ratio = 1.0f64;
    for (ra, rb) in a.iter().zip(&b).skip(1) {
        assert_eq!(ra[..3], rb[..3], "the same rows in the same order");
        for (i, name) in header.iter().enumerate().skip(3) {
            if name.ends_with("_ms") {
                if let (Ok(x), Ok(y)) = (ra[i].parse::<f64>(), rb[i].parse::<f64>()) {
                    if x > 0.0 && y > 0.0 && !ra[2].starts_with("reference") {
                        max_time_ratio = max_time_ratio.max(x / y).max(y / x);
                    }
                }
            } else {
                assert_eq!(ra[i], rb[i], "{name} of {:?}: single {} vs jobs {}", &ra[..3], ra[i], rb[i]);
            }
        }
    }
    eprintln!("errors identical; shade/frame times differ by up to {max_time_ratio:.2}x (noise of separate runs)");
    let ra = std::fs::read_to_string(single.join("regions.csv")).unwrap();
    let rb = std::fs::read_to_string(merged.join("regions.csv")).unwrap();
    assert_eq!(ra, rb, "regions.csv identical");
    // Every image the README shows was copied from its point.
    let readme = std::fs::read_to_string(merged.join("README.md")).unwrap();
    let single_imgs = std::fs::read_dir(single.join("img")).unwrap().count();
    assert_eq!(std::fs::read_dir(merged.join("img")).unwrap().count(), single_imgs);
    assert!(readme.contains("img/"), "{readme}");
    let _ = std::fs::remove_dir_all(&t);
}
