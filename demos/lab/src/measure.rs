//! Shared measurement steps of `compare` and `report`: render a technique for a few frames (median GPU times and
//! the final images), converge the Monte Carlo reference against the measured images, and the error metrics of an
//! image against a reference.

use crate::converge::{self, ConvergeReport, HalfMeans};
use crate::metrics;
use anyhow::{Context, Result};
use engine::gpu::Gpu;
use engine::math::envmap::LatLongMap;
use engine::math::tables::Fnv1a64;
use engine::passes::shade::reference::{ReferenceOptions, Visibility, FRAME_SHADERS, REFERENCE_CODE_VERSION};
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
        let report = r.technique_report(gpu)?;
        for w in report.warnings {
            eprintln!("warning: {spec}: {w}");
        }
        for c in report.counts {
            eprintln!("{spec}: {c}");
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
    /// The image as two independent half-sample means (the noise of any difference involving it is estimated
    /// from these: [`crate::converge::combination_noise_sq`]).
    pub halves: HalfMeans,
    /// GPU time of one reference frame divided by its samples per pixel.
    pub ms_per_sample: f64,
    /// Wall-clock seconds of the convergence.
    pub seconds: f64,
}

const CACHE_MAGIC: &[u8; 8] = b"REFIMG02";

impl ReferenceImage {
    /// Write the image to a cache file (little-endian: magic, width·height, the report, ms per sample,
    /// seconds, the halves' sample counts, then RGBA32F, RGBA8, the mask bytes and the halves' RGB32F).
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
        b.extend_from_slice(&self.halves.samples_a.to_le_bytes());
        b.extend_from_slice(&self.halves.samples_b.to_le_bytes());
        b.extend(self.hdr.iter().flat_map(|v| v.to_le_bytes()));
        b.extend_from_slice(&self.ldr);
        b.extend(self.mask.iter().map(|&m| m as u8));
        for half in [&self.halves.a, &self.halves.b] {
            b.extend(half.iter().flatten().flat_map(|v| v.to_le_bytes()));
        }
        // Written beside and renamed into place, so that a reader (another job of a sweep run in parallel,
        // docs/sweeps.md) never reads a half-written file under the final name.
        let tmp = path.with_extension(format!("tmp-{}", std::process::id()));
        std::fs::write(&tmp, b).with_context(|| format!("writing {}", tmp.display()))?;
        std::fs::rename(&tmp, path).with_context(|| format!("renaming {} to {}", tmp.display(), path.display()))
    }

    /// Read a file written by [`ReferenceImage::save`]; `pixels` must match.
    pub fn load(path: &Path, visibility: Visibility, pixels: usize) -> Result<Self> {
        let b = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        let bad = || {
            anyhow::anyhow!(
                "{}: not a reference cache of {pixels} pixels of this version ({}); delete it to recompute",
                path.display(),
                String::from_utf8_lossy(CACHE_MAGIC)
            )
        };
        let header = 8 + 8 + 4 + 4 + 8 + 1 + 8 + 8 + 4 + 4;
        if b.len() != header + pixels * (16 + 4 + 1 + 24) || &b[..8] != CACHE_MAGIC {
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
        let (samples_a, samples_b) = (u32_at(49), u32_at(53));
        let body = &b[header..];
        let floats = |bytes: &[u8]| -> Vec<f32> {
            bytes.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect()
        };
        let rgb =
            |bytes: &[u8]| -> Vec<[f32; 3]> { floats(bytes).chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect() };
        let hdr = floats(&body[..pixels * 16]);
        let ldr = body[pixels * 16..pixels * 20].to_vec();
        let mask = body[pixels * 20..pixels * 21].iter().map(|&m| m != 0).collect();
        let a = rgb(&body[pixels * 21..pixels * 33]);
        let b = rgb(&body[pixels * 33..]);
        let halves = HalfMeans { a, b, samples_a, samples_b };
        Ok(Self { visibility, hdr, ldr, mask, report, halves, ms_per_sample, seconds })
    }
}

/// The reference `compute` makes, kept in `dir` (when given) as `<stem>-<visibility>-<hash of key>.refimg`:
/// `key` must name everything that determines the image (scene, size, materials, visibility, sample budget,
/// time), so that a file found under it is that image and is read back instead of converging again.
pub fn cached_reference(
    dir: Option<&Path>,
    stem: &str,
    key: &str,
    visibility: Visibility,
    pixels: usize,
    compute: impl FnOnce() -> Result<ReferenceImage>,
) -> Result<ReferenceImage> {
    let vis = visibility_name(visibility);
    let path = dir.map(|d| {
        let hash = key.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ b as u64).wrapping_mul(0x100_0000_01b3));
        d.join(format!("{stem}-{vis}-{hash:016x}.refimg"))
    });
    if let Some(p) = path.as_ref().filter(|p| p.exists()) {
        eprintln!("reference from the cache {}", p.display());
        return ReferenceImage::load(p, visibility, pixels);
    }
    let r = compute()?;
    if let Some(p) = &path {
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent).with_context(|| format!("creating {}", parent.display()))?;
        }
        r.save(p)?;
    }
    Ok(r)
}

/// `scene` (registered as `name`) as its motion poses it at `t` seconds, frozen: instance transforms and bones
/// from the motion, a simulated cloth run on the GPU to that time and baked into its mesh
/// ([`scenes::cloth::frozen_at`]), so that the reference's triangles see the same pose.
pub fn freeze_at(gpu: &Gpu, name: &str, mut scene: Scene, t: f32) -> Result<Scene> {
    anyhow::ensure!(t.is_finite() && t >= 0.0, "time {t}: a finite time ≥ 0");
    let entry = scenes::find(name)?;
    if let Some(a) = scenes::Animation::for_entry(entry, &scene) {
        let pose = a.pose(t);
        for (i, m) in pose.transforms {
            scene.instances[i].transform = m;
        }
        if let Some(b) = pose.bones {
            scene.blockers.bones = b;
        }
    }
    scenes::cloth::frozen_at(gpu, &scene, t)
}

/// A reference visibility by its name (`compare --visibility`, the Python module): the inverse of
/// [`visibility_name`].
pub fn parse_visibility(name: &str) -> Result<Visibility> {
    [Visibility::Triangles, Visibility::Spheres, Visibility::Unoccluded]
        .into_iter()
        .find(|v| visibility_name(*v) == name)
        .ok_or_else(|| anyhow::anyhow!("visibility '{name}': use triangles, spheres or unoccluded"))
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
    let items: Vec<Vec<[f32; 3]>> =
        against.iter().map(|hdr| hdr.chunks_exact(4).map(|p| [p[0], p[1], p[2]]).collect()).collect();
    let fraction = run.fraction;
    reference_image(gpu, scene, settings, run, move |s| {
        let err =
            items.iter().map(|m| metrics::relative_rmse_items(m, &s.mean, &s.covered)).fold(f64::INFINITY, f64::min);
        s.relative_stderr() <= fraction * err
    })
}

/// The per-pixel reference with `visibility` at exactly `spp` samples per pixel (rounded down to whole frames of
/// `samples_per_frame`): for images that must be made alike (the hemisphere lightings of the report, sample
/// for sample with the whole-lighting reference they are compared with).
pub fn reference_at(
    gpu: &Gpu,
    scene: &Scene,
    settings: &RenderSettings,
    visibility: Visibility,
    spp: u32,
    samples_per_frame: u32,
) -> Result<ReferenceImage> {
    let run = ReferenceRun { visibility, fraction: 0.0, max_spp: spp, samples_per_frame };
    reference_image(gpu, scene, settings, &run, |_| false)
}

/// The reference's options for `run`. The same seed for every reference: the sphere-proxy and triangle
/// references then share their random numbers sample for sample, and the noise of their difference is
/// estimated from the halves.
fn reference_options(run: &ReferenceRun) -> ReferenceOptions {
    ReferenceOptions {
        samples_per_frame: run.samples_per_frame.max(1),
        seed: 1,
        visibility: run.visibility,
        ..Default::default()
    }
}

/// The digest of everything a reference image converged by [`converge_reference`] depends on, for a cache on disk:
/// - the scene as built, after every override (its meshes, materials, instances and pose, environment texels,
///   lights, blockers, cloth and camera: the content of the scene file and of every file it loads, not their
///   paths), through its `Debug` text, which prints every field and every float exactly;
/// - the size, and the run (visibility, fraction, most samples, samples per frame) with the reference's options
///   (seed, ray offset);
/// - the reference's code: [`REFERENCE_CODE_VERSION`] and the sources of every shader its frame compiles
///   ([`FRAME_SHADERS`], with their includes).
///
/// Not keyed: the images the fraction rule converges against (the first run's techniques decide when it stops).
/// FNV-1a 64 ([`Fnv1a64`]), stable across runs and Rust versions (not `DefaultHasher`).
pub fn reference_key(gpu: &Gpu, scene: &Scene, width: u32, height: u32, run: &ReferenceRun) -> Result<u64> {
    use std::fmt::Write;
    let mut h = Fnv1a64::default();
    write!(h, "{CACHE_MAGIC:?}|{REFERENCE_CODE_VERSION}|").ok();
    for shader in FRAME_SHADERS {
        for (path, text) in gpu.shader_sources(shader).with_context(|| format!("reading the shader {shader}"))? {
            write!(h, "{path}|{}|{text}", text.len()).ok();
        }
    }
    write!(h, "{width}x{height}|{run:?}|{:?}|{scene:?}", reference_options(run)).ok();
    Ok(h.0)
}

/// The cache file of a reference: `<dir>/<scene>-<visibility>-<key>.refimg`, always in `dir` (for a scene given
/// as a path, `<scene>` is its file stem), `key` from [`reference_key`].
pub fn reference_cache_file(
    gpu: &Gpu,
    dir: &Path,
    scene_name: &str,
    scene: &Scene,
    width: u32,
    height: u32,
    run: &ReferenceRun,
) -> Result<std::path::PathBuf> {
    let stem = Path::new(scene_name).file_stem().map_or_else(|| "scene".into(), |s| file_stem(&s.to_string_lossy()));
    let key = reference_key(gpu, scene, width, height, run)?;
    Ok(dir.join(format!("{stem}-{}-{key:016x}.refimg", visibility_name(run.visibility))))
}

fn reference_image(
    gpu: &Gpu,
    scene: &Scene,
    settings: &RenderSettings,
    run: &ReferenceRun,
    done: impl FnMut(&engine::passes::shade::reference::ReferenceStats) -> bool,
) -> Result<ReferenceImage> {
    let max_spp = run.max_spp;
    let settings = RenderSettings { technique: "reference".into(), per_vertex: false, ..settings.clone() };
    let mut r = Renderer::new(gpu, scene, settings)?;
    let out = (|| -> Result<ReferenceImage> {
        let opts = reference_options(run);
        converge::reference_mut(&mut r).context("reference technique")?.set_options(opts)?;
        let t0 = std::time::Instant::now();
        let (report, stats, halves) = converge::converge_until_split(gpu, &mut r, max_spp, done)?;
        let seconds = t0.elapsed().as_secs_f64();
        anyhow::ensure!(stats.nonfinite_samples == 0, "reference: {} non-finite samples", stats.nonfinite_samples);
        let hdr: Vec<f32> = stats.mean.iter().flat_map(|m| [m[0], m[1], m[2], 1.0]).collect();
        let t = r.render(gpu)?;
        let frame_ms: f64 = t.iter().filter(|p| p.name.starts_with("shade/")).map(|p| p.ms).sum();
        let ldr = r.read_ldr(gpu)?;
        Ok(ReferenceImage {
            visibility: run.visibility,
            hdr,
            ldr,
            mask: stats.covered,
            report,
            halves,
            ms_per_sample: frame_ms / opts.samples_per_frame as f64,
            seconds,
        })
    })();
    r.destroy(gpu);
    out
}

/// Errors of an image against a reference (over the reference's covered pixels).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Errors {
    /// Relative RMSE, %.
    pub rmse: f64,
    /// The same with the noise of the difference removed: √(RMSE² − noise²).
    pub debiased: f64,
    /// The noise of the difference image − reference, in the units of the relative RMSE (%): estimated from the
    /// difference itself ([`difference`]).
    pub noise: f64,
    /// Largest per-channel absolute error.
    pub max_abs: f64,
    /// Mean LDR FLIP.
    pub flip: f64,
}

/// RGB items of an RGBA image.
pub fn rgb_items(hdr: &[f32]) -> Vec<[f32; 3]> {
    hdr.chunks_exact(4).map(|p| [p[0], p[1], p[2]]).collect()
}

/// The squared sums behind a relative RMSE of `test` against `reference` over a mask, with the noise of the
/// difference.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Difference {
    /// Σ |test − reference|² over the mask and RGB.
    pub error_sq: f64,
    /// Σ |reference|².
    pub reference_sq: f64,
    /// Estimated Σ Var(test − reference) (the two images' noises, correlated or not).
    pub noise_sq: f64,
}

impl Difference {
    /// Relative RMSE, %, against `norm_sq` (the reference's own Σ|r|² or another image's).
    pub fn rmse_of(&self, norm_sq: f64) -> f64 {
        100.0 * crate::metrics::sqrt_ratio(self.error_sq, norm_sq)
    }
    pub fn rmse(&self) -> f64 {
        self.rmse_of(self.reference_sq)
    }
    /// The noise in the same units as [`Difference::rmse_of`].
    pub fn noise_of(&self, norm_sq: f64) -> f64 {
        100.0 * crate::metrics::sqrt_ratio(self.noise_sq, norm_sq)
    }
    /// The relative RMSE without the noise: 100 √(max(0, Σ|d|² − Σ Var d) / norm).
    pub fn debiased_of(&self, norm_sq: f64) -> f64 {
        100.0 * crate::metrics::sqrt_ratio((self.error_sq - self.noise_sq).max(0.0), norm_sq)
    }
}

/// The difference `test − reference` over `mask` (`test` exact when `test_halves` is `None`, e.g. a technique's
/// render; a reference's halves otherwise, e.g. the sphere-proxy reference against the triangles, whose shared
/// seeds make their difference far less noisy than their own noises added).
pub fn difference(
    test: &[[f32; 3]],
    test_halves: Option<&HalfMeans>,
    reference: &[[f32; 3]],
    reference_halves: &HalfMeans,
    mask: &[bool],
) -> Difference {
    let mut d = Difference::default();
    for ((t, r), _) in test.iter().zip(reference).zip(mask).filter(|(_, m)| **m) {
        for k in 0..3 {
            let (x, y) = (t[k] as f64, r[k] as f64);
            d.error_sq += (x - y) * (x - y);
            d.reference_sq += y * y;
        }
    }
    let exact;
    let test_halves = match test_halves {
        Some(h) => h,
        None => {
            exact = HalfMeans::exact(test.to_vec());
            &exact
        }
    };
    d.noise_sq = converge::combination_noise_sq(&[(1.0, test_halves), (-1.0, reference_halves)], mask);
    d
}

/// Errors of a technique's image (exact) against a reference; the noise removed is the reference's, estimated
/// from its halves.
pub fn errors(hdr: &[f32], ldr: &[u8], r: &ReferenceImage, width: u32, height: u32) -> Errors {
    errors_of(hdr, None, ldr, r, width, height)
}

/// Errors of an image with optional halves (a reference) against a reference.
pub fn errors_of(
    hdr: &[f32],
    halves: Option<&HalfMeans>,
    ldr: &[u8],
    r: &ReferenceImage,
    width: u32,
    height: u32,
) -> Errors {
    let d = difference(&rgb_items(hdr), halves, &rgb_items(&r.hdr), &r.halves, &r.mask);
    Errors {
        rmse: metrics::relative_rmse_percent(hdr, &r.hdr, &r.mask),
        debiased: d.debiased_of(d.reference_sq),
        noise: d.noise_of(d.reference_sq),
        max_abs: metrics::max_error(hdr, &r.hdr, &r.mask).abs,
        flip: metrics::flip_mean(ldr, &r.ldr, width, height, Some(&r.mask)),
    }
}

/// The pixels of one object (a scene instance), found exactly in the G-buffer.
#[derive(Clone, Debug)]
pub struct Region {
    pub name: String,
    pub pixels: Vec<bool>,
}

/// The pixels of every instance of `scene` at `width`×`height`, exactly: the G-buffer stores material + 1 per
/// pixel (position.w, shaders-glsl/gbuffer/gbuffer.frag), so one frame of a copy of the scene with one material
/// per instance (same geometry and camera, so the same raster) names each pixel's instance. Instances that cover
/// no pixel are left out; names are the meshes' (with `#instance` where several instances share a mesh name).
pub fn object_regions(gpu: &Gpu, scene: &Scene, width: u32, height: u32) -> Result<Vec<Region>> {
    let mut ids = scene.clone();
    ids.materials = scene
        .instances
        .iter()
        .map(|i| scene.materials.get(i.material).copied().context("instance with a missing material"))
        .collect::<Result<_>>()?;
    for (k, inst) in ids.instances.iter_mut().enumerate() {
        inst.material = k;
    }
    let settings = RenderSettings { width, height, technique: "none".into(), ..Default::default() };
    let mut r = Renderer::new(gpu, &ids, settings).context("rendering the instance ids")?;
    let position =
        r.render(gpu).map_err(anyhow::Error::from).and_then(|_| Ok(gpu.read_image_rgba32f(&r.gbuffer.position)?));
    r.destroy(gpu);
    let position = position?;
    let id: Vec<Option<usize>> = position
        .chunks_exact(4)
        .map(|p| (p[3] >= 0.5 && p[3].is_finite()).then(|| (p[3] - 1.0).round() as usize))
        .collect();
    let name = |k: usize| scene.meshes.get(scene.instances[k].mesh).map_or("?", |m| m.name.as_str());
    let mut out = Vec::new();
    for k in 0..scene.instances.len() {
        let pixels: Vec<bool> = id.iter().map(|i| *i == Some(k)).collect();
        if !pixels.iter().any(|&p| p) {
            continue;
        }
        let shared = (0..scene.instances.len()).filter(|&j| name(j) == name(k)).count() > 1;
        let label = if name(k).is_empty() { format!("instance {k}") } else { name(k).to_string() };
        out.push(Region { name: if shared { format!("{label}#{k}") } else { label }, pixels });
    }
    Ok(out)
}

/// Which part of the environment a lighting keeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lighting {
    Whole,
    /// Directions above the ground's horizon (world +Y up).
    Upper,
    Lower,
    /// The scene's sphere lights alone (no environment).
    Lights,
}

impl Lighting {
    pub fn name(self) -> &'static str {
        match self {
            Lighting::Whole => "whole",
            Lighting::Upper => "upper",
            Lighting::Lower => "lower",
            Lighting::Lights => "lights",
        }
    }
}

/// A copy of the environment keeping only the texels of `lighting` (by the direction through each texel's
/// centre: y > 0 is upper; none for [`Lighting::Lights`]). Every texel is in exactly one of upper and lower, so, rendering being linear in the
/// lighting (any linear filter of the map included), upper + lower = whole; with an even map height the split
/// falls exactly on the horizon.
pub fn hemisphere(env: &LatLongMap, lighting: Lighting) -> LatLongMap {
    let mut out = env.clone();
    match lighting {
        Lighting::Whole => return out,
        Lighting::Lights => {
            out.texels.iter_mut().for_each(|t| *t = [0.0; 3]);
            return out;
        }
        Lighting::Upper | Lighting::Lower => {}
    }
    for row in 0..env.height {
        let upper = env.texel_direction(0, row)[1] > 0.0;
        if upper != (lighting == Lighting::Upper) {
            for t in &mut out.texels[row * env.width..(row + 1) * env.width] {
                *t = [0.0; 3];
            }
        }
    }
    out
}

/// `scene` under one part of its lighting: the environment's hemisphere without the sphere lights, or the lights
/// without the environment (so that upper + lower + lights = whole).
pub fn lit_by(scene: &Scene, lighting: Lighting) -> Scene {
    let mut s = scene.clone();
    s.environment = hemisphere(&scene.environment, lighting);
    if matches!(lighting, Lighting::Upper | Lighting::Lower) {
        s.lights.clear();
    }
    s
}

/// `scene` with no blockers at all (spheres, thin shells and every other kind; skins and bones kept): what is
/// left of a technique's error against the unoccluded reference is its representation error (docs/design.md §4).
pub fn without_blockers(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    s.blockers = engine::scene::SceneBlockers {
        skins: scene.blockers.skins.clone(),
        bones: scene.blockers.bones.clone(),
        // The cloth still moves (its generated spheres are blockers of their own: dropped by the
        // technique's reads only when it sees thin shells, which this scene has none of).
        cloth: scene.blockers.cloth.clone(),
        ..Default::default()
    };
    s
}

/// Heat map (RGBA8) of |image − reference| scaled to a tenth of the reference's maximum.
pub fn heatmap(hdr: &[f32], r: &ReferenceImage, width: u32, height: u32) -> Vec<u8> {
    let scale = r.hdr.iter().copied().fold(0.0f32, f32::max).max(1e-6) * 0.1;
    metrics::error_heatmap(hdr, &r.hdr, &r.mask, width, height, scale)
}

/// [`heatmap`] written as a PNG file.
pub fn write_heatmap(path: &Path, hdr: &[f32], r: &ReferenceImage, width: u32, height: u32) -> Result<()> {
    engine::output::write_png(path, width, height, &heatmap(hdr, r, width, height))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every texel is in exactly one hemisphere (upper + lower = whole, bit for bit), split at the horizon.
    #[test]
    fn hemispheres_partition_the_environment() {
        let (w, h) = (8, 6);
        let env = LatLongMap { width: w, height: h, texels: (0..w * h).map(|i| [i as f32, 1.0, 0.5]).collect() };
        let (up, low) = (hemisphere(&env, Lighting::Upper), hemisphere(&env, Lighting::Lower));
        assert_eq!(hemisphere(&env, Lighting::Whole), env);
        assert!(hemisphere(&env, Lighting::Lights).texels.iter().all(|t| *t == [0.0; 3]));
        for (i, t) in env.texels.iter().enumerate() {
            let (u, l) = (up.texels[i], low.texels[i]);
            assert!((u == [0.0; 3]) != (l == [0.0; 3]) || *t == [0.0; 3], "texel {i} in both or neither");
            assert_eq!([u[0] + l[0], u[1] + l[1], u[2] + l[2]], *t);
            // Rows 0..3 look up (+Y: v < 1/2), rows 3..6 down.
            assert_eq!(u != [0.0; 3], i / w < h / 2, "texel {i}");
        }
    }

    /// Against a reference with halves, an exact image's noise is the reference's half-split variance
    /// Σ (a − b)²/4; the debiased error is √(Σ d² − noise) over the norm; a reference against itself has none.
    #[test]
    fn difference_removes_the_half_split_noise() {
        let reference = vec![[1.0f32, 2.0, 0.0], [3.0, 0.0, 4.0], [9.0, 9.0, 9.0]];
        let halves = HalfMeans {
            a: vec![[1.5, 2.0, 0.0], [2.0, 0.0, 4.0], [0.0; 3]],
            b: vec![[0.5, 2.0, 0.0], [4.0, 0.0, 4.0], [18.0; 3]],
            samples_a: 8,
            samples_b: 8,
        };
        let mask = [true, true, false];
        let test = vec![[2.0f32, 2.0, 0.0], [3.0, 0.0, 2.0], [0.0; 3]];
        let d = difference(&test, None, &reference, &halves, &mask);
        assert_eq!(d.error_sq, 1.0 + 4.0);
        assert_eq!(d.reference_sq, 1.0 + 4.0 + 9.0 + 16.0);
        assert_eq!(d.noise_sq, (1.0 + 4.0) / 4.0);
        assert!((d.debiased_of(d.reference_sq) - 100.0 * (3.75f64 / 30.0).sqrt()).abs() < 1e-12);
        assert!((d.rmse() - 100.0 * (5.0f64 / 30.0).sqrt()).abs() < 1e-12);
        let same = difference(&reference, Some(&halves), &reference, &halves, &mask);
        assert_eq!((same.error_sq, same.noise_sq), (0.0, 0.0));
    }

    /// A cached reference reads back bit for bit; a file of another size or kind is refused.
    #[test]
    fn reference_cache_round_trips() {
        let r = ReferenceImage {
            visibility: Visibility::Spheres,
            hdr: vec![0.5, f32::MIN_POSITIVE, 3.25, 1.0, 7.0, 0.0, 1e-30, 1.0],
            ldr: vec![1, 2, 3, 255, 9, 8, 7, 255],
            mask: vec![true, false],
            report: ConvergeReport { samples: 4096, frames: 256, relative_stderr: 0.0183, converged: false },
            halves: HalfMeans {
                a: vec![[0.25, 1e-20, 3.0], [7.5, 0.0, 2.0]],
                b: vec![[0.75, 0.0, 3.5], [6.5, 0.0, 1e-30]],
                samples_a: 2048,
                samples_b: 2048,
            },
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
        assert_eq!(back.halves, r.halves);
        assert_eq!((back.ms_per_sample, back.seconds), (r.ms_per_sample, r.seconds));
        assert!(ReferenceImage::load(&path, Visibility::Spheres, 3).is_err(), "wrong pixel count accepted");
        std::fs::write(&path, b"not a cache").unwrap();
        assert!(ReferenceImage::load(&path, Visibility::Spheres, 2).is_err(), "garbage accepted");
        std::fs::remove_dir_all(&dir).ok();
    }
}
