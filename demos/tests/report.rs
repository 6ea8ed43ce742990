//! `cargo xtask report --tiny`: the tiny sweep of tools/report/sweep.json runs end to end on lavapipe and writes a
//! results.csv with every scene × shading × technique plus the reference rows (proxy error on the bunny), Pareto
//! plots that are well-formed SVG, and a README whose tables and thumbnails point at files that exist.

use demos::report::{self, CSV_HEADER};

/// Split a CSV line, honouring double quotes.
fn cells(line: &str) -> Vec<String> {
    let (mut out, mut cur, mut quoted) = (Vec::new(), String::new(), false);
    for c in line.chars() {
        match c {
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(std::mem::take(&mut cur)),
            c => cur.push(c),
        }
    }
    out.push(cur);
    out
}

#[test]
fn tiny_sweep_runs_end_to_end() {
    let sweep = report::load_sweep(&report::default_config(), "tiny").expect("tiny sweep in tools/report/sweep.json");
    let out = std::env::temp_dir().join(format!("report-tiny-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    // The validation layer required, leaks and validation errors fail the test (even without shutdown).
    let gpu = engine::gpu::testing::test_gpu().expect("gpu");
    let res = report::run(&gpu, &sweep, &out);
    gpu.shutdown().expect("clean teardown");
    let res = res.expect("tiny sweep");

    let csv = std::fs::read_to_string(out.join("results.csv")).expect("results.csv");
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some(CSV_HEADER));
    let columns = CSV_HEADER.split(',').count();
    let rows: Vec<Vec<String>> = lines.map(cells).collect();
    assert!(rows.iter().all(|r| r.len() == columns), "{rows:?}");
    let num = |r: &Vec<String>, name: &str| -> Option<f64> {
        let i = CSV_HEADER.split(',').position(|c| c == name).unwrap();
        (!r[i].is_empty()).then(|| r[i].parse().unwrap_or_else(|e| panic!("{name} = '{}': {e}", r[i])))
    };
    for spec in &sweep.scenes {
        let shadings = spec.shading.clone().unwrap_or_else(|| sweep.shading.clone());
        for shading in &shadings {
            for tech in &sweep.techniques {
                let row = rows
                    .iter()
                    .find(|r| r[0] == spec.label() && &r[1] == shading && &r[2] == tech)
                    .unwrap_or_else(|| panic!("no row for {} {shading} {tech}", spec.label()));
                let ms = num(row, "shade_ms").expect("time");
                assert!(ms.is_finite() && ms > 0.0, "{row:?}");
                let rmse = num(row, "rmse_tri_pct").expect("error vs triangles");
                assert!(rmse.is_finite() && rmse > 0.0, "{row:?}");
                let flip = num(row, "flip_tri").unwrap();
                assert!((0.0..=1.0).contains(&flip), "{row:?}");
            }
        }
        // Every scene has a triangle reference row; scenes with spheres a sphere-proxy row with the proxy error.
        assert!(rows.iter().any(|r| r[0] == spec.label() && r[2] == "reference/triangles"));
    }
    let proxy = rows.iter().find(|r| r[0] == "bunny" && r[2] == "reference/spheres").expect("bunny proxy error row");
    let p = num(proxy, "rmse_tri_pct").expect("proxy error");
    assert!(p > 0.0 && p < 100.0, "proxy error {p}");
    assert_eq!(rows.len(), res.rows.len());

    for svg in ["pareto.svg", "pareto-bunny.svg", "pareto-arm.svg"] {
        let text = std::fs::read_to_string(out.join(svg)).unwrap_or_else(|e| panic!("{svg}: {e}"));
        roxmltree::Document::parse(&text).unwrap_or_else(|e| panic!("{svg}: {e}"));
        assert!(text.contains(">none (pixel)<") && text.contains(">isg (pixel)<"), "{svg}: series per technique");
    }
    let readme = std::fs::read_to_string(out.join("README.md")).expect("README.md");
    assert!(readme.contains("Error decomposition"), "decomposition section");
    let mut images = 0;
    for part in readme.split("](").skip(1) {
        let target = &part[..part.find(')').unwrap()];
        assert!(out.join(target).is_file(), "README links to missing {target}");
        images += target.ends_with(".png") as usize;
    }
    assert!(images >= 6, "thumbnails in the README: {images}");
    let png = engine::output::read_png(&out.join("img/bunny-pixel-none.png")).expect("thumbnail PNG");
    assert_eq!((png.0, png.1), (sweep.width, sweep.height));
    let _ = std::fs::remove_dir_all(&out);
}
