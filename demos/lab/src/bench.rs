//! `cargo xtask bench`: every registered scene × technique × shading rate × resolution, warm-up frames, then N
//! frames of the scene's animation; per-pass GPU medians and p95 from timestamps, frames per second and device
//! memory, written as CSV, JSON, a Markdown table and plots into `out/bench/`. Every file names the adapter,
//! the driver and the git commit the binary was built from.
//!
//! One renderer per scene × rate × resolution; the techniques are switched on it
//! ([`Renderer::set_technique`]), so every technique of a row group shades the same G-buffer.
//!
//! Frames per second is `1000 / median frame GPU time`: the sum of the passes' timestamps, not wall-clock
//! time (the host waits for every frame's fence, which a real-time loop would not).

use crate::capture::{order_stats, Capture, Summary, TOTAL};
use anyhow::{bail, Context, Result};
use engine::gpu::Gpu;
use engine::renderer::{RenderSettings, Renderer};
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The git commit the binary was built from (demos/build.rs), `-dirty` when tracked files differed from it.
pub const COMMIT: &str = env!("ENGINE_GIT_COMMIT");

/// What to run.
#[derive(Clone, Debug)]
pub struct BenchPlan {
    pub scenes: Vec<String>,
    /// Technique specs (`isg`, `isg:patches=8`, ...).
    pub techniques: Vec<String>,
    /// `false`: per pixel, `true`: per vertex.
    pub rates: Vec<bool>,
    pub sizes: Vec<(u32, u32)>,
    pub warmup: u32,
    pub frames: u32,
}

impl BenchPlan {
    /// Every registered scene and technique, both rates; the size and frame counts by the kind of adapter:
    /// 128×96, 2 + 10 frames on a CPU driver (lavapipe: one ISG frame at 1920×1080 takes tens of seconds there),
    /// 1920×1080, 10 + 100 frames on a GPU.
    pub fn defaults(cpu_adapter: bool) -> Self {
        let (sizes, warmup, frames) =
            if cpu_adapter { (vec![(128, 96)], 2, 10) } else { (vec![(1920, 1080)], 10, 100) };
        Self {
            scenes: scenes::SCENES.iter().map(|s| s.name.to_string()).collect(),
            techniques: engine::passes::shade::TECHNIQUES.iter().map(|t| t.name.to_string()).collect(),
            rates: vec![false, true],
            sizes,
            warmup,
            frames,
        }
    }

    /// Rows this plan measures.
    pub fn row_count(&self) -> usize {
        self.scenes.len() * self.techniques.len() * self.rates.len() * self.sizes.len()
    }

    /// Refuse a plan that would measure nothing or names what does not exist, before any GPU work.
    pub fn check(&self) -> Result<()> {
        if self.row_count() == 0 {
            bail!("the bench has nothing to measure: give at least one scene, technique, rate and size");
        }
        if self.frames == 0 {
            bail!("--frames must be at least 1 (the frames that are timed)");
        }
        for s in &self.scenes {
            if !scenes::user::is_file_spec(s) {
                scenes::find(s)?;
            }
        }
        for t in &self.techniques {
            engine::passes::shade::technique_entry(t.split(':').next().unwrap_or(t))?;
        }
        for &(w, h) in &self.sizes {
            if w == 0 || h == 0 || w > 16384 || h > 16384 {
                bail!("bad size {w}x{h} (1..=16384 each)");
            }
        }
        Ok(())
    }
}

/// The adapter a bench ran on.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Machine {
    pub adapter: String,
    pub device_type: String,
    pub driver: String,
    pub commit: String,
}

impl Machine {
    pub fn of(gpu: &Gpu) -> Self {
        Self {
            adapter: gpu.info.name.clone(),
            device_type: gpu.info.device_type.clone(),
            driver: gpu.info.driver.clone(),
            commit: COMMIT.to_string(),
        }
    }
}

/// One measured scene × technique × rate × size.
#[derive(Clone, Debug)]
pub struct Row {
    pub scene: String,
    pub technique: String,
    pub per_vertex: bool,
    pub width: u32,
    pub height: u32,
    pub capture: Capture,
    /// Device memory allocated after the timed frames (bytes).
    pub device_bytes: u64,
    /// Device allocations made during the timed frames (a steady frame makes none).
    pub steady_allocations: u64,
    /// The blocker tiles' counters over the timed frames (a technique that traverses the blocker BVH).
    pub tiles: Option<engine::passes::shade::tiles::TileCounts>,
}

impl Row {
    pub fn rate(&self) -> &'static str {
        rate_name(self.per_vertex)
    }

    /// Per-pass statistics, the frame total last.
    pub fn summary(&self) -> Vec<Summary> {
        self.capture.summary()
    }

    /// The frame total's median (ms).
    pub fn median_total(&self) -> f64 {
        order_stats(&self.capture.totals()).0
    }

    pub fn fps(&self) -> f64 {
        let m = self.median_total();
        if m > 0.0 {
            1000.0 / m
        } else {
            f64::NAN
        }
    }

    /// The median of the technique's own passes (`shade/...`), summed.
    pub fn shade_median(&self) -> f64 {
        self.summary().iter().filter(|s| s.name.starts_with("shade/")).map(|s| s.median).sum()
    }
}

/// A row that could not be measured (the technique refused the scene, say), with the reason.
#[derive(Clone, Debug)]
pub struct Skipped {
    pub scene: String,
    pub technique: String,
    pub per_vertex: bool,
    pub width: u32,
    pub height: u32,
    pub reason: String,
}

pub fn rate_name(per_vertex: bool) -> &'static str {
    if per_vertex {
        "vertex"
    } else {
        "pixel"
    }
}

/// Run the plan, printing one progress line per row to stderr.
pub fn run(gpu: &Gpu, plan: &BenchPlan) -> Result<(Vec<Row>, Vec<Skipped>)> {
    plan.check()?;
    let (mut rows, mut skipped) = (Vec::new(), Vec::new());
    let total = plan.row_count();
    let t0 = std::time::Instant::now();
    for scene_name in &plan.scenes {
        let loaded = scenes::load(scene_name, None, &Default::default())?;
        let (scene, animation) = (loaded.scene, loaded.animation);
        for &(width, height) in &plan.sizes {
            for &per_vertex in &plan.rates {
                let skip = |technique: &str, reason: String| Skipped {
                    scene: scene_name.clone(),
                    technique: technique.to_string(),
                    per_vertex,
                    width,
                    height,
                    reason,
                };
                // One renderer per group, made by the first technique that accepts the scene; the others are
                // switched on it. A technique that refuses the scene is listed with its reason.
                let mut renderer: Option<Renderer> = None;
                let result = (|| -> Result<()> {
                    for technique in &plan.techniques {
                        let made = match renderer.as_mut() {
                            Some(r) => r.set_technique(gpu, technique),
                            None => {
                                let settings = RenderSettings {
                                    width,
                                    height,
                                    technique: technique.clone(),
                                    per_vertex,
                                    exposure: 1.0,
                                };
                                Renderer::new(gpu, &scene, settings).map(|r| renderer = Some(r))
                            }
                        };
                        let Some(r) = renderer.as_mut().filter(|_| made.is_ok()) else {
                            skipped.push(skip(technique, made.err().map_or_else(String::new, |e| e.to_string())));
                            continue;
                        };
                        let row = measure(gpu, r, plan, animation.as_ref(), scene_name, technique)?;
                        let done = rows.len() + skipped.len() + 1;
                        eprintln!(
                            "[{done}/{total}] {} {} per {} {}x{}: frame {:.3} ms median ({:.1} fps), shade {:.3} ms \
                             ({:.0} s so far)",
                            row.scene,
                            row.technique,
                            row.rate(),
                            width,
                            height,
                            row.median_total(),
                            row.fps(),
                            row.shade_median(),
                            t0.elapsed().as_secs_f64()
                        );
                        rows.push(row);
                    }
                    Ok(())
                })();
                if let Some(r) = renderer {
                    r.destroy(gpu);
                }
                result?;
            }
        }
    }
    for s in &skipped {
        eprintln!(
            "skipped {} {} per {} {}x{}: {}",
            s.scene,
            s.technique,
            rate_name(s.per_vertex),
            s.width,
            s.height,
            s.reason
        );
    }
    Ok((rows, skipped))
}

fn measure(
    gpu: &Gpu,
    renderer: &mut Renderer,
    plan: &BenchPlan,
    animation: Option<&scenes::Animation>,
    scene: &str,
    technique: &str,
) -> Result<Row> {
    // Warm-up: pipelines are compiled lazily by some drivers (lavapipe JIT-compiles on first dispatch).
    Capture::record_from(gpu, renderer, 0, plan.warmup, animation)?;
    renderer.tile_counts(gpu)?; // the counters restart
    let before = gpu.memory_stats();
    let capture = Capture::record_from(gpu, renderer, plan.warmup, plan.frames, animation)?;
    let after = gpu.memory_stats();
    let tiles = renderer.tile_counts(gpu)?;
    Ok(Row {
        scene: scene.to_string(),
        technique: technique.to_string(),
        per_vertex: renderer.settings.per_vertex,
        width: renderer.settings.width,
        height: renderer.settings.height,
        capture,
        device_bytes: after.allocated_bytes,
        steady_allocations: after.allocations_made - before.allocations_made,
        tiles,
    })
}

/// One line of `bench.csv`: one pass (or the frame total) of one row.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct CsvLine {
    pub adapter: String,
    pub device_type: String,
    pub driver: String,
    pub commit: String,
    pub scene: String,
    pub technique: String,
    pub rate: String,
    pub width: u32,
    pub height: u32,
    pub frames: usize,
    pub pass: String,
    pub median_ms: f64,
    pub p95_ms: f64,
    pub max_ms: f64,
    /// Frames per second from the median frame total (the same on every line of a row).
    pub fps: f64,
    pub device_mib: f64,
    pub steady_allocations: u64,
    /// BVH nodes tested per shaded pixel in the last timed frame, mean and p99 (techniques that traverse the
    /// blocker BVH per pixel; empty otherwise).
    #[serde(default)]
    pub nodes_per_pixel_mean: Option<f64>,
    #[serde(default)]
    pub nodes_per_pixel_p99: Option<f64>,
    /// The blocker tiles' start lists over the timed frames: mean and longest length, tiles that fell back to
    /// the root (`tiles=on`; empty otherwise).
    #[serde(default)]
    pub tile_list_mean: Option<f64>,
    #[serde(default)]
    pub tile_list_max: Option<u64>,
    #[serde(default)]
    pub tiles_fell_back: Option<u64>,
}

impl CsvLine {
    fn key(&self) -> (String, String, String, u32, u32, String) {
        (self.scene.clone(), self.technique.clone(), self.rate.clone(), self.width, self.height, self.pass.clone())
    }
}

pub fn csv_lines(machine: &Machine, rows: &[Row]) -> Vec<CsvLine> {
    let mut out = Vec::new();
    for r in rows {
        let pixel = r.tiles.as_ref().filter(|t| t.pixels > 0);
        let lists = r.tiles.as_ref().filter(|t| t.frames > 0);
        for s in r.summary() {
            out.push(CsvLine {
                adapter: machine.adapter.clone(),
                device_type: machine.device_type.clone(),
                driver: machine.driver.clone(),
                commit: machine.commit.clone(),
                scene: r.scene.clone(),
                technique: r.technique.clone(),
                rate: r.rate().to_string(),
                width: r.width,
                height: r.height,
                frames: r.capture.frames.len(),
                pass: s.name.clone(),
                median_ms: s.median,
                p95_ms: s.p95,
                max_ms: s.max,
                fps: r.fps(),
                device_mib: r.device_bytes as f64 / (1024.0 * 1024.0),
                steady_allocations: r.steady_allocations,
                nodes_per_pixel_mean: pixel.map(|t| t.pixel_mean),
                nodes_per_pixel_p99: pixel.map(|t| t.pixel_p99),
                tile_list_mean: lists.map(|t| t.list_mean),
                tile_list_max: lists.map(|t| t.list_max),
                tiles_fell_back: lists.map(|t| t.fell_back),
            });
        }
    }
    out
}

pub fn to_csv(machine: &Machine, rows: &[Row]) -> Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for l in csv_lines(machine, rows) {
        w.serialize(l)?;
    }
    Ok(String::from_utf8(w.into_inner().context("writing the CSV")?)?)
}

pub fn read_csv(path: &Path) -> Result<Vec<CsvLine>> {
    let mut r = csv::Reader::from_path(path).with_context(|| format!("reading {}", path.display()))?;
    let lines: Result<Vec<CsvLine>, _> = r.deserialize().collect();
    lines.with_context(|| format!("{}: not a bench CSV (cargo xtask bench writes one)", path.display()))
}

pub fn to_json(machine: &Machine, rows: &[Row], skipped: &[Skipped]) -> serde_json::Value {
    let rows: Vec<_> = rows
        .iter()
        .map(|r| {
            let passes: Vec<_> = r
                .summary()
                .iter()
                .map(|s| json!({ "name": s.name, "median_ms": s.median, "p95_ms": s.p95, "max_ms": s.max, "count": s.count }))
                .collect();
            json!({
                "scene": r.scene, "technique": r.technique, "rate": r.rate(), "width": r.width, "height": r.height,
                "frames": r.capture.frames.len(), "passes": passes, "fps": r.fps(),
                "device_mib": r.device_bytes as f64 / (1024.0 * 1024.0), "steady_allocations": r.steady_allocations,
                "frame_ms": r.capture.totals(),
            })
        })
        .collect();
    let skipped: Vec<_> = skipped
        .iter()
        .map(|s| json!({ "scene": s.scene, "technique": s.technique, "rate": rate_name(s.per_vertex), "width": s.width, "height": s.height, "reason": s.reason }))
        .collect();
    json!({
        "adapter": machine.adapter, "device_type": machine.device_type, "driver": machine.driver,
        "commit": machine.commit, "fps_from": "median of the per-frame sum of GPU pass timestamps",
        "rows": rows, "skipped": skipped,
    })
}

fn machine_line(machine: &Machine) -> String {
    format!(
        "Adapter: {} ({}), driver: {}, commit: {}.",
        machine.adapter, machine.device_type, machine.driver, machine.commit
    )
}

/// The Markdown table: one line per row; `shade` is the technique's own passes, `frame` the sum of all passes.
pub fn to_markdown(machine: &Machine, rows: &[Row], skipped: &[Skipped]) -> String {
    let mut s = format!("{}\n\n", machine_line(machine));
    s.push_str(
        "| scene | technique | rate | size | shade ms (median) | frame ms (median) | frame ms (p95) | fps | device MiB | \
         steady allocs |\n|---|---|---|---|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in rows {
        let total = r.summary().into_iter().find(|x| x.name == TOTAL);
        let p95 = total.map_or(f64::NAN, |t| t.p95);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {}×{} | {:.3} | {:.3} | {:.3} | {:.1} | {:.1} | {} |",
            r.scene,
            r.technique,
            r.rate(),
            r.width,
            r.height,
            r.shade_median(),
            r.median_total(),
            p95,
            r.fps(),
            r.device_bytes as f64 / (1024.0 * 1024.0),
            r.steady_allocations
        );
    }
    if !skipped.is_empty() {
        s.push_str("\nNot measured:\n\n");
        for k in skipped {
            let _ = writeln!(
                s,
                "- {} {} per {} {}×{}: {}",
                k.scene,
                k.technique,
                rate_name(k.per_vertex),
                k.width,
                k.height,
                k.reason
            );
        }
    }
    s
}

/// Per-line ratios of `new` against an earlier run `old` (new / old medians: below 1 is faster), as Markdown.
/// Lines present in only one run are listed as such.
pub fn compare(old: &[CsvLine], new: &[CsvLine]) -> String {
    let by_key: HashMap<_, _> = old.iter().map(|l| (l.key(), l)).collect();
    let mut s = String::new();
    if let (Some(o), Some(n)) = (old.first(), new.first()) {
        let _ = writeln!(s, "Earlier: {} ({}), commit {}.", o.adapter, o.driver, o.commit);
        let _ = writeln!(s, "Now: {} ({}), commit {}.\n", n.adapter, n.driver, n.commit);
        if o.adapter != n.adapter || o.driver != n.driver {
            s.push_str("**Different adapters or drivers: the ratios compare machines, not code.**\n\n");
        }
    }
    s.push_str("| scene | technique | rate | size | pass | earlier ms | now ms | now / earlier |\n");
    s.push_str("|---|---|---|---|---|---:|---:|---:|\n");
    let mut only_new = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for l in new {
        let k = l.key();
        seen.insert(k.clone());
        match by_key.get(&k) {
            Some(o) => {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {}×{} | {} | {:.3} | {:.3} | {:.3} |",
                    l.scene,
                    l.technique,
                    l.rate,
                    l.width,
                    l.height,
                    l.pass,
                    o.median_ms,
                    l.median_ms,
                    l.median_ms / o.median_ms
                );
            }
            None => only_new.push(l),
        }
    }
    let only_old: Vec<_> = old.iter().filter(|l| !seen.contains(&l.key())).collect();
    // Unmatched lines are listed per row (scene technique rate size), not per pass.
    let rows_of = |lines: &[&CsvLine]| {
        let mut v: Vec<String> = lines
            .iter()
            .map(|l| format!("{} {} per {} {}×{}", l.scene, l.technique, l.rate, l.width, l.height))
            .collect();
        v.dedup();
        v.join("; ")
    };
    if !only_new.is_empty() {
        let _ = writeln!(s, "\nOnly in this run: {}", rows_of(&only_new));
    }
    if !only_old.is_empty() {
        let _ = writeln!(s, "\nOnly in the earlier run: {}", rows_of(&only_old));
    }
    s
}

/// The plots: frame time against frame index for every row (log scale), and frame time against pixel count
/// when the plan has several sizes.
pub fn plots(machine: &Machine, rows: &[Row]) -> Vec<(String, plot::Plot)> {
    let mut out = Vec::new();
    let mut frames = plot::Plot::new(format!("GPU frame time per frame on {}", machine.adapter))
        .size(1000.0, 600.0)
        .x_axis("timed frame", plot::Scale::Linear)
        .y_axis("frame GPU ms", plot::Scale::Log10)
        .legend(plot::Legend::TopRight);
    for r in rows {
        let pts = r.capture.totals().iter().enumerate().map(|(f, &v)| (f as f64, v)).collect();
        let name = format!("{} {} {} {}x{}", r.scene, r.technique, r.rate(), r.width, r.height);
        frames = frames.series(plot::Series::new(name, pts, plot::Style::Line));
    }
    out.push(("bench-frames".to_string(), frames));
    let mut sizes: Vec<(u32, u32)> = rows.iter().map(|r| (r.width, r.height)).collect();
    sizes.sort_unstable();
    sizes.dedup();
    if sizes.len() > 1 {
        let mut res = plot::Plot::new(format!("GPU frame time against resolution on {}", machine.adapter))
            .size(1000.0, 600.0)
            .x_axis("pixels", plot::Scale::Log10)
            .y_axis("median frame GPU ms", plot::Scale::Log10)
            .legend(plot::Legend::TopLeft);
        let mut groups: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
        for r in rows {
            let name = format!("{} {} {}", r.scene, r.technique, r.rate());
            let p = ((r.width as f64) * (r.height as f64), r.median_total());
            match groups.iter_mut().find(|g| g.0 == name) {
                Some(g) => g.1.push(p),
                None => groups.push((name, vec![p])),
            }
        }
        for (name, mut pts) in groups {
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            res = res.series(plot::Series::new(name, pts, plot::Style::LineMarkers));
        }
        out.push(("bench-resolution".to_string(), res));
    }
    out
}

/// Write `bench.csv`, `bench.json`, `bench.md` and the plots into `dir`; returns the paths written.
pub fn write(dir: &Path, machine: &Machine, rows: &[Row], skipped: &[Skipped]) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut paths = Vec::new();
    let mut put = |name: &str, text: String| -> Result<()> {
        let p = dir.join(name);
        std::fs::write(&p, text).with_context(|| format!("writing {}", p.display()))?;
        paths.push(p);
        Ok(())
    };
    put("bench.csv", to_csv(machine, rows)?)?;
    put("bench.json", serde_json::to_string_pretty(&to_json(machine, rows, skipped))? + "\n")?;
    put("bench.md", to_markdown(machine, rows, skipped))?;
    for (name, p) in plots(machine, rows) {
        put(&format!("{name}.svg"), p.to_svg())?;
    }
    Ok(paths)
}

/// Parse `WxH` (`128x96`).
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X', '×']).ok_or_else(|| format!("'{s}': expected WIDTHxHEIGHT, e.g. 128x96"))?;
    let n = |v: &str| v.trim().parse::<u32>().map_err(|_| format!("'{s}': expected WIDTHxHEIGHT, e.g. 128x96"));
    let (w, h) = (n(w)?, n(h)?);
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("'{s}': each side must be 1..=16384"));
    }
    Ok((w, h))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(technique: &str, totals: &[f64]) -> Row {
        Row {
            scene: "bunny".into(),
            technique: technique.into(),
            per_vertex: false,
            width: 8,
            height: 6,
            capture: Capture {
                passes: vec!["gbuffer".into(), format!("shade/{technique}")],
                frames: totals.iter().map(|&t| vec![Some(0.25 * t), Some(0.75 * t)]).collect(),
            },
            device_bytes: 3 * 1024 * 1024,
            steady_allocations: 0,
            tiles: None,
        }
    }

    fn machine() -> Machine {
        Machine {
            adapter: "llvmpipe (LLVM 15.0.6, 256 bits)".into(),
            device_type: "CPU".into(),
            driver: "llvmpipe".into(),
            commit: "abc".into(),
        }
    }

    #[test]
    fn csv_round_trips_with_commas_in_the_adapter_name() {
        let rows = [row("isg", &[4.0, 2.0, 8.0])];
        let text = to_csv(&machine(), &rows).unwrap();
        let dir = std::env::temp_dir().join(format!("bench-csv-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("a.csv");
        std::fs::write(&p, &text).unwrap();
        let back = read_csv(&p).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(back, csv_lines(&machine(), &rows));
        assert_eq!(back.len(), 3, "two passes and the total");
        let total = back.iter().find(|l| l.pass == TOTAL).unwrap();
        assert_eq!((total.median_ms, total.p95_ms, total.max_ms), (4.0, 8.0, 8.0));
        assert_eq!(total.fps, 250.0);
        assert_eq!(total.device_mib, 3.0);
        assert_eq!(back[1].median_ms, 3.0, "shade/isg is 3/4 of each frame");
    }

    #[test]
    fn compare_gives_ratios_and_lists_unmatched_lines() {
        let old = csv_lines(&machine(), &[row("isg", &[4.0])]);
        let new = csv_lines(&machine(), &[row("isg", &[1.0]), row("none", &[1.0])]);
        let md = compare(&old, &new);
        assert!(md.contains("| bunny | isg | pixel | 8×6 | total | 4.000 | 1.000 | 0.250 |"), "{md}");
        assert!(md.contains("Only in this run: bunny none per pixel 8×6\n"), "{md}");
        assert!(!md.contains("Different adapters"));
    }

    #[test]
    fn markdown_names_the_machine_and_every_row() {
        let md = to_markdown(&machine(), &[row("isg", &[2.0, 2.0])], &[]);
        assert!(md.starts_with("Adapter: llvmpipe (LLVM 15.0.6, 256 bits) (CPU), driver: llvmpipe, commit: abc."));
        assert!(md.contains("| bunny | isg | pixel | 8×6 | 1.500 | 2.000 | 2.000 | 500.0 | 3.0 | 0 |"), "{md}");
    }

    #[test]
    fn sizes_parse_and_bad_ones_are_refused() {
        assert_eq!(parse_size("128x96"), Ok((128, 96)));
        assert_eq!(parse_size("1920×1080"), Ok((1920, 1080)));
        for bad in ["", "128", "0x10", "x", "10x-1", "99999x1"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn plans_are_checked_before_the_gpu() {
        let mut p = BenchPlan::defaults(true);
        assert!(p.check().is_ok());
        assert_eq!(p.row_count(), p.scenes.len() * p.techniques.len() * 2);
        p.frames = 0;
        assert!(p.check().is_err());
        p.frames = 1;
        p.scenes = vec!["nosuch".into()];
        assert!(p.check().unwrap_err().to_string().contains("unknown scene"));
        p.scenes = vec!["bunny".into()];
        p.techniques = vec!["nosuch".into()];
        assert!(p.check().is_err());
        p.techniques = vec![];
        assert!(p.check().unwrap_err().to_string().contains("nothing to measure"));
    }
}
