//! `compare --clip`: a short clip of a moving scene measured against references of the same frames
//! (lab::temporal, whose unit tests check the statistics on clips with known answers).

use std::process::Command;

#[test]
fn a_clip_reports_error_change_and_flicker_per_technique() {
    let out = std::env::temp_dir().join(format!("compare-clip-{}", std::process::id()));
    let run = Command::new(env!("CARGO_BIN_EXE_compare"))
        .args(["--scene", "bunny", "--technique", "none", "--technique", "isg", "--width", "16", "--height", "12"])
        .args(["--clip", "3", "--clip-step", "0.1", "--max-spp", "16", "--visibility", "spheres", "--frames", "1"])
        .arg("--out")
        .arg(&out)
        .output()
        .expect("compare");
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{}{stdout}", String::from_utf8_lossy(&run.stderr));
    assert!(
        stdout.contains("clip of 3 frames") && stdout.contains("| technique | vs spheres: mean error %"),
        "{stdout}"
    );
    for spec in ["none", "isg"] {
        let row = stdout.lines().find(|l| l.starts_with(&format!("| {spec} |"))).expect("a row per technique");
        let numbers: Vec<f64> = row.split('|').filter_map(|c| c.trim().split(' ').next()?.parse().ok()).collect();
        assert!(numbers.len() >= 8 && numbers.iter().all(|v| v.is_finite() && *v >= 0.0), "{row}");
    }
    let csv = std::fs::read_to_string(out.join("clip.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 2 * 3, "{csv}");
    assert!(std::fs::read_to_string(out.join("clip-error-spheres.svg")).unwrap().contains("<svg"));
    // Too short a clip, and a clip without a reference, are refused before any frame.
    let short = Command::new(env!("CARGO_BIN_EXE_compare")).args(["--clip", "2"]).output().unwrap();
    assert_eq!(short.status.code(), Some(2), "{}", String::from_utf8_lossy(&short.stderr));
    let _ = std::fs::remove_dir_all(&out);
}
