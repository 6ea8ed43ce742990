//! A sweep run as jobs on existing engines (GNU parallel, a Slurm job array, xargs: docs/sweeps.md), not a
//! scheduler of our own: `report --emit-jobs FILE` writes one self-contained shell command per point, each point
//! writes its part of the results under a content key, and `report --merge DIR...` assembles the tables, plots
//! and page from the finished points through the same writers as the single-process run ([`super::write_outputs`]).
//!
//! A point is a scene's references ([`Part::References`]) or one technique at one shading rate on one scene
//! ([`Part::Technique`]). The technique points need their scene's references: they load them from the reference
//! cache (content-keyed, `measure::cached_reference`), which the reference points fill. The emitted file `FILE`
//! holds the technique points and `FILE.references` the reference points, to run first; a technique point run
//! before its references converges them itself (the same image: the references are seeded and converge against
//! every technique of the scene either way), so running `FILE` alone is correct, only slower.
//!
//! A point's folder is `DIR/points/<key>`, the key a hash of the point's definition ([`point_key`]). It is written
//! as `DIR/points/.<key>.tmp-<pid>` and renamed at the end, so a killed point leaves no folder under its key and
//! is simply run again; a finished point is skipped.

use super::results::*;
use super::run::{measure_part, Part};
use super::sweep::*;
use anyhow::{bail, Context, Result};
use engine::gpu::Gpu;
use engine::math::tables::Fnv1a64;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::hash::Hasher;
use std::path::{Path, PathBuf};

/// The file a finished point keeps in its folder.
pub const POINT_FILE: &str = "point.cbor";

/// Bump when what a point writes changes, so that old points are not merged as new ones.
const POINT_FORMAT: u32 = 1;

/// One point of a sweep: its scene (index and label) and what it measures.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    pub label: String,
    pub part: Part,
}

impl Point {
    /// The point as `--point` takes it: `LABEL/references` or `LABEL/SHADING/TECHNIQUE`.
    pub fn spec(&self) -> String {
        match &self.part {
            Part::Technique { shading, technique, .. } => format!("{}/{shading}/{technique}", self.label),
            _ => format!("{}/references", self.label),
        }
    }

    pub fn is_references(&self) -> bool {
        matches!(self.part, Part::References { .. })
    }
}

/// Every point of the sweep, in the order of the single-process run: per scene its references, then its
/// techniques per shading rate.
pub fn points(sweep: &Sweep) -> Vec<Point> {
    let mut v = Vec::new();
    for (scene, spec) in sweep.scenes.iter().enumerate() {
        let label = spec.label().to_string();
        v.push(Point { label: label.clone(), part: Part::References { scene } });
        for shading in spec.shading.as_ref().unwrap_or(&sweep.shading) {
            for technique in sweep.techniques_at(shading) {
                let part = Part::Technique { scene, shading: shading.clone(), technique: technique.clone() };
                v.push(Point { label: label.clone(), part });
            }
        }
    }
    v
}

/// The point of `sweep` named `spec` ([`Point::spec`]).
pub fn find_point(sweep: &Sweep, spec: &str) -> Result<Point> {
    let all = points(sweep);
    all.iter().find(|p| p.spec() == spec).cloned().with_context(|| {
        let names: Vec<String> = all.iter().take(4).map(Point::spec).collect();
        format!("no point '{spec}' in this sweep (points look like: {}, …)", names.join(", "))
    })
}

/// The content key of a point: FNV-1a 64 of everything its results depend on that the sweep file says (size,
/// frames, the reference's budget, the split lighting and representation switches, the cache, whether images
/// are files or embedded, the scene's spec with its overrides, the shading and technique), and the point format.
/// Not keyed: the code and the machine (a new build measuring the same sweep: use a new jobs folder).
pub fn point_key(sweep: &Sweep, point: &Point) -> String {
    let scene = match &point.part {
        Part::References { scene } | Part::Technique { scene, .. } => &sweep.scenes[*scene],
        Part::All => unreachable!("a point is a scene's references or one technique"),
    };
    let mut h = Fnv1a64::default();
    let _ = write!(
        h,
        "report point {POINT_FORMAT}|{}x{}|{}|{}|{}|{}|{}|{}|{:?}|images {}|{scene:?}|{}",
        sweep.width,
        sweep.height,
        sweep.frames,
        sweep.fraction,
        sweep.max_spp,
        sweep.samples_per_frame,
        sweep.split_lighting,
        sweep.representation,
        sweep.reference_cache,
        if sweep.site.is_none() { "files" } else { "embedded" },
        point.spec()
    );
    format!("{:016x}", h.finish())
}

/// What a finished point keeps in `POINT_FILE` (CBOR: the errors' NaNs survive, unlike in JSON).
#[derive(Serialize, Deserialize)]
pub struct PointFile {
    pub format: u32,
    pub key: String,
    pub point: String,
    /// The adapter that measured it (`Gpu::info.name`).
    pub device: String,
    pub seconds: f64,
    pub results: Results,
}

/// Quote `s` for a POSIX shell.
fn quote(s: &str) -> String {
    if !s.is_empty() && s.bytes().all(|b| b.is_ascii_alphanumeric() || b"/._-=:,+@".contains(&b)) {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

/// The reference cache of a sweep run as jobs: the sweep's own, else `DIR/references`.
fn with_cache(sweep: &Sweep, dir: &Path) -> Sweep {
    let mut s = sweep.clone();
    if s.reference_cache.is_none() {
        s.reference_cache = Some(dir.join("references").to_string_lossy().into_owned());
    }
    s
}

/// Write the job files: `file` (one command per technique point) and `file.references` (one per scene's
/// references, to run first). Each command runs `exe` (this binary) on `config`'s sweep `name` and writes its
/// point under `dir/points`. Returns (reference jobs, technique jobs).
pub fn emit(sweep: &Sweep, config: &Path, name: &str, dir: &Path, file: &Path, exe: &Path) -> Result<(usize, usize)> {
    let abs = |p: &Path| -> Result<PathBuf> {
        Ok(if p.is_absolute() { p.to_path_buf() } else { std::env::current_dir()?.join(p) })
    };
    let (config, dir, exe) = (abs(config)?, abs(dir)?, abs(exe)?);
    let (mut refs, mut techs) = (String::new(), String::new());
    let (mut n_refs, mut n_techs) = (0, 0);
    for p in points(sweep) {
        let line = format!(
            "{} --config {} --sweep {} --jobs-dir {} --point {}\n",
            quote(&exe.to_string_lossy()),
            quote(&config.to_string_lossy()),
            quote(name),
            quote(&dir.to_string_lossy()),
            quote(&p.spec())
        );
        if p.is_references() {
            refs.push_str(&line);
            n_refs += 1;
        } else {
            techs.push_str(&line);
            n_techs += 1;
        }
    }
    if let Some(parent) = file.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).with_context(|| format!("creating {}", parent.display()))?;
    }
    std::fs::create_dir_all(dir.join("points")).with_context(|| format!("creating {}/points", dir.display()))?;
    let refs_file = references_file(file);
    std::fs::write(&refs_file, refs).with_context(|| format!("writing {}", refs_file.display()))?;
    std::fs::write(file, techs).with_context(|| format!("writing {}", file.display()))?;
    Ok((n_refs, n_techs))
}

/// `FILE.references`, beside the job file `FILE`.
pub fn references_file(file: &Path) -> PathBuf {
    let mut s = file.as_os_str().to_owned();
    s.push(".references");
    PathBuf::from(s)
}

/// Where a point keeps its results: `dir/points/<key>`.
pub fn point_dir(dir: &Path, sweep: &Sweep, point: &Point) -> PathBuf {
    dir.join("points").join(point_key(sweep, point))
}

/// Run one point into `dir/points/<key>` (skipped when finished): measured into a temporary folder, renamed into
/// place at the end. Returns false when the point was already finished.
pub fn run_point(gpu: &Gpu, sweep: &Sweep, dir: &Path, point: &Point) -> Result<bool> {
    let key = point_key(sweep, point);
    let done = dir.join("points").join(&key);
    if done.join(POINT_FILE).exists() {
        eprintln!("{}: finished already ({}), skipped", point.spec(), done.display());
        return Ok(false);
    }
    let t0 = std::time::Instant::now();
    let tmp = dir.join("points").join(format!(".{key}.tmp-{}", std::process::id()));
    if tmp.exists() {
        std::fs::remove_dir_all(&tmp).with_context(|| format!("removing {}", tmp.display()))?;
    }
    std::fs::create_dir_all(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
    let results = measure_part(gpu, &with_cache(sweep, dir), &tmp, &point.part)
        .with_context(|| format!("point {}", point.spec()))?;
    let file = PointFile {
        format: POINT_FORMAT,
        key: key.clone(),
        point: point.spec(),
        device: gpu.info.name.clone(),
        seconds: t0.elapsed().as_secs_f64(),
        results,
    };
    let mut bytes = Vec::new();
    ciborium::into_writer(&file, &mut bytes).context("encoding the point")?;
    std::fs::write(tmp.join(POINT_FILE), bytes).with_context(|| format!("writing {}", tmp.display()))?;
    if let Err(e) = std::fs::rename(&tmp, &done) {
        // Another run of the same point (another host) finished first: keep its folder.
        if done.join(POINT_FILE).exists() {
            std::fs::remove_dir_all(&tmp).ok();
        } else {
            return Err(e).with_context(|| format!("renaming {} to {}", tmp.display(), done.display()));
        }
    }
    eprintln!("{}: finished in {:.1} s into {}", point.spec(), file.seconds, done.display());
    Ok(true)
}

/// Read a finished point (`DIR/points/<key>` or `DIR/<key>` of any of `dirs`); None when no folder has it.
fn load_point(dirs: &[PathBuf], key: &str) -> Result<Option<(PathBuf, PointFile)>> {
    for d in dirs {
        for folder in [d.join("points").join(key), d.join(key)] {
            let path = folder.join(POINT_FILE);
            if path.exists() {
                let bytes = std::fs::read(&path).with_context(|| format!("reading {}", path.display()))?;
                let file: PointFile =
                    ciborium::from_reader(&bytes[..]).with_context(|| format!("decoding {}", path.display()))?;
                if file.format != POINT_FORMAT || file.key != key {
                    bail!(
                        "{}: format {} key {}, expected format {POINT_FORMAT} key {key}",
                        path.display(),
                        file.format,
                        file.key
                    );
                }
                return Ok(Some((folder, file)));
            }
        }
    }
    Ok(None)
}

/// What [`merge`] found.
pub struct Merged {
    pub results: Results,
    /// The points with no finished folder, as `--point` takes them.
    pub missing: Vec<String>,
    /// Every adapter that measured a point (more than one: the times are not comparable across them).
    pub devices: Vec<String>,
}

/// Assemble the results of the sweep from the finished points in `dirs`, in the order of the single-process run
/// (per scene: the techniques' rows then the references', the references' images first, …), copying the points'
/// images into `out/img` for a sweep without a site. Missing points are listed, not an error here.
pub fn merge(sweep: &Sweep, dirs: &[PathBuf], out: &Path) -> Result<Merged> {
    let mut results = Results::default();
    let (mut missing, mut devices) = (Vec::new(), Vec::<String>::new());
    let all = points(sweep);
    for (scene, spec) in sweep.scenes.iter().enumerate() {
        let label = spec.label().to_string();
        let mut refs: Option<Results> = None;
        let mut techs: Vec<Results> = Vec::new();
        for p in all.iter().filter(
            |p| matches!(&p.part, Part::References { scene: s } | Part::Technique { scene: s, .. } if *s == scene),
        ) {
            let key = point_key(sweep, p);
            let Some((folder, file)) = load_point(dirs, &key)? else {
                missing.push(p.spec());
                continue;
            };
            if !devices.contains(&file.device) {
                devices.push(file.device.clone());
            }
            let img = folder.join("img");
            if img.is_dir() {
                std::fs::create_dir_all(out.join("img")).with_context(|| format!("creating {}/img", out.display()))?;
                for e in std::fs::read_dir(&img).with_context(|| format!("reading {}", img.display()))? {
                    let e = e?;
                    std::fs::copy(e.path(), out.join("img").join(e.file_name()))
                        .with_context(|| format!("copying {}", e.path().display()))?;
                }
            }
            if p.is_references() {
                refs = Some(file.results);
            } else {
                techs.push(file.results);
            }
        }
        if refs.is_none() && techs.is_empty() {
            continue;
        }
        let parts: Vec<&Results> = refs.iter().chain(&techs).collect();
        let (w, h) = parts
            .iter()
            .flat_map(|r| &r.images)
            .map(|i| (i.width, i.height))
            .next()
            .unwrap_or((sweep.width, sweep.height));
        let mut page = SceneImages { scene: label.clone(), width: w, height: h, images: Vec::new() };
        let mut thumbs = Vec::new();
        for r in &parts {
            page.images.extend(r.images.iter().flat_map(|i| i.images.iter().cloned()));
            thumbs.extend(r.thumbnails.iter().flat_map(|(_, t)| t.iter().cloned()));
        }
        // Rows and region rows: the techniques', then the references' (as `run::measure_part` orders them);
        // linearity checks: the references', then the techniques'.
        for r in techs.iter().chain(&refs) {
            results.rows.extend(r.rows.iter().cloned());
            results.regions.extend(r.regions.iter().cloned());
        }
        for r in &parts {
            results.linearity.extend(r.linearity.iter().cloned());
        }
        if let Some(r) = refs {
            results.references.extend(r.references);
        }
        results.images.push(page);
        results.thumbnails.push((label, thumbs));
    }
    Ok(Merged { results, missing, devices })
}

/// `report --merge`: merge, say what is missing (an error unless `allow_missing`), and write the outputs.
pub fn merge_and_write(
    sweep: &Sweep,
    dirs: &[PathBuf],
    out: &Path,
    allow_missing: bool,
    command: &str,
) -> Result<Merged> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let merged = merge(sweep, dirs, out)?;
    let total = points(sweep).len();
    if !merged.missing.is_empty() {
        eprintln!(
            "{} of {total} points missing (none finished under their key in the given folders):",
            merged.missing.len()
        );
        for m in &merged.missing {
            eprintln!("  missing: {m}");
        }
        if !allow_missing {
            bail!(
                "{} of {total} points missing: re-run their jobs (finished points are skipped), or merge with --allow-missing",
                merged.missing.len()
            );
        }
    }
    if merged.devices.len() > 1 {
        eprintln!(
            "warning: the points were measured on {} different adapters ({}): times compare only within one",
            merged.devices.len(),
            merged.devices.join(", ")
        );
    }
    let device = if merged.devices.is_empty() { "no device".to_string() } else { merged.devices.join(" + ") };
    super::write_outputs(out, sweep, &merged.results, &device, command)?;
    eprintln!("merged {} of {total} points into {}", total - merged.missing.len(), out.display());
    Ok(merged)
}
