//! Running a sweep: every scene's references (triangles, spheres, per lighting), every technique measured
//! against them, the error decomposition and the region and lighting split. Measures only; [`super::write`] and
//! [`super::page`] write the files.

use super::results::*;
use super::sweep::*;
use crate::converge::{combination_noise_sq, HalfMeans};
use crate::measure::{self, Difference, Errors, Lighting, Measured, ReferenceImage, ReferenceRun, Region};
use anyhow::{bail, Context, Result};
use engine::gpu::Gpu;
use engine::passes::shade::reference::Visibility;
use engine::renderer::RenderSettings;
use std::path::Path;

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

/// Which part of a sweep to measure: all of it (one process), or one point of the sweep run as jobs
/// (`super::jobs`, docs/sweeps.md): a scene's references, or one technique at one shading rate on one scene.
#[derive(Clone, Debug, PartialEq)]
pub enum Part {
    All,
    /// The references of scene `scene` (index into the sweep's scenes): their rows, images, region rows and
    /// linearity checks. Converges them into the reference cache, where the scene's technique points find them.
    References {
        scene: usize,
    },
    /// One technique on one scene: its row, images, region rows and linearity check, against the scene's
    /// references (from the cache, or converged here when its reference point has not run yet).
    Technique {
        scene: usize,
        shading: String,
        technique: String,
    },
}

impl Part {
    fn has_scene(&self, i: usize) -> bool {
        match self {
            Part::All => true,
            Part::References { scene } | Part::Technique { scene, .. } => *scene == i,
        }
    }

    /// Whether the references' rows, images and checks are this part's output.
    fn references(&self) -> bool {
        !matches!(self, Part::Technique { .. })
    }

    fn measures(&self, shading: &str, tech: &str) -> bool {
        match self {
            Part::All => true,
            Part::References { .. } => false,
            Part::Technique { shading: s, technique: t, .. } => s == shading && t == tech,
        }
    }
}

/// Run the sweep, printing progress to stderr, and write its images into `out`.
pub fn measure(gpu: &Gpu, sweep: &Sweep, out: &Path) -> Result<Results> {
    measure_part(gpu, sweep, out, &Part::All)
}

/// Measure `part` of the sweep (see [`Part`]). A point's references are exactly those of the single-process run:
/// the fraction rule converges them against every technique of the scene (rendered here for that, when the
/// reference is not cached), and the hemisphere and unoccluded references go through the same cache.
pub fn measure_part(gpu: &Gpu, sweep: &Sweep, out: &Path, part: &Part) -> Result<Results> {
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
    let total: usize = (sweep.scenes.iter().enumerate().filter(|(i, _)| part.has_scene(*i)))
        .flat_map(|(_, spec)| shadings(spec))
        .map(|s| sweep.techniques_at(&s).filter(|t| part.measures(&s, t)).count())
        .sum();
    let refs_out = part.references();
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
    let mut results = Results::default();
    for (scene_index, spec) in sweep.scenes.iter().enumerate() {
        if !part.has_scene(scene_index) {
            continue;
        }
        let label = spec.label().to_string();
        let mut scene = scenes::build(&spec.scene, None)?;
        if let Some(m) = scene.materials.first_mut() {
            if let Some(s) = spec.gloss {
                m.shininess = s;
            }
            if let Some(k) = spec.ks {
                m.specular = glam::Vec3::splat(k);
            }
        }
        if let Some(b) = &spec.brdf {
            scenes::apply_brdf(&mut scene, b)?;
        }
        if let Some(t) = spec.time {
            scene = measure::freeze_at(gpu, &spec.scene, scene, t).with_context(|| format!("{label} at {t} s"))?;
        }
        let has_spheres = scene.blockers.spheres.iter().any(Option::is_some);
        let mut measured: Vec<(String, Measured)> = Vec::new();
        for shading in &shadings(spec) {
            for tech in sweep.techniques_at(shading).filter(|t| part.measures(shading, t)) {
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
        // The images the fraction rule converges a reference against: every technique of the scene, as the
        // single-process run measured them (a point renders them when it converges a reference itself).
        let every_technique = |scene: &engine::scene::Scene, frames: u32| -> Result<Vec<Vec<f32>>> {
            let mut v = Vec::new();
            for shading in &shadings(spec) {
                for tech in sweep.techniques_at(shading) {
                    v.push(measure::measure_technique(gpu, scene, settings(shading, tech)?, frames)?.hdr);
                }
            }
            Ok(v)
        };
        let key = |vis: Visibility| {
            format!(
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
            )
        };
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
            let r = measure::cached_reference(
                cache.as_deref(),
                &measure::file_stem(&label),
                &key(vis),
                vis,
                pixels,
                || {
                    let images = match part {
                        Part::All => measured.iter().map(|(_, m)| m.hdr.clone()).collect(),
                        _ => every_technique(&scene, frames)?,
                    };
                    let against: Vec<&[f32]> = images.iter().map(Vec::as_slice).collect();
                    measure::converge_reference(gpu, &scene, &base, &run, &against)
                },
            )?;
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
        if refs_out {
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
                let png =
                    keep(&mut thumbs, format!("{stem}-reference-spheres.png"), "reference (spheres)".into(), &s.ldr)?;
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
        // A scene's reference point converges the unoccluded reference too (into the cache, for its technique
        // points), though it has no row of its own.
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
            let vis = Visibility::Unoccluded;
            let unocc = measure::cached_reference(cache.as_deref(), &stem, &key(vis), vis, pixels, || {
                let all = match part {
                    Part::All => images.iter().map(|m| m.hdr.clone()).collect(),
                    _ => every_technique(&free, 1)?,
                };
                let against: Vec<&[f32]> = all.iter().map(Vec::as_slice).collect();
                measure::converge_reference(gpu, &free, &base, &run, &against)
            })?;
            for (slot, m) in representation.iter_mut().zip(&images) {
                *slot = Some(measure::errors(&m.hdr, &m.ldr, &unocc, w, h));
            }
        }
        for (row, e) in results.rows.iter_mut().rev().take(measured.len()).rev().zip(&representation) {
            row.representation = *e;
        }
        if let (Some(s), true) = (&sph, refs_out) {
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
        if refs_out {
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
        }

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
                    let vis = r.visibility;
                    let key = format!("{}|lighting {}|{} spp", key(vis), lighting.name(), r.report.samples);
                    let stem = format!("{stem}-{}", lighting.name());
                    measure::cached_reference(cache.as_deref(), &stem, &key, vis, pixels, || {
                        measure::reference_at(gpu, &lit, &base, vis, r.report.samples, sweep.samples_per_frame)
                    })
                };
                let tri = at(&sets[0].tri)?;
                let sph = sets[0].sph.as_ref().map(at).transpose()?;
                sets.push(LightingSet { lighting, tri, sph, techniques });
            }
            linearity(&label, &measured, &sets, refs_out, &mut results.linearity);
        }
        region_rows(&label, &measured, &regions, &sets, refs_out, &mut results.regions);
        let (tri, sph) = {
            let whole = sets.swap_remove(0);
            (whole.tri, whole.sph)
        };

        if refs_out {
            results.references.push(SceneReferences {
                scene: label.clone(),
                triangles: (&tri).into(),
                spheres: sph.as_ref().map(Into::into),
            });
        }
        results.thumbnails.push((label, thumbs));
    }
    Ok(results)
}

/// Upper + lower (+ lights) − whole for every reference and technique of a scene ([`LinearityCheck`]), printed
/// as well.
fn linearity(
    label: &str,
    measured: &[(String, Measured)],
    sets: &[LightingSet],
    refs_out: bool,
    out: &mut Vec<LinearityCheck>,
) {
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
    for kind in (0..2).filter(|_| refs_out) {
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
    refs_out: bool,
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
    if whole.sph.is_some() && refs_out {
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
                        lighting: set.lighting.name().to_string(),
                        against: against.to_string(),
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
