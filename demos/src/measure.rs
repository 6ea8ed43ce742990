//! Shared measurement steps of `compare` and `report`: render a technique for a few frames (median GPU times and
//! the final images), converge the Monte Carlo reference against the measured images, and the error metrics of an
//! image against a reference.

use anyhow::{Context, Result};
use engine::converge::{self, ConvergeReport};
use engine::gpu::Gpu;
use engine::metrics;
use engine::passes::shade::reference::{ReferenceOptions, Visibility};
use engine::renderer::{RenderSettings, Renderer};
use engine::scene::Scene;
use std::path::Path;

/// Median (the upper middle value for an even count; NaN when empty).
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// A file name made of a technique spec.
pub fn file_stem(spec: &str) -> String {
    spec.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect()
}

/// One technique rendered for some frames.
pub struct Measured {
    pub spec: String,
    /// Median over the frames of the summed `shade/*` passes (the technique's own cost), ms.
    pub shade_ms: f64,
    /// Median over the frames of the whole frame (every pass), ms.
    pub frame_ms: f64,
    /// Linear RGBA32F image of the last frame.
    pub hdr: Vec<f32>,
    /// Tone-mapped RGBA8 image of the last frame.
    pub ldr: Vec<u8>,
}

/// Render `frames` frames (at least 1) of `settings.technique` and keep the last frame's images.
pub fn measure_technique(gpu: &Gpu, scene: &Scene, settings: RenderSettings, frames: u32) -> Result<Measured> {
    let spec = settings.technique.clone();
    let mut r = Renderer::new(gpu, scene, settings).with_context(|| format!("preparing technique {spec}"))?;
    let (mut shade, mut total) = (Vec::new(), Vec::new());
    let out = (|| -> Result<(Vec<f32>, Vec<u8>)> {
        for _ in 0..frames.max(1) {
            let t = r.render(gpu)?;
            shade.push(t.iter().filter(|p| p.name.starts_with("shade/")).map(|p| p.ms).sum::<f64>());
            total.push(t.iter().map(|p| p.ms).sum::<f64>());
        }
        Ok((r.read_radiance(gpu)?, r.read_ldr(gpu)?))
    })();
    r.destroy(gpu);
    let (hdr, ldr) = out?;
    Ok(Measured { spec, shade_ms: median(shade), frame_ms: median(total), hdr, ldr })
}

/// Refit mesh 0 of `scene` (named `scene_name`) with `count` blocker spheres, cached in `dir`
/// (`<scene_name>-<count>.spheres.json`), and make them its blocker set.
pub fn refit_first_mesh(scene: &mut Scene, scene_name: &str, count: usize, dir: &Path) -> Result<()> {
    let settings = engine::blockers::fit::FitSettings { count, ..Default::default() };
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mesh = scene.meshes.first().context("the scene has no mesh")?;
    let cache = dir.join(format!("{scene_name}-{count}.spheres.json"));
    eprintln!("fitting {count} spheres to mesh 0 (cached in {})...", cache.display());
    let t0 = std::time::Instant::now();
    let spheres = engine::scene::blockers::fitted_spheres(mesh, &settings, &cache)?;
    eprintln!("{} spheres in {:.1} s", spheres.len(), t0.elapsed().as_secs_f64());
    match scene.blockers.spheres.first_mut() {
        Some(slot) => *slot = Some(spheres),
        None => scene.blockers.spheres.push(Some(spheres)),
    }
    Ok(())
}

/// A converged reference image.
pub struct ReferenceImage {
    pub visibility: Visibility,
    pub hdr: Vec<f32>,
    pub ldr: Vec<u8>,
    /// Covered pixels (the metrics' mask).
    pub mask: Vec<bool>,
    pub report: ConvergeReport,
    /// GPU time of one reference frame divided by its samples per pixel.
    pub ms_per_sample: f64,
    /// Wall-clock seconds of the convergence.
    pub seconds: f64,
}

const CACHE_MAGIC: &[u8; 8] = b"REFIMG01";

impl ReferenceImage {
    /// Write the image to a cache file (little-endian: magic, width·height, the report, ms per sample,
    /// seconds, then RGBA32F, RGBA8 and the mask bytes).
    pub fn save(&self, path: &Path) -> Result<()> {
        let mut b = Vec::with_capacity(64 + self.hdr.len() * 4 + self.ldr.len() + self.mask.len());
        b.extend_from_slice(CACHE_MAGIC);
        b.extend_from_slice(&(self.mask.len() as u64).to_le_bytes());
        b.extend_from_slice(&self.report.samples.to_le_bytes());
        b.extend_from_slice(&self.report.frames.to_le_bytes());
        b.extend_from_slice(&self.report.relative_stderr.to_le_bytes());
        b.push(self.report.converged as u8);
        b.extend_from_slice(&self.ms_per_sample.to_le_bytes());
        b.extend_from_slice(&self.seconds.to_le_bytes());
        b.extend(self.hdr.iter().flat_map(|v| v.to_le_bytes()));
        b.extend_from_slice(&self.ldr);
        b.extend(self.mask.iter().map(|&m| m as u8));
        std::fs::write(path, b).with_context(|| format!("writing {}", path.display()))
    }

    /// Read a file written by [`ReferenceImage::save`]; `pixels` must match.
    pub fn load(path: &Path, visibility: Visibility, pixels: usize) -> Result<Self> {
        let b = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        let bad = || anyhow::anyhow!("{}: not a reference cache of {pixels} pixels", path.display());
        let header = 8 + 8 + 4 + 4 + 8 + 1 + 8 + 8;
        if b.len() != header + pixels * (16 + 4 + 1) || &b[..8] != CACHE_MAGIC {
            return Err(bad());
        }
        let u64_at = |o: usize| u64::from_le_bytes(b[o..o + 8].try_into().unwrap());
        let u32_at = |o: usize| u32::from_le_bytes(b[o..o + 4].try_into().unwrap());
        let f64_at = |o: usize| f64::from_bits(u64_at(o));
        if u64_at(8) as usize != pixels {
            return Err(bad());
        }
        let report = ConvergeReport {
            samples: u32_at(16),
            frames: u32_at(20),
            relative_stderr: f64_at(24),
            converged: b[32] != 0,
        };
        let (ms_per_sample, seconds) = (f64_at(33), f64_at(41));
        let body = &b[header..];
        let hdr = body[..pixels * 16].chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
        let ldr = body[pixels * 16..pixels * 20].to_vec();
        let mask = body[pixels * 20..].iter().map(|&m| m != 0).collect();
        Ok(Self { visibility, hdr, ldr, mask, report, ms_per_sample, seconds })
    }
}

pub fn visibility_name(v: Visibility) -> &'static str {
    match v {
        Visibility::Triangles => "triangles",
        Visibility::Spheres => "spheres",
        Visibility::Unoccluded => "unoccluded",
    }
}

/// How to converge a reference (see [`converge_reference`]).
#[derive(Clone, Copy, Debug)]
pub struct ReferenceRun {
    pub visibility: Visibility,
    /// Stop when the relative standard error is this fraction of the smallest measured error.
    pub fraction: f64,
    pub max_spp: u32,
    pub samples_per_frame: u32,
}

/// Converge the per-pixel reference with `visibility` until its relative standard error is at most `fraction`
/// of the smallest relative RMSE of the `against` images (linear RGBA, at `settings`' size) against it, or
/// `max_spp` samples per pixel are reached. `settings.technique` and `per_vertex` are overridden.
pub fn converge_reference(
    gpu: &Gpu,
    scene: &Scene,
    settings: &RenderSettings,
    run: &ReferenceRun,
    against: &[&[f32]],
) -> Result<ReferenceImage> {
    let ReferenceRun { visibility, fraction, max_spp, samples_per_frame } = *run;
    let settings = RenderSettings { technique: "reference".into(), per_vertex: false, ..settings.clone() };
    let mut r = Renderer::new(gpu, scene, settings)?;
    let out = (|| -> Result<ReferenceImage> {
        let opts =
            ReferenceOptions { samples_per_frame: samples_per_frame.max(1), seed: 1, visibility, ..Default::default() };
        converge::reference_mut(&mut r).context("reference technique")?.set_options(opts)?;
        let items: Vec<Vec<[f32; 3]>> =
            against.iter().map(|hdr| hdr.chunks_exact(4).map(|p| [p[0], p[1], p[2]]).collect()).collect();
        let t0 = std::time::Instant::now();
        let (report, stats) = converge::converge_until(gpu, &mut r, max_spp, |s| {
            let err = items
                .iter()
                .map(|m| metrics::relative_rmse_items(m, &s.mean, &s.covered))
                .fold(f64::INFINITY, f64::min);
            s.relative_stderr() <= fraction * err
        })?;
        let seconds = t0.elapsed().as_secs_f64();
        anyhow::ensure!(stats.nonfinite_samples == 0, "reference: {} non-finite samples", stats.nonfinite_samples);
        let hdr: Vec<f32> = stats.mean.iter().flat_map(|m| [m[0], m[1], m[2], 1.0]).collect();
        let t = r.render(gpu)?;
        let frame_ms: f64 = t.iter().filter(|p| p.name.starts_with("shade/")).map(|p| p.ms).sum();
        let ldr = r.read_ldr(gpu)?;
        Ok(ReferenceImage {
            visibility,
            hdr,
            ldr,
            mask: stats.covered,
            report,
            ms_per_sample: frame_ms / opts.samples_per_frame as f64,
            seconds,
        })
    })();
    r.destroy(gpu);
    out
}

/// Errors of an image against a reference (over the reference's covered pixels).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Errors {
    /// Relative RMSE, %.
    pub rmse: f64,
    /// The same with the reference's own noise removed: √(RMSE² − σ²), σ its relative standard error in %.
    pub debiased: f64,
    /// Largest per-channel absolute error.
    pub max_abs: f64,
    /// Mean LDR FLIP.
    pub flip: f64,
}

pub fn errors(hdr: &[f32], ldr: &[u8], r: &ReferenceImage, width: u32, height: u32) -> Errors {
    let rmse = metrics::relative_rmse_percent(hdr, &r.hdr, &r.mask);
    let noise = 100.0 * r.report.relative_stderr;
    Errors {
        rmse,
        debiased: (rmse * rmse - noise * noise).max(0.0).sqrt(),
        max_abs: metrics::max_error(hdr, &r.hdr, &r.mask).abs,
        flip: metrics::flip_mean(ldr, &r.ldr, width, height, Some(&r.mask)),
    }
}

/// Heat map of |image − reference| scaled to a tenth of the reference's maximum.
pub fn write_heatmap(path: &Path, hdr: &[f32], r: &ReferenceImage, width: u32, height: u32) -> Result<()> {
    let scale = r.hdr.iter().copied().fold(0.0f32, f32::max).max(1e-6) * 0.1;
    metrics::write_error_heatmap(path, hdr, &r.hdr, &r.mask, width, height, scale)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cached reference reads back bit for bit; a file of another size or kind is refused.
    #[test]
    fn reference_cache_round_trips() {
        let r = ReferenceImage {
            visibility: Visibility::Spheres,
            hdr: vec![0.5, f32::MIN_POSITIVE, 3.25, 1.0, 7.0, 0.0, 1e-30, 1.0],
            ldr: vec![1, 2, 3, 255, 9, 8, 7, 255],
            mask: vec![true, false],
            report: ConvergeReport { samples: 4096, frames: 256, relative_stderr: 0.0183, converged: false },
            ms_per_sample: 53.1,
            seconds: 188.0,
        };
        let dir = std::env::temp_dir().join(format!("refcache-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("r.refimg");
        r.save(&path).unwrap();
        let back = ReferenceImage::load(&path, Visibility::Spheres, 2).unwrap();
        assert_eq!((back.hdr, back.ldr, back.mask), (r.hdr.clone(), r.ldr.clone(), r.mask.clone()));
        assert_eq!(back.report, r.report);
        assert_eq!((back.ms_per_sample, back.seconds), (r.ms_per_sample, r.seconds));
        assert!(ReferenceImage::load(&path, Visibility::Spheres, 3).is_err(), "wrong pixel count accepted");
        std::fs::write(&path, b"not a cache").unwrap();
        assert!(ReferenceImage::load(&path, Visibility::Spheres, 2).is_err(), "garbage accepted");
        std::fs::remove_dir_all(&dir).ok();
    }
}
