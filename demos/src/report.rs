//! The speed-against-error report (`cargo xtask report`): a sweep of scenes × technique specs × shading rates,
//! defined in one config file (tools/report/sweep.json), each measured for GPU time (median of ≥ 5 frames,
//! timestamp queries) and error against the converged Monte Carlo reference; plus the error decomposition of
//! docs/design.md §4 (SHEXP Fig. 7) on every scene with blocker spheres: proxy error (sphere-proxy reference against
//! the triangle reference), technique error (technique against the sphere-proxy reference) and representation
//! error (technique on the scene without blockers against the unoccluded reference); and the error split by
//! region (each object's pixels, exactly from the G-buffer) and by lighting (the environment's upper and lower
//! hemisphere rendered separately, with upper + lower = whole checked against the noise).
//!
//! Every "minus noise" figure removes the noise of the difference itself, estimated from the two independent
//! half-sample means each reference keeps (`engine::converge::combination_noise_sq`): the references share their
//! random numbers, so their difference is far less noisy than their own noises added.
//!
//! Writes into the output folder: `results.csv` (one row per measurement, columns in [`CSV_HEADER`]),
//! `regions.csv` (error by region and lighting, [`REGIONS_HEADER`]), `pareto.svg` (all scenes) and
//! `pareto-<scene>.svg` (GPU ms against relative RMSE vs the triangle reference, one series per technique and
//! shading rate), `decomposition-<scene>.svg` (proxy, technique and representation error against GPU ms),
//! `README.md` (tables, decomposition, thumbnails) and `img/*.png` (renders, reference renders, error heat maps).

use crate::measure::{self, Difference, Errors, Lighting, Measured, ReferenceImage, ReferenceRun, Region};
use anyhow::{bail, Context, Result};
use engine::converge::{combination_noise_sq, HalfMeans};
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
    /// Also render every image under the environment's upper and lower hemisphere only (above and below the
    /// ground's horizon, world +Y up; without the sphere lights, which are then a third part), for the error by
    /// lighting (default: true; costs two (three) more references per visibility and frames per technique).
    #[serde(default = "yes")]
    pub split_lighting: bool,
    /// Also measure every technique on the scene without blockers against the unoccluded reference (the
    /// representation error; default: true; costs one more reference and frame per technique).
    #[serde(default = "yes")]
    pub representation: bool,
    /// Keep the converged references in this folder (relative to the workspace root), keyed by everything that
    /// determines them, and reuse them on the next run (`measure::cached_reference`). With a cache, set a small
    /// `fraction` so that `max_spp` decides: the fraction rule converges against the techniques of the first run.
    #[serde(default)]
    pub reference_cache: Option<String>,
    /// Write the results page (index.html, README.md, the summary) for this sweep ([`Site`]).
    #[serde(default)]
    pub site: Option<Site>,
    pub scenes: Vec<SceneSpec>,
    /// Technique specs as `demo --technique` takes them (`none`, `isg:patches=8,K=4`, …).
    pub techniques: Vec<String>,
    /// More specs measured per pixel only, after `techniques` (variants whose per-vertex figures would add
    /// little for the time they take on lavapipe: the environment split on and off, a higher SH order).
    #[serde(default)]
    pub pixel_techniques: Vec<String>,
    /// `pixel` and/or `vertex`.
    pub shading: Vec<String>,
}

impl Sweep {
    /// The technique specs measured at shading rate `shading`: every one of `techniques`, and per pixel also
    /// `pixel_techniques`.
    pub fn techniques_at(&self, shading: &str) -> impl Iterator<Item = &String> {
        let extra = if shading == "pixel" { &self.pixel_techniques[..] } else { &[] };
        self.techniques.iter().chain(extra)
    }
}

fn yes() -> bool {
    true
}

/// The results page of a sweep (docs/results: see [`crate::results_page`]).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Site {
    /// Output folder, relative to the workspace root (the default `--out` of this sweep).
    pub out: String,
    /// The scene of the first-screen picture…
    pub hero_scene: String,
    /// …and its techniques, left to right, per pixel; the triangle reference follows them.
    pub hero_techniques: Vec<String>,
    /// The techniques of the summary table and plot (per pixel), usually each technique at its defaults.
    pub summary_techniques: Vec<String>,
    /// A Markdown file (relative to the workspace root) whose block between [`crate::results_page::BEGIN`] and
    /// [`crate::results_page::END`] is replaced by the summary (the project's README.md).
    #[serde(default)]
    pub readme: Option<String>,
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
    /// Specular BRDF of the glossy materials as `demo --brdf` takes it (applied after gloss/ks).
    #[serde(default)]
    pub brdf: Option<String>,
    /// Shading rates for this scene instead of the sweep's.
    #[serde(default)]
    pub shading: Option<Vec<String>>,
    /// Measure the scene as its motion poses it at this time (s), frozen (`measure::freeze_at`, as `compare
    /// --time`): a piece mid-slide, the cloth landed, the club raised.
    #[serde(default)]
    pub time: Option<f32>,
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
    for spec in sweep.techniques.iter().chain(&sweep.pixel_techniques) {
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

/// The workspace root (where the sweep's relative folders start).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
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
    /// Representation error (docs/design.md §4): the technique on the scene without blockers against the unoccluded
    /// reference (scenes with blocker spheres only).
    pub representation: Option<Errors>,
}

/// Columns of `results.csv`; errors are relative RMSE in %, its value minus the noise of the difference
/// (estimated from the difference itself: [`measure::difference`]), the largest absolute channel error, mean
/// FLIP; then the noise removed (in % of the reference), and the representation error (no blockers against the
/// unoccluded reference); empty where a reference does not exist (no spheres).
pub const CSV_HEADER: &str = "scene,shading,technique,shade_ms,frame_ms,rmse_tri_pct,rmse_tri_debiased_pct,max_err_tri,flip_tri,rmse_sph_pct,rmse_sph_debiased_pct,max_err_sph,flip_sph,noise_tri_pct,noise_sph_pct,rmse_repr_pct,rmse_repr_debiased_pct";

/// Columns of `regions.csv`: one row per scene × image × region × lighting × reference. `rmse_pct` is
/// relative to the reference under the same lighting over the region; `of_whole_pct` the same error relative
/// to the whole-lighting reference over the region (so that the upper and lower parts compare with the whole);
/// `error_share_pct` the region's part of the image's squared error (same lighting and reference);
/// `radiance_share_pct` the image's radiance in the region under this lighting over that under the whole.
pub const REGIONS_HEADER: &str = "scene,shading,image,region,lighting,against,rmse_pct,debiased_pct,noise_pct,of_whole_pct,of_whole_debiased_pct,error_share_pct,radiance_share_pct";

/// One row of `regions.csv` ([`REGIONS_HEADER`]).
#[derive(Clone, Debug)]
pub struct RegionRow {
    pub scene: String,
    pub shading: String,
    pub image: String,
    pub region: String,
    pub lighting: &'static str,
    pub against: &'static str,
    pub rmse: f64,
    pub debiased: f64,
    pub noise: f64,
    pub of_whole: f64,
    pub of_whole_debiased: f64,
    pub error_share: f64,
    pub radiance_share: f64,
}

/// Upper + lower against whole for one image: the relative RMSE of (upper + lower − whole) against the whole,
/// and the noise of that combination estimated from the halves (0 for a technique: its renders are exact).
#[derive(Clone, Debug)]
pub struct LinearityCheck {
    pub scene: String,
    pub image: String,
    pub rmse: f64,
    pub noise: f64,
}

impl LinearityCheck {
    /// Upper + lower equals the whole within the noise (1.5× its estimate, or 1e-3 % for exact images).
    pub fn holds(&self) -> bool {
        self.rmse <= 1.5 * self.noise + 1e-3
    }

    /// The verdict in words: a noisy image (a reference) is linear within its noise or not; an exact render
    /// (a technique, whose fit of the lighting need not be linear) is linear or off by its RMSE.
    pub fn verdict(&self) -> String {
        match (self.noise > 0.0, self.holds()) {
            (true, true) => "linear within noise".into(),
            (true, false) => "NOT linear within noise".into(),
            (false, true) => "exact render: linear".into(),
            (false, false) => format!("exact render: not linear in the lighting by {:.3} %", self.rmse),
        }
    }
}

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

/// One image of a scene on the results page, PNG-encoded, with its error heat maps.
#[derive(Clone, Debug)]
pub struct PageImage {
    /// `spec (shading)` for a technique, `reference (triangles)` / `reference (spheres)` for a reference.
    pub label: String,
    /// The technique spec (`none`, `isg:diffuse=ratio`, …) or `reference/<visibility>`.
    pub spec: String,
    /// `pixel`, `vertex`, or `reference`.
    pub group: String,
    /// The tone-mapped RGBA8 image and its PNG file.
    pub ldr: Vec<u8>,
    pub png: Vec<u8>,
    /// |image − triangle reference| and |image − sphere-proxy reference| ([`measure::heatmap`]).
    pub heat_triangles: Option<Vec<u8>>,
    pub heat_spheres: Option<Vec<u8>>,
}

/// The images of one scene of the sweep.
#[derive(Clone, Debug)]
pub struct SceneImages {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub images: Vec<PageImage>,
}

/// Everything a sweep measured.
pub struct Results {
    /// Every scene's images (for the results page), in sweep order.
    pub images: Vec<SceneImages>,
    pub rows: Vec<Row>,
    pub references: Vec<SceneReferences>,
    /// Thumbnails per scene: (caption, path relative to the output folder).
    pub thumbnails: Vec<(String, Vec<(String, String)>)>,
    /// The error by region and lighting (`regions.csv`).
    pub regions: Vec<RegionRow>,
    /// Upper + lower = whole, per scene and image (with `split_lighting`).
    pub linearity: Vec<LinearityCheck>,
}

/// The images of one scene under one lighting.
struct LightingSet {
    lighting: Lighting,
    tri: ReferenceImage,
    sph: Option<ReferenceImage>,
    /// Per measured technique (same order), RGB.
    techniques: Vec<Vec<[f32; 3]>>,
}

/// Σ over the mask and RGB of the values (radiance) and of their squares.
fn sums(rgb: &[[f32; 3]], mask: &[bool]) -> (f64, f64) {
    let (mut sum, mut sq) = (0.0, 0.0);
    for (p, _) in rgb.iter().zip(mask).filter(|(_, m)| **m) {
        for v in p {
            sum += *v as f64;
            sq += (*v as f64) * (*v as f64);
        }
    }
    (sum, sq)
}

fn share(part: f64, whole: f64) -> f64 {
    if whole != 0.0 {
        100.0 * part / whole
    } else {
        f64::NAN
    }
}

fn shading_flag(s: &str) -> Result<bool> {
    match s {
        "pixel" => Ok(false),
        "vertex" => Ok(true),
        other => bail!("shading '{other}': use pixel or vertex"),
    }
}

/// Run the sweep, printing progress to stderr, and write every output into `out`; `command` is the command line
/// that ran it (the results page names it).
pub fn run(gpu: &Gpu, sweep: &Sweep, out: &Path, command: &str) -> Result<Results> {
    let img = out.join("img");
    std::fs::create_dir_all(if sweep.site.is_none() { &img } else { out })
        .with_context(|| format!("creating {}", img.display()))?;
    let shadings = |spec: &SceneSpec| spec.shading.clone().unwrap_or_else(|| sweep.shading.clone());
    for s in sweep.scenes.iter().flat_map(shadings) {
        shading_flag(&s)?;
    }
    check_scenes(sweep)?;
    let (w, h) = (sweep.width, sweep.height);
    let frames = sweep.frames.max(5);
    let total: usize = sweep.scenes.iter().flat_map(shadings).map(|s| sweep.techniques_at(&s).count()).sum();
    let mut done = 0;
    let t0 = std::time::Instant::now();
    let cache = sweep.reference_cache.as_ref().map(|d| workspace_root().join(d));
    let pixels = (w * h) as usize;
    // A results page embeds its images; the plain report writes them into img/.
    let write_images = sweep.site.is_none();
    let settings = |shading: &str, tech: &str| -> Result<RenderSettings> {
        Ok(RenderSettings {
            width: w,
            height: h,
            technique: tech.to_string(),
            per_vertex: shading_flag(shading)?,
            ..Default::default()
        })
    };
    let mut results = Results {
        images: Vec::new(),
        rows: Vec::new(),
        references: Vec::new(),
        thumbnails: Vec::new(),
        regions: Vec::new(),
        linearity: Vec::new(),
    };
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
        if let Some(t) = spec.time {
            scene = measure::freeze_at(gpu, &spec.scene, scene, t).with_context(|| format!("{label} at {t} s"))?;
        }
        let has_spheres = scene.blockers.spheres.iter().any(Option::is_some);
        let mut measured: Vec<(String, Measured)> = Vec::new();
        for shading in &shadings(spec) {
            for tech in sweep.techniques_at(shading) {
                done += 1;
                let m = measure::measure_technique(gpu, &scene, settings(shading, tech)?, frames)
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
            let key = format!(
                "{}|{:?}|{:?}|{:?}|{:?}|{w}x{h}|{}|{}|{}|{}",
                spec.scene,
                spec.gloss,
                spec.ks,
                spec.brdf,
                spec.time.map(f32::to_bits),
                measure::visibility_name(vis),
                sweep.fraction,
                sweep.max_spp,
                sweep.samples_per_frame
            );
            let r =
                measure::cached_reference(cache.as_deref(), &measure::file_stem(&label), &key, vis, pixels, || {
                    measure::converge_reference(gpu, &scene, &base, &run, &against)
                })?;
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
        let mut page = SceneImages { scene: label.clone(), width: w, height: h, images: Vec::new() };
        let keep =
            |thumbs: &mut Vec<(String, String)>, name: String, caption: String, rgba: &[u8]| -> Result<Vec<u8>> {
                let png = engine::output::encode_png(w, h, rgba).map_err(anyhow::Error::msg)?;
                if write_images {
                    let path = img.join(&name);
                    std::fs::write(&path, &png).with_context(|| format!("writing {}", path.display()))?;
                    thumbs.push((caption, format!("img/{name}")));
                }
                Ok(png)
            };
        let png =
            keep(&mut thumbs, format!("{stem}-reference-triangles.png"), "reference (triangles)".into(), &tri.ldr)?;
        page.images.push(PageImage {
            label: "reference (triangles)".into(),
            spec: "reference/triangles".into(),
            group: "reference".into(),
            ldr: tri.ldr.clone(),
            png,
            heat_triangles: None,
            heat_spheres: None,
        });
        if let Some(s) = &sph {
            let png = keep(&mut thumbs, format!("{stem}-reference-spheres.png"), "reference (spheres)".into(), &s.ldr)?;
            let heat = keep(
                &mut thumbs,
                format!("{stem}-proxy-error.png"),
                "proxy error |spheres − triangles|".into(),
                &measure::heatmap(&s.hdr, &tri, w, h),
            )?;
            page.images.push(PageImage {
                label: "reference (spheres)".into(),
                spec: "reference/spheres".into(),
                group: "reference".into(),
                ldr: s.ldr.clone(),
                png,
                heat_triangles: Some(heat),
                heat_spheres: None,
            });
        }
        for (shading, m) in &measured {
            let name = format!("{stem}-{shading}-{}", measure::file_stem(&m.spec));
            let label = format!("{} ({shading})", m.spec);
            let png = keep(&mut thumbs, format!("{name}.png"), label.clone(), &m.ldr)?;
            let heat_triangles = keep(
                &mut thumbs,
                format!("{name}-error.png"),
                format!("{label} error vs triangles"),
                &measure::heatmap(&m.hdr, &tri, w, h),
            )?;
            let heat_spheres = match &sph {
                Some(s) => Some(
                    engine::output::encode_png(w, h, &measure::heatmap(&m.hdr, s, w, h)).map_err(anyhow::Error::msg)?,
                ),
                None => None,
            };
            page.images.push(PageImage {
                label,
                spec: m.spec.clone(),
                group: shading.clone(),
                ldr: m.ldr.clone(),
                png,
                heat_triangles: Some(heat_triangles),
                heat_spheres,
            });
            results.rows.push(Row {
                scene: page.scene.clone(),
                shading: shading.clone(),
                technique: m.spec.clone(),
                shade_ms: m.shade_ms,
                frame_ms: m.frame_ms,
                vs_triangles: Some(measure::errors(&m.hdr, &m.ldr, &tri, w, h)),
                vs_spheres: sph.as_ref().map(|s| measure::errors(&m.hdr, &m.ldr, s, w, h)),
                representation: None,
            });
        }
        results.images.push(page);
        // The references as rows: the sphere-proxy reference against the triangles is the proxy error. Both
        // share their random numbers (same seed and frames), so the noise of their difference is estimated from
        // the difference's own halves, not as the two noises added.
        let between =
            |a: &ReferenceImage, b: &ReferenceImage| measure::errors_of(&a.hdr, Some(&a.halves), &a.ldr, b, w, h);

        // Representation error (docs/design.md §4): every technique on the scene without blockers against the
        // unoccluded reference; what is left is the technique's fit of the lighting and BRDF.
        let mut representation: Vec<Option<Errors>> = vec![None; measured.len()];
        if has_spheres && sweep.representation {
            let free = measure::without_blockers(&scene);
            let mut images = Vec::new();
            for (shading, m) in &measured {
                images.push(measure::measure_technique(gpu, &free, settings(shading, &m.spec)?, 1)?);
            }
            eprintln!("{label}: converging the unoccluded reference (≤ {} spp)...", sweep.max_spp);
            let run = ReferenceRun {
                visibility: Visibility::Unoccluded,
                fraction: sweep.fraction,
                max_spp: sweep.max_spp,
                samples_per_frame: sweep.samples_per_frame,
            };
            let against: Vec<&[f32]> = images.iter().map(|m| m.hdr.as_slice()).collect();
            let unocc = measure::converge_reference(gpu, &free, &base, &run, &against)?;
            for (slot, m) in representation.iter_mut().zip(&images) {
                *slot = Some(measure::errors(&m.hdr, &m.ldr, &unocc, w, h));
            }
        }
        for (row, e) in results.rows.iter_mut().rev().take(measured.len()).rev().zip(&representation) {
            row.representation = *e;
        }
        if let Some(s) = &sph {
            results.rows.push(Row {
                scene: label.clone(),
                shading: "pixel".into(),
                technique: "reference/spheres".into(),
                shade_ms: s.ms_per_sample * s.report.samples as f64,
                frame_ms: f64::NAN,
                vs_triangles: Some(between(s, &tri)),
                vs_spheres: None,
                representation: None,
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
            representation: None,
        });

        // The error by region (objects, found exactly in the G-buffer) and by lighting (upper and lower
        // hemisphere of the environment, rendered separately: rendering is linear in the lighting).
        let regions = measure::object_regions(gpu, &scene, w, h)?;
        let mut sets = vec![LightingSet {
            lighting: Lighting::Whole,
            techniques: measured.iter().map(|(_, m)| measure::rgb_items(&m.hdr)).collect(),
            tri,
            sph,
        }];
        if sweep.split_lighting {
            // The environment's hemispheres without the sphere lights, and the lights alone (when there are
            // any), so that the parts add up to the whole.
            let mut parts = vec![Lighting::Upper, Lighting::Lower];
            if !scene.lights.is_empty() {
                parts.push(Lighting::Lights);
            }
            for lighting in parts {
                let lit = measure::lit_by(&scene, lighting);
                let mut techniques = Vec::new();
                for (shading, m) in &measured {
                    let img = measure::measure_technique(gpu, &lit, settings(shading, &m.spec)?, 1)?;
                    techniques.push(measure::rgb_items(&img.hdr));
                }
                // Sample for sample with the whole-lighting references (same seed, frames and count).
                let at = |r: &ReferenceImage| -> Result<ReferenceImage> {
                    eprintln!(
                        "{label}: the {} reference, lighting: {} ({} spp)...",
                        measure::visibility_name(r.visibility),
                        lighting.name(),
                        r.report.samples
                    );
                    measure::reference_at(gpu, &lit, &base, r.visibility, r.report.samples, sweep.samples_per_frame)
                };
                let tri = at(&sets[0].tri)?;
                let sph = sets[0].sph.as_ref().map(at).transpose()?;
                sets.push(LightingSet { lighting, tri, sph, techniques });
            }
            linearity(&label, &measured, &sets, &mut results.linearity);
        }
        region_rows(&label, &measured, &regions, &sets, &mut results.regions);
        let (tri, sph) = {
            let whole = sets.swap_remove(0);
            (whole.tri, whole.sph)
        };

        results.references.push(SceneReferences {
            scene: label.clone(),
            triangles: (&tri).into(),
            spheres: sph.as_ref().map(Into::into),
        });
        results.thumbnails.push((label, thumbs));
    }
    write_csv(&out.join("results.csv"), &results.rows)?;
    write_regions_csv(&out.join("regions.csv"), &results.regions)?;
    write_plots(out, &results.rows)?;
    match &sweep.site {
        Some(site) => crate::results_page::write(out, sweep, site, &results, &gpu.info.name, command)?,
        None => {
            let readme = readme(gpu, sweep, &results);
            std::fs::write(out.join("README.md"), readme)
                .with_context(|| format!("writing {}/README.md", out.display()))?;
        }
    }
    eprintln!(
        "wrote {}/results.csv, regions.csv, pareto*.svg, decomposition*.svg, README.md{} in {:.0} s",
        out.display(),
        if write_images { " and img/" } else { ", index.html and the summary" },
        t0.elapsed().as_secs_f64()
    );
    Ok(results)
}

/// Upper + lower (+ lights) − whole for every reference and technique of a scene ([`LinearityCheck`]), printed
/// as well.
fn linearity(label: &str, measured: &[(String, Measured)], sets: &[LightingSet], out: &mut Vec<LinearityCheck>) {
    let Some((whole, parts)) = sets.split_first() else { return };
    if parts.is_empty() {
        return;
    }
    let names: Vec<&str> = parts.iter().map(|p| p.lighting.name()).collect();
    let sum_name = names.join(" + ");
    let mask = &whole.tri.mask;
    let check = |image: String, w: &[[f32; 3]], parts: &[&[[f32; 3]]], noise_sq: f64| {
        let (mut err, mut norm) = (0.0, 0.0);
        for (i, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
            for k in 0..3 {
                let d = parts.iter().map(|p| p[i][k] as f64).sum::<f64>() - w[i][k] as f64;
                err += d * d;
                norm += (w[i][k] as f64).powi(2);
            }
        }
        let c = LinearityCheck {
            scene: label.to_string(),
            image,
            rmse: 100.0 * (err / norm).sqrt(),
            noise: 100.0 * (noise_sq / norm).sqrt(),
        };
        eprintln!(
            "{label}: {}: {sum_name} − whole = {:.3} % of whole, noise estimate {:.3} %: {}",
            c.image,
            c.rmse,
            c.noise,
            c.verdict()
        );
        c
    };
    fn refs(s: &LightingSet) -> [Option<&ReferenceImage>; 2] {
        [Some(&s.tri), s.sph.as_ref()]
    }
    for kind in 0..2 {
        let Some(w) = refs(whole)[kind] else { continue };
        let Some(p) = parts.iter().map(|p| refs(p)[kind]).collect::<Option<Vec<&ReferenceImage>>>() else {
            continue;
        };
        let mut terms: Vec<(f64, &HalfMeans)> = p.iter().map(|r| (1.0, &r.halves)).collect();
        terms.push((-1.0, &w.halves));
        let noise = combination_noise_sq(&terms, mask);
        let rgb: Vec<Vec<[f32; 3]>> = p.iter().map(|r| measure::rgb_items(&r.hdr)).collect();
        let rgb: Vec<&[[f32; 3]]> = rgb.iter().map(Vec::as_slice).collect();
        let image = format!("reference/{}", measure::visibility_name(w.visibility));
        out.push(check(image, &measure::rgb_items(&w.hdr), &rgb, noise));
    }
    for (k, (shading, m)) in measured.iter().enumerate() {
        let image = format!("{} ({shading})", m.spec);
        let rgb: Vec<&[[f32; 3]]> = parts.iter().map(|p| p.techniques[k].as_slice()).collect();
        out.push(check(image, &whole.techniques[k], &rgb, 0.0));
    }
}

/// The rows of `regions.csv` for one scene: every image (techniques, and each reference against the other) ×
/// region (all covered pixels, then each object) × lighting × reference.
fn region_rows(
    label: &str,
    measured: &[(String, Measured)],
    regions: &[Region],
    sets: &[LightingSet],
    out: &mut Vec<RegionRow>,
) {
    let Some(whole) = sets.first() else { return };
    // (shading, image name, its RGB and halves per lighting set, the references to measure it against).
    struct Image<'a> {
        shading: String,
        name: String,
        per_set: Vec<(Vec<[f32; 3]>, Option<&'a HalfMeans>)>,
        skip: Option<&'static str>,
    }
    let mut images: Vec<Image> = measured
        .iter()
        .enumerate()
        .map(|(k, (shading, m))| Image {
            shading: shading.clone(),
            name: m.spec.clone(),
            per_set: sets.iter().map(|s| (s.techniques[k].clone(), None)).collect(),
            skip: None,
        })
        .collect();
    if whole.sph.is_some() {
        images.push(Image {
            shading: "pixel".into(),
            name: "reference/spheres".into(),
            per_set: sets
                .iter()
                .filter_map(|s| s.sph.as_ref())
                .map(|r| (measure::rgb_items(&r.hdr), Some(&r.halves)))
                .collect(),
            skip: Some("spheres"),
        });
        images.push(Image {
            shading: "pixel".into(),
            name: "reference/triangles".into(),
            per_set: sets.iter().map(|s| (measure::rgb_items(&s.tri.hdr), Some(&s.tri.halves))).collect(),
            skip: Some("triangles"),
        });
    }
    let all = Region { name: "all".into(), pixels: whole.tri.mask.clone() };
    for img in &images {
        for (against, pick) in [("triangles", 0usize), ("spheres", 1)] {
            if img.skip == Some(against) {
                continue;
            }
            let reference = |s: &'_ LightingSet| -> Option<(Vec<[f32; 3]>, HalfMeans, Vec<bool>)> {
                let r = if pick == 0 { Some(&s.tri) } else { s.sph.as_ref() }?;
                Some((measure::rgb_items(&r.hdr), r.halves.clone(), r.mask.clone()))
            };
            let refs: Vec<_> = sets.iter().map(reference).collect();
            let Some(Some((whole_rgb, _, mask))) = refs.first() else { continue };
            for (set, ((rgb, halves), r)) in sets.iter().zip(img.per_set.iter().zip(&refs)) {
                let Some((ref_rgb, ref_halves, _)) = r else { continue };
                let diff = |pixels: &[bool]| -> (Vec<bool>, Difference) {
                    let m: Vec<bool> = pixels.iter().zip(mask).map(|(a, b)| *a && *b).collect();
                    let d = measure::difference(rgb, *halves, ref_rgb, ref_halves, &m);
                    (m, d)
                };
                let (_, d_all) = diff(&all.pixels);
                for region in std::iter::once(&all).chain(regions) {
                    let (m, d) = diff(&region.pixels);
                    let (_, whole_sq) = sums(whole_rgb, &m);
                    let (radiance, _) = sums(rgb, &m);
                    let (radiance_whole, _) = sums(&img.per_set[0].0, &m);
                    out.push(RegionRow {
                        scene: label.to_string(),
                        shading: img.shading.clone(),
                        image: img.name.clone(),
                        region: region.name.clone(),
                        lighting: set.lighting.name(),
                        against,
                        rmse: d.rmse(),
                        debiased: d.debiased_of(d.reference_sq),
                        noise: d.noise_of(d.reference_sq),
                        of_whole: d.rmse_of(whole_sq),
                        of_whole_debiased: d.debiased_of(whole_sq),
                        error_share: share(d.error_sq, d_all.error_sq),
                        radiance_share: share(radiance, radiance_whole),
                    });
                }
            }
        }
    }
}

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

fn num(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.6}")
    } else {
        String::new()
    }
}

fn errs(e: &Option<Errors>) -> [String; 4] {
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

fn readme(gpu: &Gpu, sweep: &Sweep, res: &Results) -> String {
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
