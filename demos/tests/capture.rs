//! `demo --capture N`: the binary renders a few frames of the skinned-arm scene (every pass runs: skin, blocker
//! spheres and BVH, G-buffer, shading, tone mapping) and writes CSV, JSON and SVG that parse and hold every pass
//! for every frame.

use std::path::PathBuf;
use std::process::Command;

const FRAMES: usize = 4;

fn out_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("demo-capture-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn capture_writes_every_pass_of_every_frame() {
    let out = out_dir("arm");
    let status = Command::new(env!("CARGO_BIN_EXE_demo"))
        .args(["--scene", "arm", "--technique", "none", "--width", "48", "--height", "32", "--name", "t"])
        .args(["--capture", &FRAMES.to_string()])
        .arg("--out")
        .arg(&out)
        .output()
        .expect("running demo");
    let stdout = String::from_utf8_lossy(&status.stdout);
    assert!(status.status.success(), "demo failed: {}\n{stdout}", String::from_utf8_lossy(&status.stderr));
    let expected = ["skin", "blocker_spheres", "blocker_bvh", "gbuffer", "shade/none", "tonemap"];

    // CSV: header frame, passes..., total; FRAMES rows of numbers; total = sum of the passes.
    let csv = std::fs::read_to_string(out.join("capture/t.csv")).expect("csv written");
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    assert_eq!(header.first(), Some(&"frame"));
    assert_eq!(header.last(), Some(&"total"));
    for pass in expected {
        assert!(header.contains(&pass), "pass {pass} missing from CSV header {header:?}");
    }
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            l.split(',').map(|c| c.parse::<f64>().unwrap_or_else(|e| panic!("cell '{c}' in '{l}': {e}"))).collect()
        })
        .collect();
    assert_eq!(rows.len(), FRAMES);
    for (f, row) in rows.iter().enumerate() {
        assert_eq!(row.len(), header.len());
        assert_eq!(row[0], f as f64);
        let passes = &row[1..row.len() - 1];
        assert!(passes.iter().all(|&ms| ms.is_finite() && ms >= 0.0), "frame {f}: {row:?}");
        let sum: f64 = passes.iter().sum();
        assert!((sum - row[row.len() - 1]).abs() < 1e-5 * (1.0 + sum), "frame {f}: total {row:?}");
    }

    // JSON: the same passes, FRAMES times each, and order statistics consistent with them.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("capture/t.json")).expect("json written"))
            .expect("JSON parses");
    assert_eq!(json["frames"], FRAMES);
    assert_eq!(json["scene"], "arm");
    assert_eq!((json["width"].as_u64(), json["height"].as_u64()), (Some(48), Some(32)));
    let passes = json["passes"].as_array().expect("passes array");
    let names: Vec<&str> = passes.iter().map(|p| p["name"].as_str().expect("name")).collect();
    assert_eq!(names, header[1..header.len() - 1].to_vec(), "JSON and CSV list the same passes");
    for (p, pass) in passes.iter().enumerate() {
        let ms: Vec<f64> = pass["ms"].as_array().expect("ms").iter().map(|v| v.as_f64().expect("number")).collect();
        assert_eq!(ms.len(), FRAMES);
        for (f, v) in ms.iter().enumerate() {
            assert!(
                (v - rows[f][p + 1]).abs() < 1e-5,
                "pass {} frame {f}: JSON {v} vs CSV {}",
                names[p],
                rows[f][p + 1]
            );
        }
        let (med, p95, max) =
            (pass["median"].as_f64().unwrap(), pass["p95"].as_f64().unwrap(), pass["max"].as_f64().unwrap());
        let lo = ms.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(lo <= med && med <= p95 && p95 <= max, "{}: {med} {p95} {max}", names[p]);
        assert_eq!(max, ms.iter().copied().fold(0.0, f64::max));
    }
    assert_eq!(json["total"]["ms"].as_array().map(Vec::len), Some(FRAMES));

    // The plot: an SVG with one legend entry per pass.
    let svg = std::fs::read_to_string(out.join("capture/t.svg")).expect("svg written");
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    roxmltree::Document::parse(&svg).expect("SVG is well-formed XML");
    for pass in expected {
        assert!(svg.contains(&format!(">{pass}<")), "plot lacks a legend entry for {pass}");
    }
    // The printed summary names every pass.
    for pass in expected {
        assert!(stdout.lines().any(|l| l.starts_with(pass)), "summary lacks {pass}:\n{stdout}");
    }
    let _ = std::fs::remove_dir_all(&out);
}
