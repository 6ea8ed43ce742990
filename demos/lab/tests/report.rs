//! `cargo xtask report --tiny`: the tiny sweep of tools/report/sweep.json runs end to end on lavapipe and writes a
//! results.csv with every scene × shading × technique plus the reference rows (proxy error on the bunny), Pareto
//! plots that are well-formed SVG, and a README whose tables and thumbnails point at files that exist; the error
//! by region and lighting (regions.csv) partitions the covered pixels, upper + lower = whole holds for the
//! references within their noise, and the proxy error's noise is that of the difference of references that share
//! their random numbers (well below their own noises added).

use lab::report::{self, CSV_HEADER, REGIONS_HEADER};

/// The records of a CSV file (header first), read with the `csv` crate the report writes it with.
fn records(text: &str) -> Vec<Vec<String>> {
    csv::ReaderBuilder::new()
        .has_headers(false)
        .from_reader(text.as_bytes())
        .records()
        .map(|r| r.expect("a CSV record").iter().map(str::to_string).collect())
        .collect()
}

#[test]
fn tiny_sweep_runs_end_to_end() {
    let sweep = report::load_sweep(&report::default_config(), "tiny").expect("tiny sweep in tools/report/sweep.json");
    let out = std::env::temp_dir().join(format!("report-tiny-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    // The validation layer required, leaks and validation errors fail the test (even without shutdown).
    let gpu = engine::gpu::testing::test_gpu().expect("gpu");
    let res = report::run(&gpu, &sweep, &out, "cargo xtask report --tiny");
    gpu.shutdown().expect("clean teardown");
    let res = res.expect("tiny sweep");

    let csv = std::fs::read_to_string(out.join("results.csv")).expect("results.csv");
    let mut rows = records(&csv);
    assert_eq!(rows.remove(0).join(","), CSV_HEADER);
    let columns = CSV_HEADER.split(',').count();
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
    // Same seeds: the difference of the references is far less noisy than their own noises added.
    let noise = num(proxy, "noise_tri_pct").expect("noise of the proxy difference");
    let refs = res.references.iter().find(|r| r.scene == "bunny").unwrap();
    let independent = 100.0
        * (refs.triangles.relative_stderr.powi(2) + refs.spheres.as_ref().unwrap().relative_stderr.powi(2)).sqrt();
    assert!(noise > 0.0 && noise < 0.5 * independent, "proxy noise {noise} % vs independent {independent} %");
    let debiased = num(proxy, "rmse_tri_debiased_pct").unwrap();
    assert!((debiased - (p * p - noise * noise).max(0.0).sqrt()).abs() < 1e-4, "{proxy:?}");
    // Representation error on the scenes with spheres.
    for r in rows.iter().filter(|r| r[0] == "bunny" && !r[2].starts_with("reference")) {
        let e = num(r, "rmse_repr_pct").expect("representation error");
        assert!(e.is_finite() && e >= 0.0, "{r:?}");
    }

    let regions = std::fs::read_to_string(out.join("regions.csv")).expect("regions.csv");
    let mut region_rows = records(&regions);
    assert_eq!(region_rows.remove(0).join(","), REGIONS_HEADER);
    assert_eq!(region_rows.len(), res.regions.len());
    let col = |name: &str| REGIONS_HEADER.split(',').position(|c| c == name).unwrap();
    let f = |r: &Vec<String>, name: &str| -> f64 { r[col(name)].parse().unwrap_or(f64::NAN) };
    // The bunny scene's objects, found in the G-buffer, partition its covered pixels: their error shares add up.
    for image in ["none", "reference/spheres"] {
        for lighting in ["whole", "upper", "lower"] {
            let of = |region: &str| {
                region_rows
                    .iter()
                    .find(|r| {
                        r[0] == "bunny"
                            && r[col("image")] == image
                            && r[col("region")] == region
                            && r[col("lighting")] == lighting
                            && r[col("against")] == "triangles"
                    })
                    .unwrap_or_else(|| panic!("no regions.csv row for {image} {region} {lighting}"))
            };
            let (all, bunny, ground) = (of("all"), of("bunny"), of("ground"));
            assert_eq!(f(all, "error_share_pct"), 100.0);
            let sum = f(bunny, "error_share_pct") + f(ground, "error_share_pct");
            // The ground under the lower hemisphere only is black in both images: 0/0 shares.
            if f(all, "rmse_pct") > 0.0 {
                assert!((sum - 100.0).abs() < 1e-6, "{image} {lighting}: shares add to {sum}");
            }
            if lighting == "whole" {
                assert_eq!(f(all, "rmse_pct"), f(all, "of_whole_pct"));
            }
        }
    }
    // Upper + lower = whole for the references, within their noise (rendering is linear in the lighting).
    for c in res.linearity.iter().filter(|c| c.image.starts_with("reference")) {
        assert!(c.holds() && c.noise > 0.0, "{c:?}");
    }
    assert!(res.linearity.iter().any(|c| c.scene == "bunny" && c.image == "reference/spheres"));
    let svg = std::fs::read_to_string(out.join("decomposition-bunny.svg")).expect("decomposition plot");
    roxmltree::Document::parse(&svg).expect("decomposition-bunny.svg");
    assert!(svg.contains("proxy (spheres vs triangles)") && svg.contains("representation"), "decomposition series");

    for svg in ["pareto.svg", "pareto-bunny.svg", "pareto-arm.svg"] {
        let text = std::fs::read_to_string(out.join(svg)).unwrap_or_else(|e| panic!("{svg}: {e}"));
        roxmltree::Document::parse(&text).unwrap_or_else(|e| panic!("{svg}: {e}"));
        assert!(text.contains(">none (pixel)<") && text.contains(">isg (pixel)<"), "{svg}: series per technique");
    }
    let readme = std::fs::read_to_string(out.join("README.md")).expect("README.md");
    for section in ["Error decomposition", "Error by region and lighting", "Upper + lower hemisphere = whole"] {
        assert!(readme.contains(section), "README section {section}");
    }
    let mut images = 0;
    for part in readme.split("](").skip(1) {
        let target = &part[..part.find(')').unwrap()];
        assert!(out.join(target).is_file(), "README links to missing {target}");
        images += target.ends_with(".png") as usize;
    }
    assert!(images >= 6, "thumbnails in the README: {images}");
    let png = engine::output::read_png(&out.join("img/bunny-pixel-none.png")).expect("thumbnail PNG");
    assert_eq!((png.0, png.1), (sweep.width, sweep.height));

    // The results page (what `--sweep readme` writes into docs/results) from the same results, so that the
    // generator is exercised on every run, not only at the 45-minute regeneration: every file, a self-contained
    // page, the hero picture, and the summary spliced into a README between its markers.
    // Into the same folder, as `report` does: the page inlines the Pareto plots written there.
    let site_dir = out.clone();
    let readme_path = out.join("MANUAL.md");
    let marked = format!("# before\n\n{}\nstale\n{}\n\nafter\n", lab::report::page::BEGIN, lab::report::page::END);
    std::fs::write(&readme_path, &marked).unwrap();
    let site = report::Site {
        out: site_dir.to_string_lossy().into(),
        hero_scene: "bunny".into(),
        hero_techniques: sweep.techniques.clone(),
        summary_techniques: sweep.techniques.clone(),
        readme: Some(readme_path.to_string_lossy().into()),
    };
    lab::report::page::write(&site_dir, &sweep, &site, &res, "lavapipe", "cargo xtask report --tiny").expect("page");
    for f in ["index.html", "README.md", "summary.md", "summary.svg", "hero.png"] {
        assert!(site_dir.join(f).is_file(), "the results page lacks {f}");
    }
    let html = std::fs::read_to_string(site_dir.join("index.html")).unwrap();
    assert!(html.contains("data:image/png;base64,"), "images are embedded");
    for external in ["<script src", "<link ", "@import", "url(http"] {
        assert!(!html.contains(external), "index.html loads something from outside: {external}");
    }
    let hero = engine::output::read_png(&site_dir.join("hero.png")).expect("hero PNG");
    assert_eq!(hero.1, 3 * sweep.height, "the hero picture is scaled 3x");
    let summary = std::fs::read_to_string(site_dir.join("summary.md")).unwrap();
    let manual = std::fs::read_to_string(&readme_path).unwrap();
    assert_eq!(lab::report::page::block_of(&manual), Some(summary.trim_end()), "{manual}");
    assert!(manual.starts_with("# before") && manual.ends_with("after\n") && !manual.contains("stale"), "{manual}");
    let _ = std::fs::remove_dir_all(&out);
}

// Every named sweep of the shipped config loads: its technique specs parse against the registry (a typo in an
// option of the `full` sweep would otherwise surface only hours into `cargo xtask report`), its scenes exist.
#[test]
fn every_shipped_sweep_loads() {
    let path = report::default_config();
    let text = std::fs::read_to_string(&path).expect("tools/report/sweep.json");
    let names: Vec<String> = text
        .lines()
        .filter_map(|l| l.strip_prefix("  \"").and_then(|r| r.split_once("\": {")).map(|(name, _)| name.to_string()))
        .collect();
    assert!(names.len() >= 2 && names.iter().any(|n| n == "full"), "sweep names: {names:?}");
    for name in &names {
        report::load_sweep(&path, name).unwrap_or_else(|e| panic!("sweep '{name}': {e:#}"));
    }
}

// `pixel_techniques` are measured per pixel only, after `techniques`, and are checked against the registry like
// them: a bad spec there fails at load, before any GPU work.
#[test]
fn pixel_only_techniques_are_measured_per_pixel_and_validated() {
    let dir = std::env::temp_dir().join(format!("report-pixel-only-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("sweep.json");
    let sweep = |extra: &str| {
        format!(
            r#"{{"s": {{"width": 8, "height": 6, "frames": 1, "fraction": 0.1, "max_spp": 16, "samples_per_frame": 16,
                "scenes": [{{"scene": "bunny"}}], "techniques": ["none", "isg"], "pixel_techniques": [{extra}],
                "shading": ["pixel", "vertex"]}}}}"#
        )
    };
    std::fs::write(&path, sweep(r#""shexp:env_lights=off""#)).unwrap();
    let s = report::load_sweep(&path, "s").expect("sweep loads");
    let at = |rate: &str| s.techniques_at(rate).cloned().collect::<Vec<_>>();
    assert_eq!(at("pixel"), ["none", "isg", "shexp:env_lights=off"]);
    assert_eq!(at("vertex"), ["none", "isg"]);
    std::fs::write(&path, sweep(r#""shexp:env_lights=maybe""#)).unwrap();
    let err = format!("{:#}", report::load_sweep(&path, "s").unwrap_err());
    assert!(err.contains("env_lights"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_report_sweep_refuses_unregistered_scenes() {
    let path = std::env::temp_dir().join(format!("sweep-scenes-{}.json", std::process::id()));
    let sweep = |scene: &str| {
        format!(
            r#"{{"s": {{"width": 8, "height": 6, "frames": 1, "fraction": 0.5, "max_spp": 4, "samples_per_frame": 4,
               "scenes": [{{"scene": "bunny"}}, {{"scene": "{scene}", "label": "mine"}}], "techniques": ["none"],
               "shading": ["pixel"]}}}}"#
        )
    };
    std::fs::write(&path, sweep("teapot")).unwrap();
    let err = format!("{:#}", lab::report::load_sweep(&path, "s").unwrap_err());
    assert!(
        err.contains("teapot") && err.contains("mine") && scenes::SCENES.iter().all(|s| err.contains(s.name)),
        "{err}"
    );
    std::fs::write(&path, sweep("lamp")).unwrap();
    lab::report::load_sweep(&path, "s").expect("registered scenes load");
    let _ = std::fs::remove_file(&path);
}
