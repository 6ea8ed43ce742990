//! The speed-against-error report (`cargo xtask report`): a sweep of scenes × technique specs × shading rates,
//! defined in one config file (tools/report/sweep.json), each measured for GPU time (median of ≥ 5 frames,
//! timestamp queries) and error against the converged Monte Carlo reference; plus the error decomposition of
//! SHEXP Fig. 7 on every scene with blocker spheres: proxy error (sphere-proxy reference against the triangle
//! reference) and technique error (technique against the sphere-proxy reference).
//!
//! Writes into the output folder: `results.csv` (one row per measurement, columns in [`CSV_HEADER`]),
//! `pareto.svg` (all scenes) and `pareto-<scene>.svg` (GPU ms against relative RMSE vs the triangle reference,
//! one series per technique and shading rate), `README.md` (tables, decomposition, thumbnails) and `img/*.png`
//! (renders, reference renders, error heat maps).

use crate::measure::{self, Errors, Measured, ReferenceImage, ReferenceRun};
use anyhow::{bail, Context, Result};
use engine::gpu::Gpu;
use engine::passes::shade::reference::Visibility;
use engine::renderer::RenderSettings;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The config file: named sweeps (`full` and `tiny` in the default file).
pub type SweepFile = BTreeMap<String, Sweep>;

/// One sweep.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sweep {
    pub width: u32,
    pub height: u32,
    /// Frames per technique; at least 5 are rendered (times are medians).
    pub frames: u32,
    /// The reference stops when its relative standard error is this fraction of the smallest measured error…
    pub fraction: f64,
    /// …or at this many samples per pixel.
    pub max_spp: u32,
    pub samples_per_frame: u32,
    /// The scene whose decomposition heads the README (every scene with spheres gets one in the CSV).
    #[serde(default)]
    pub decomposition_scene: Option<String>,
    pub scenes: Vec<SceneSpec>,
    /// Technique specs as `demo --technique` takes them (`none`, `isg:patches=8,K=4`, …).
    pub techniques: Vec<String>,
    /// `pixel` and/or `vertex`.
    pub shading: Vec<String>,
}

/// A scene of the sweep, optionally with material 0 overridden.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// A `demo --scene` name (a scene of the registry, demos/src/scenes).
    pub scene: String,
    /// Name in the results (default: the scene name).
    #[serde(default)]
    pub label: Option<String>,
    /// Blinn-Phong exponent of material 0.
    #[serde(default)]
    pub gloss: Option<f32>,
    /// k_s of material 0.
    #[serde(default)]
    pub ks: Option<f32>,
    /// Specular BRDF of material 0 as `demo --brdf` takes it (applied after gloss/ks).
    #[serde(default)]
    pub brdf: Option<String>,
    /// Shading rates for this scene instead of the sweep's.
    #[serde(default)]
    pub shading: Option<Vec<String>>,
}

impl SceneSpec {
    pub fn label(&self) -> &str {
        self.label.as_deref().unwrap_or(&self.scene)
    }
}

/// Read the config and pick sweep `name`.
pub fn load_sweep(path: &Path, name: &str) -> Result<Sweep> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut file: SweepFile = serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
    let names = file.keys().cloned().collect::<Vec<_>>().join(", ");
    let sweep = file.remove(name).with_context(|| format!("{}: no sweep '{name}' (has: {names})", path.display()))?;
    validate_techniques(&sweep).with_context(|| format!("{}: sweep '{name}'", path.display()))?;
    check_scenes(&sweep).with_context(|| format!("{}: sweep '{name}'", path.display()))?;
    Ok(sweep)
}

/// Every technique spec of a sweep parses against the technique registry (before any GPU work), and
/// the report rows are measured against a reference, so `reference` itself is not a sweep entry.
pub fn validate_techniques(sweep: &Sweep) -> Result<()> {
    for spec in &sweep.techniques {
        let (entry, _) = engine::passes::shade::parse_technique(spec)?;
        if entry.name == "reference" {
            bail!("technique '{spec}': the reference is measured against itself; leave it out of the sweep");
        }
    }
    Ok(())
}

/// Every scene of the sweep is registered (demos/src/scenes), so that a typo fails before hours of measuring.
pub fn check_scenes(sweep: &Sweep) -> Result<()> {
    for s in &sweep.scenes {
        crate::scenes::find(&s.scene).with_context(|| format!("scene '{}'", s.label()))?;
    }
    Ok(())
}

/// The default config: tools/report/sweep.json.
pub fn default_config() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tools/report/sweep.json")
}

/// One measured row of `results.csv`.
#[derive(Clone, Debug)]
pub struct Row {
    pub scene: String,
    /// `pixel`, `vertex`, or `-` for reference rows.
    pub shading: String,
    /// Technique spec, or `reference/spheres` / `reference/triangles`.
    pub technique: String,
    /// Median GPU ms of the technique's shading passes (for a reference: its GPU time to the samples it took).
    pub shade_ms: f64,
    /// Median GPU ms of the whole frame (references: NaN).
    pub frame_ms: f64,
    pub vs_triangles: Option<Errors>,
    pub vs_spheres: Option<Errors>,
}

/// Columns of `results.csv`; errors are relative RMSE in %, its value minus the reference's own noise, the
/// largest absolute channel error, mean FLIP; empty where a reference does not exist (no spheres).
pub const CSV_HEADER: &str = "scene,shading,technique,shade_ms,frame_ms,rmse_tri_pct,rmse_tri_debiased_pct,max_err_tri,flip_tri,rmse_sph_pct,rmse_sph_debiased_pct,max_err_sph,flip_sph";

/// The references of one scene.
pub struct SceneReferences {
    pub scene: String,
    pub triangles: ReferenceSummary,
    pub spheres: Option<ReferenceSummary>,
}

/// What the README says about a converged reference.
#[derive(Clone, Debug)]
pub struct ReferenceSummary {
    pub spp: u32,
    pub relative_stderr: f64,
    pub converged: bool,
    pub ms_per_sample: f64,
    pub seconds: f64,
}

impl From<&ReferenceImage> for ReferenceSummary {
    fn from(r: &ReferenceImage) -> Self {
        Self {
            spp: r.report.samples,
            relative_stderr: r.report.relative_stderr,
            converged: r.report.converged,
            ms_per_sample: r.ms_per_sample,
            seconds: r.seconds,
        }
    }
}

/// Everything a sweep measured.
pub struct Results {
    pub rows: Vec<Row>,
    pub references: Vec<SceneReferences>,
    /// Thumbnails per scene: (caption, path relative to the output folder).
    pub thumbnails: Vec<(String, Vec<(String, String)>)>,
}

fn shading_flag(s: &str) -> Result<bool> {
    match s {
        "pixel" => Ok(false),
        "vertex" => Ok(true),
        other => bail!("shading '{other}': use pixel or vertex"),
    }
}

/// Run the sweep, printing progress to stderr, and write every output into `out`.
pub fn run(gpu: &Gpu, sweep: &Sweep, out: &Path) -> Result<Results> {
    let img = out.join("img");
    std::fs::create_dir_all(&img).with_context(|| format!("creating {}", img.display()))?;
    let shadings = |spec: &SceneSpec| spec.shading.clone().unwrap_or_else(|| sweep.shading.clone());
    for s in sweep.scenes.iter().flat_map(shadings) {
        shading_flag(&s)?;
    }
    check_scenes(sweep)?;
    let (w, h) = (sweep.width, sweep.height);
    let frames = sweep.frames.max(5);
    let total: usize = sweep.scenes.iter().map(|s| shadings(s).len() * sweep.techniques.len()).sum();
    let mut done = 0;
    let t0 = std::time::Instant::now();
    let mut results = Results { rows: Vec::new(), references: Vec::new(), thumbnails: Vec::new() };
    for spec in &sweep.scenes {
        let label = spec.label().to_string();
        let mut scene = crate::scenes::build(&spec.scene, None)?;
        if let Some(m) = scene.materials.first_mut() {
            if let Some(s) = spec.gloss {
                m.shininess = s;
            }
            if let Some(k) = spec.ks {
                m.specular = glam::Vec3::splat(k);
            }
        }
        if let Some(b) = &spec.brdf {
            crate::apply_brdf(&mut scene, b)?;
        }
        let has_spheres = scene.blockers.spheres.iter().any(Option::is_some);
        let mut measured: Vec<(String, Measured)> = Vec::new();
        for shading in &shadings(spec) {
            for tech in &sweep.techniques {
                done += 1;
                let settings = RenderSettings {
                    width: w,
                    height: h,
                    technique: tech.clone(),
                    per_vertex: shading_flag(shading)?,
                    ..Default::default()
                };
                let m = measure::measure_technique(gpu, &scene, settings, frames)
                    .with_context(|| format!("{label} / {shading} / {tech}"))?;
                eprintln!(
                    "[{done}/{total}] {label} {shading} {tech}: shade {:.3} ms, frame {:.3} ms (median of {frames}) [{:.0} s]",
                    m.shade_ms,
                    m.frame_ms,
                    t0.elapsed().as_secs_f64()
                );
                measured.push((shading.clone(), m));
            }
        }
        let against: Vec<&[f32]> = measured.iter().map(|(_, m)| m.hdr.as_slice()).collect();
        let base = RenderSettings { width: w, height: h, ..Default::default() };
        let converge = |vis: Visibility| -> Result<ReferenceImage> {
            eprintln!(
                "{label}: converging the {} reference (≤ {} spp)...",
                measure::visibility_name(vis),
                sweep.max_spp
            );
            let run = ReferenceRun {
                visibility: vis,
                fraction: sweep.fraction,
                max_spp: sweep.max_spp,
                samples_per_frame: sweep.samples_per_frame,
            };
            let r = measure::converge_reference(gpu, &scene, &base, &run, &against)?;
            eprintln!(
                "{label}: {} reference: {} spp, relative standard error {:.3} % ({}converged) in {:.1} s",
                measure::visibility_name(vis),
                r.report.samples,
                100.0 * r.report.relative_stderr,
                if r.report.converged { "" } else { "not " },
                r.seconds
            );
            Ok(r)
        };
        let tri = converge(Visibility::Triangles)?;
        let sph = if has_spheres { Some(converge(Visibility::Spheres)?) } else { None };

        let stem = measure::file_stem(&label);
        let mut thumbs = Vec::new();
        let save = |thumbs: &mut Vec<(String, String)>, name: String, caption: String, ldr: &[u8]| -> Result<()> {
            engine::output::write_png(&img.join(&name), w, h, ldr)?;
            thumbs.push((caption, format!("img/{name}")));
            Ok(())
        };
        save(&mut thumbs, format!("{stem}-reference-triangles.png"), "reference (triangles)".into(), &tri.ldr)?;
        if let Some(s) = &sph {
            save(&mut thumbs, format!("{stem}-reference-spheres.png"), "reference (spheres)".into(), &s.ldr)?;
            let heat = format!("{stem}-proxy-error.png");
            measure::write_heatmap(&img.join(&heat), &s.hdr, &tri, w, h)?;
            thumbs.push(("proxy error |spheres − triangles|".into(), format!("img/{heat}")));
        }
        for (shading, m) in &measured {
            let name = format!("{stem}-{shading}-{}", measure::file_stem(&m.spec));
            save(&mut thumbs, format!("{name}.png"), format!("{} ({shading})", m.spec), &m.ldr)?;
            measure::write_heatmap(&img.join(format!("{name}-error.png")), &m.hdr, &tri, w, h)?;
            thumbs.push((format!("{} ({shading}) error vs triangles", m.spec), format!("img/{name}-error.png")));
            results.rows.push(Row {
                scene: label.clone(),
                shading: shading.clone(),
                technique: m.spec.clone(),
                shade_ms: m.shade_ms,
                frame_ms: m.frame_ms,
                vs_triangles: Some(measure::errors(&m.hdr, &m.ldr, &tri, w, h)),
                vs_spheres: sph.as_ref().map(|s| measure::errors(&m.hdr, &m.ldr, s, w, h)),
            });
        }
        // The references as rows: the sphere-proxy reference against the triangles is the proxy error.
        // Between two references both noises are in the measured RMSE: the debiased value removes both.
        let between = |a: &ReferenceImage, b: &ReferenceImage| {
            let mut e = measure::errors(&a.hdr, &a.ldr, b, w, h);
            let noise2 = (100.0 * a.report.relative_stderr).powi(2) + (100.0 * b.report.relative_stderr).powi(2);
            e.debiased = (e.rmse * e.rmse - noise2).max(0.0).sqrt();
            e
        };
        if let Some(s) = &sph {
            results.rows.push(Row {
                scene: label.clone(),
                shading: "pixel".into(),
                technique: "reference/spheres".into(),
                shade_ms: s.ms_per_sample * s.report.samples as f64,
                frame_ms: f64::NAN,
                vs_triangles: Some(between(s, &tri)),
                vs_spheres: None,
            });
        }
        results.rows.push(Row {
            scene: label.clone(),
            shading: "pixel".into(),
            technique: "reference/triangles".into(),
            shade_ms: tri.ms_per_sample * tri.report.samples as f64,
            frame_ms: f64::NAN,
            vs_triangles: None,
            vs_spheres: sph.as_ref().map(|s| between(&tri, s)),
        });
        results.references.push(SceneReferences {
            scene: label.clone(),
            triangles: (&tri).into(),
            spheres: sph.as_ref().map(Into::into),
        });
        results.thumbnails.push((label, thumbs));
    }
    write_csv(&out.join("results.csv"), &results.rows)?;
    write_plots(out, &results.rows)?;
    let readme = readme(gpu, sweep, &results);
    std::fs::write(out.join("README.md"), readme).with_context(|| format!("writing {}/README.md", out.display()))?;
    eprintln!(
        "wrote {}/results.csv, pareto*.svg, README.md and img/ in {:.0} s",
        out.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(results)
}

fn num(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.6}")
    } else {
        String::new()
    }
}

fn errs(e: &Option<Errors>) -> String {
    match e {
        Some(e) => format!("{},{},{},{}", num(e.rmse), num(e.debiased), num(e.max_abs), num(e.flip)),
        None => ",,,".into(),
    }
}

pub fn write_csv(path: &Path, rows: &[Row]) -> Result<()> {
    let mut s = format!("{CSV_HEADER}\n");
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{}",
            r.scene,
            r.shading,
            // Specs hold commas (isg:patches=8,K=4): quote.
            format_args!("\"{}\"", r.technique.replace('"', "\"\"")),
            num(r.shade_ms),
            num(r.frame_ms),
            errs(&r.vs_triangles),
            errs(&r.vs_spheres)
        );
    }
    std::fs::write(path, s).with_context(|| format!("writing {}", path.display()))
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

fn write_plots(out: &Path, rows: &[Row]) -> Result<()> {
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

fn readme(gpu: &Gpu, sweep: &Sweep, res: &Results) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Speed against error\n");
    let _ = writeln!(
        s,
        "Generated by `cargo xtask report` on **{}**, {}×{}, times = median GPU ms of {} frames (timestamp queries), \
         errors over covered pixels against the Monte Carlo reference converged until its relative standard error \
         is {} of the smallest measured error (at most {} spp). Data: [results.csv](results.csv).\n",
        gpu.info.name,
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
            "| shading | technique | shade ms | frame ms | rel. RMSE % vs triangles | minus ref. noise | max error | FLIP |"
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
                 ({:.2} % without the two references' noise; FLIP {:.4}). Technique error = technique against the \
                 sphere-proxy reference.\n",
                p.rmse, p.debiased, p.flip
            );
            let _ = writeln!(
                s,
                "| shading | technique | total (vs triangles) % | proxy % | technique (vs spheres) % | minus ref. noise % | technique FLIP |"
            );
            let _ = writeln!(s, "|---|---|---|---|---|---|---|");
            for r in rows.iter().filter(|r| !r.technique.starts_with("reference")) {
                if let (Some(t), Some(sp)) = (&r.vs_triangles, &r.vs_spheres) {
                    let _ = writeln!(
                        s,
                        "| {} | `{}` | {} | {} | {} | {} | {:.4} |",
                        r.shading,
                        r.technique,
                        f2(t.rmse),
                        f2(p.rmse),
                        f2(sp.rmse),
                        f2(sp.debiased),
                        sp.flip
                    );
                }
            }
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
