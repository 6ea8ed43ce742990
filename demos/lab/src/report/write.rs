//! The sweep's plain files: results.csv, regions.csv, the Pareto and decomposition plots, and the README of a
//! sweep without a site.

use super::results::*;
use super::sweep::*;
use crate::measure::{self, Errors};
use anyhow::{Context, Result};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

pub fn write_regions_csv(path: &Path, rows: &[RegionRow]) -> Result<()> {
    write_records(
        path,
        REGIONS_HEADER,
        rows.iter().map(|r| {
            vec![
                r.scene.clone(),
                r.shading.clone(),
                r.image.clone(),
                r.region.clone(),
                r.lighting.to_string(),
                r.against.to_string(),
                num(r.rmse),
                num(r.debiased),
                num(r.noise),
                num(r.of_whole),
                num(r.of_whole_debiased),
                num(r.error_share),
                num(r.radiance_share),
            ]
        }),
    )
}

/// A CSV file of `header` and `records` (the `csv` crate quotes the fields that need it: technique specs hold
/// commas, `isg:patches=8,K=4`).
fn write_records(path: &Path, header: &str, records: impl Iterator<Item = Vec<String>>) -> Result<()> {
    let write = || -> Result<()> {
        let mut w = csv::Writer::from_path(path)?;
        w.write_record(header.split(','))?;
        for r in records {
            w.write_record(&r)?;
        }
        w.flush()?;
        Ok(())
    };
    write().with_context(|| format!("writing {}", path.display()))
}

pub(super) fn num(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.6}")
    } else {
        String::new()
    }
}

pub(super) fn errs(e: &Option<Errors>) -> [String; 4] {
    match e {
        Some(e) => [num(e.rmse), num(e.debiased), num(e.max_abs), num(e.flip)],
        None => Default::default(),
    }
}

pub fn write_csv(path: &Path, rows: &[Row]) -> Result<()> {
    write_records(
        path,
        CSV_HEADER,
        rows.iter().map(|r| {
            let mut rec =
                vec![r.scene.clone(), r.shading.clone(), r.technique.clone(), num(r.shade_ms), num(r.frame_ms)];
            rec.extend(errs(&r.vs_triangles));
            rec.extend(errs(&r.vs_spheres));
            rec.push(r.vs_triangles.map_or(String::new(), |e| num(e.noise)));
            rec.push(r.vs_spheres.map_or(String::new(), |e| num(e.noise)));
            rec.push(r.representation.map_or(String::new(), |e| num(e.rmse)));
            rec.push(r.representation.map_or(String::new(), |e| num(e.debiased)));
            rec
        }),
    )
}

/// Technique family of a spec: the spec without its swept sizes `patches` and `K`
/// (`isg:patches=8,diffuse=sg` → `isg:diffuse=sg`), so that a family's points trace a speed-error curve.
fn family(spec: &str) -> String {
    let (name, opts) = spec.split_once(':').unwrap_or((spec, ""));
    let kept: Vec<&str> =
        opts.split(',').filter(|kv| !kv.is_empty() && !kv.starts_with("patches=") && !kv.starts_with("K=")).collect();
    if kept.is_empty() {
        name.to_string()
    } else {
        format!("{name}:{}", kept.join(","))
    }
}

/// Against which reference a plot measures.
#[derive(Clone, Copy)]
enum Against {
    Triangles,
    Spheres,
}

fn pareto(title: &str, rows: &[&Row], against: Against) -> plot::Plot {
    let err = |r: &Row| match against {
        Against::Triangles => r.vs_triangles,
        Against::Spheres => r.vs_spheres,
    };
    let mut series: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    for r in rows.iter().filter(|r| !r.technique.starts_with("reference")) {
        if let Some(e) = err(r) {
            series.entry(format!("{} ({})", family(&r.technique), r.shading)).or_default().push((r.shade_ms, e.rmse));
        }
    }
    let y_label = match against {
        Against::Triangles => "relative RMSE % vs triangle reference",
        Against::Spheres => "relative RMSE % vs sphere-proxy reference",
    };
    let mut p = plot::Plot::new(title)
        .size(820.0, 500.0)
        .x_axis("GPU ms (shading passes, median)", plot::Scale::Log10)
        .y_axis(y_label, plot::Scale::Log10)
        .legend(plot::Legend::TopRight);
    for (name, mut pts) in series {
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        p = p.series(plot::Series::new(name, pts, plot::Style::LineMarkers));
    }
    // Against triangles, the sphere-proxy reference's error is the floor any sphere technique can reach.
    for r in rows.iter().filter(|r| r.technique == "reference/spheres") {
        if let (Against::Triangles, Some(e)) = (against, &r.vs_triangles) {
            p = p.series(
                plot::Series::new(
                    format!("proxy error floor ({})", r.scene),
                    vec![(r.shade_ms, e.rmse)],
                    plot::Style::Scatter,
                )
                .color("#000000"),
            );
        }
    }
    p
}

/// The error decomposition of docs/design.md §4 against cost: per technique and shading, the total error (vs the
/// triangle reference), the technique error (vs the sphere-proxy reference) and the representation error (no
/// blockers vs the unoccluded reference), all minus noise; the proxy error as a dashed horizontal line.
fn decomposition_plot(title: &str, rows: &[&Row]) -> Option<plot::Plot> {
    let proxy = rows.iter().find(|r| r.technique == "reference/spheres").and_then(|r| r.vs_triangles)?;
    let techniques: Vec<&&Row> = rows.iter().filter(|r| !r.technique.starts_with("reference")).collect();
    let mut p = plot::Plot::new(title)
        .size(820.0, 500.0)
        .x_axis("GPU ms (shading passes, median)", plot::Scale::Log10)
        .y_axis("relative RMSE % minus noise", plot::Scale::Log10)
        .legend(plot::Legend::TopRight);
    let mut shadings: Vec<&str> = techniques.iter().map(|r| r.shading.as_str()).collect();
    shadings.sort();
    shadings.dedup();
    type Part = fn(&Row) -> Option<Errors>;
    let parts: [(&str, Part); 3] = [
        ("total (vs triangles)", |r| r.vs_triangles),
        ("technique (vs spheres)", |r| r.vs_spheres),
        ("representation (no blockers vs unoccluded)", |r| r.representation),
    ];
    for (name, part) in parts {
        for shading in &shadings {
            let mut pts: Vec<(f64, f64)> = techniques
                .iter()
                .filter(|r| r.shading == *shading)
                .filter_map(|r| part(r).map(|e| (r.shade_ms, e.debiased)))
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            if !pts.is_empty() {
                p = p.series(plot::Series::new(format!("{name} ({shading})"), pts, plot::Style::Scatter));
            }
        }
    }
    let xs = techniques.iter().map(|r| r.shade_ms).filter(|x| x.is_finite() && *x > 0.0);
    let (lo, hi) = xs.fold((f64::INFINITY, 0.0f64), |(l, h), x| (l.min(x), h.max(x)));
    if lo.is_finite() {
        p = p.series(
            plot::Series::new(
                format!("proxy (spheres vs triangles): {:.2} %", proxy.debiased),
                vec![(lo, proxy.debiased), (hi.max(lo * 1.01), proxy.debiased)],
                plot::Style::Line,
            )
            .color("#000000")
            .dashed(),
        );
    }
    Some(p)
}

pub(super) fn write_plots(out: &Path, rows: &[Row]) -> Result<()> {
    let all: Vec<&Row> = rows.iter().collect();
    pareto("time against error, all scenes", &all, Against::Triangles).write(out.join("pareto.svg"))?;
    let mut scenes: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    for s in scenes {
        let rs: Vec<&Row> = rows.iter().filter(|r| r.scene == s).collect();
        let stem = measure::file_stem(s);
        pareto(&format!("time against error: {s}"), &rs, Against::Triangles)
            .write(out.join(format!("pareto-{stem}.svg")))?;
        if rs.iter().any(|r| r.vs_spheres.is_some()) {
            pareto(&format!("time against error vs the sphere proxy: {s}"), &rs, Against::Spheres)
                .write(out.join(format!("pareto-{stem}-spheres.svg")))?;
        }
        if let Some(p) = decomposition_plot(&format!("error decomposition: {s}"), &rs) {
            p.write(out.join(format!("decomposition-{stem}.svg")))?;
        }
    }
    Ok(())
}

fn f2(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.2}")
    } else {
        "–".into()
    }
}

pub(super) fn readme(device: &str, sweep: &Sweep, res: &Results) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Speed against error\n");
    let _ = writeln!(
        s,
        "Generated by `cargo xtask report` on **{}**, {}×{}, times = median GPU ms of {} frames (timestamp queries), \
         errors over covered pixels against the Monte Carlo reference converged until its relative standard error \
         is {} of the smallest measured error (at most {} spp). Data: [results.csv](results.csv), by region and \
         lighting [regions.csv](regions.csv).\n\n\
         \"Minus noise\" removes the noise of the difference itself: every reference keeps two independent \
         half-sample means (its even and its odd frames), and Σ (D_a − D_b)²/4 over pixels and channels (D the \
         difference image, D_a and D_b its halves) estimates the variance of the difference. The sphere-proxy and \
         triangle references share their random numbers (same seed, frames and samples), so their difference is \
         far less noisy than the two noises added.\n",
        device,
        sweep.width,
        sweep.height,
        sweep.frames.max(5),
        sweep.fraction,
        sweep.max_spp
    );
    let _ = writeln!(s, "![time against error](pareto.svg)\n");
    let _ = writeln!(s, "## References\n");
    let _ = writeln!(s, "| scene | visibility | spp | rel. std. error % | converged | GPU ms per sample | wall s |");
    let _ = writeln!(s, "|---|---|---|---|---|---|---|");
    for r in &res.references {
        for (vis, x) in [("triangles", Some(&r.triangles)), ("spheres", r.spheres.as_ref())] {
            if let Some(x) = x {
                let _ = writeln!(
                    s,
                    "| {} | {vis} | {} | {:.3} | {} | {:.3} | {:.1} |",
                    r.scene,
                    x.spp,
                    100.0 * x.relative_stderr,
                    if x.converged { "yes" } else { "no" },
                    x.ms_per_sample,
                    x.seconds
                );
            }
        }
    }
    let decomposition: Vec<&str> = match &sweep.decomposition_scene {
        Some(d) => vec![d.as_str()],
        None => Vec::new(),
    };
    for scene in res.references.iter().map(|r| r.scene.as_str()) {
        let rows: Vec<&Row> = res.rows.iter().filter(|r| r.scene == scene).collect();
        let _ = writeln!(s, "\n## {scene}\n");
        let _ = writeln!(s, "![{scene}](pareto-{}.svg)\n", measure::file_stem(scene));
        if res.rows.iter().any(|r| r.scene == *scene && r.vs_spheres.is_some()) {
            let _ = writeln!(s, "![{scene} vs the sphere proxy](pareto-{}-spheres.svg)\n", measure::file_stem(scene));
        }
        let _ = writeln!(
            s,
            "| shading | technique | shade ms | frame ms | rel. RMSE % vs triangles | minus noise | max error | FLIP |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|");
        for r in &rows {
            if let Some(e) = &r.vs_triangles {
                let _ = writeln!(
                    s,
                    "| {} | `{}` | {} | {} | {} | {} | {:.3} | {:.4} |",
                    r.shading,
                    r.technique,
                    f2(r.shade_ms),
                    f2(r.frame_ms),
                    f2(e.rmse),
                    f2(e.debiased),
                    e.max_abs,
                    e.flip
                );
            }
        }
        let proxy = rows.iter().find(|r| r.technique == "reference/spheres").and_then(|r| r.vs_triangles);
        if let Some(p) = proxy {
            let head = if decomposition.contains(&scene) { " (SHEXP Fig. 7)" } else { "" };
            let _ = writeln!(s, "\n### Error decomposition{head}\n");
            let _ = writeln!(
                s,
                "Proxy error = the sphere-proxy reference against the triangle reference: **{:.2} %** relative RMSE \
                 ({:.2} % minus the noise of their difference, which is {:.2} %; FLIP {:.4}). Technique error = \
                 technique against the sphere-proxy reference. Representation error (docs/design.md §4) = the technique \
                 on the scene without blockers against the unoccluded reference (its fit of lighting and BRDF). \
                 Each as relative RMSE % / minus noise.\n",
                p.rmse, p.debiased, p.noise, p.flip
            );
            let _ = writeln!(s, "![decomposition of {scene}](decomposition-{}.svg)\n", measure::file_stem(scene));
            let _ = writeln!(
                s,
                "| shading | technique | total (vs triangles) % | proxy % | technique (vs spheres) % | representation % | technique FLIP |"
            );
            let _ = writeln!(s, "|---|---|---|---|---|---|---|");
            let pair = |e: Option<Errors>| e.map_or("–".into(), |e| format!("{} / {}", f2(e.rmse), f2(e.debiased)));
            for r in rows.iter().filter(|r| !r.technique.starts_with("reference")) {
                if let (Some(_), Some(sp)) = (&r.vs_triangles, &r.vs_spheres) {
                    let _ = writeln!(
                        s,
                        "| {} | `{}` | {} | {} | {} | {} | {:.4} |",
                        r.shading,
                        r.technique,
                        pair(r.vs_triangles),
                        pair(Some(p)),
                        pair(r.vs_spheres),
                        pair(r.representation),
                        sp.flip
                    );
                }
            }
        }
        let checks: Vec<&LinearityCheck> = res.linearity.iter().filter(|c| c.scene == *scene).collect();
        if !checks.is_empty() {
            let _ = writeln!(s, "\n### Upper + lower hemisphere = whole lighting\n");
            let _ = writeln!(
                s,
                "Each image rendered again under the environment above the ground's horizon only (world +Y up; texels \
                 split by their centre direction) and below it only (and, in scenes with sphere lights, the lights \
                 alone, which the hemispheres leave out); rendering is linear in the lighting, so the parts add up \
                 to the whole. The check: relative RMSE of the sum of the parts − whole against the whole, beside \
                 the noise of that combination (estimated from the halves; 0 for the exact technique renders, whose \
                 lighting fits need not be linear).\n"
            );
            let _ = writeln!(s, "| image | (sum of the parts − whole) % of whole | noise % | verdict |");
            let _ = writeln!(s, "|---|---|---|---|");
            for c in checks {
                let verdict = if c.noise > 0.0 && !c.holds() { format!("**{}**", c.verdict()) } else { c.verdict() };
                let _ = writeln!(s, "| `{}` | {:.3} | {:.3} | {verdict} |", c.image, c.rmse, c.noise);
            }
        }
        let region_rows: Vec<&RegionRow> = res.regions.iter().filter(|r| r.scene == *scene).collect();
        if !region_rows.is_empty() {
            let _ = writeln!(s, "\n### Error by region and lighting\n");
            let _ = writeln!(
                s,
                "Regions: every object's pixels, exactly from the G-buffer (a frame with one material per instance). \
                 Errors as relative RMSE % / minus noise, relative to the reference under the same lighting over the \
                 region; \"of whole\": the same error relative to the whole-lighting reference over the region (the \
                 upper and lower parts of the whole's error); error share: the region's part of the image's squared \
                 error; radiance share: the image's radiance in the region under this lighting over that under the \
                 whole.\n"
            );
            // Long (images × regions × lightings × references): folded, the CSV has the same rows.
            let _ = writeln!(s, "<details><summary>{} rows (also in regions.csv)</summary>\n", region_rows.len());
            let _ = writeln!(
                s,
                "| image | shading | vs | region | lighting | rel. RMSE % | of whole % | error share % | radiance share % |"
            );
            let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
            for r in region_rows {
                let _ = writeln!(
                    s,
                    "| `{}` | {} | {} | {} | {} | {} / {} | {} / {} | {} | {} |",
                    r.image,
                    r.shading,
                    r.against,
                    r.region,
                    r.lighting,
                    f2(r.rmse),
                    f2(r.debiased),
                    f2(r.of_whole),
                    f2(r.of_whole_debiased),
                    f2(r.error_share),
                    f2(r.radiance_share)
                );
            }
            let _ = writeln!(s, "\n</details>");
        }
        if let Some((_, thumbs)) = res.thumbnails.iter().find(|(l, _)| l == scene) {
            let _ = writeln!(s, "\n### Images\n");
            let _ = writeln!(s, "| image | |\n|---|---|");
            for (caption, path) in thumbs {
                let _ = writeln!(s, "| {caption} | ![{caption}]({path}) |");
            }
        }
    }
    s
}
