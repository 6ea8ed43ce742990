//! Performance capture (`demo --capture N`): the per-pass GPU time of every one of N frames, written as
//! CSV and JSON, summarised (median, p95, max per pass) and plotted (ms against frame index, SVG).
//!
//! Files, for `--out DIR --name STEM`:
//! - `DIR/capture/STEM.csv`: a header `frame,<pass>,...,total`, then one row per frame (ms; an empty cell where a
//!   pass did not run in that frame);
//! - `DIR/capture/STEM.json`: `{ "device", "scene", "technique", "per_vertex", "width", "height", "frames",
//!   "passes": [{ "name", "ms": [per frame, null where absent], "median", "p95", "max" }], "total": {...} }`;
//! - `DIR/capture/STEM.svg`: per-pass ms against frame index, one line per pass plus the frame total.

use anyhow::{Context, Result};
use engine::gpu::Gpu;
use engine::renderer::Renderer;
use serde_json::json;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The name of the per-frame sum of all passes in the files.
pub const TOTAL: &str = "total";

/// Per-pass GPU times of consecutive frames.
#[derive(Clone, Debug, Default)]
pub struct Capture {
    /// Pass names in first-seen order.
    pub passes: Vec<String>,
    /// `frames[f][p]`: ms of pass `p` in frame `f` (`None`: the pass did not run in that frame).
    pub frames: Vec<Vec<Option<f64>>>,
}

/// Order statistics of one pass over the captured frames (frames where it did not run are left out).
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    pub name: String,
    /// Frames the pass ran in.
    pub count: usize,
    /// Median (the mean of the two middle values for an even count).
    pub median: f64,
    /// 95th percentile, nearest rank: the ⌈0.95 n⌉-th smallest value.
    pub p95: f64,
    pub max: f64,
}

/// Median, p95 (nearest rank) and maximum of `v` (NaN for an empty slice).
pub fn order_stats(v: &[f64]) -> (f64, f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    let median = if n % 2 == 1 { s[n / 2] } else { 0.5 * (s[n / 2 - 1] + s[n / 2]) };
    let rank = ((0.95 * n as f64).ceil() as usize).clamp(1, n);
    (median, s[rank - 1], s[n - 1])
}

/// What the files record about the run besides the times.
#[derive(Clone, Debug, Default)]
pub struct CaptureInfo {
    pub device: String,
    pub scene: String,
    pub technique: String,
    pub per_vertex: bool,
    pub width: u32,
    pub height: u32,
}

impl Capture {
    /// Render `frames` frames, posing the scene first at t = frame / 30 s when `animation` is given, and record
    /// every pass time.
    pub fn record(
        gpu: &Gpu,
        renderer: &mut Renderer,
        frames: u32,
        animation: Option<&scenes::Animation>,
    ) -> Result<Self> {
        Self::record_from(gpu, renderer, 0, frames, animation)
    }

    /// [`Capture::record`] of frames `first..first + frames` of the animation (the bench's timed frames
    /// continue after its warm-up frames).
    pub fn record_from(
        gpu: &Gpu,
        renderer: &mut Renderer,
        first: u32,
        frames: u32,
        animation: Option<&scenes::Animation>,
    ) -> Result<Self> {
        let mut c = Capture::default();
        for f in first..first + frames {
            if let Some(a) = animation {
                a.apply(renderer, f as f32 / 30.0)?;
            }
            let timings = renderer.render(gpu)?;
            let mut row = vec![None; c.passes.len()];
            for t in timings {
                let i = match c.passes.iter().position(|n| *n == t.name) {
                    Some(i) => i,
                    None => {
                        c.passes.push(t.name);
                        row.push(None);
                        c.passes.len() - 1
                    }
                };
                // A pass recorded twice in one frame counts once with both times summed.
                row[i] = Some(row[i].unwrap_or(0.0) + t.ms);
            }
            c.frames.push(row);
        }
        Ok(c)
    }

    /// Times of pass `p` per frame (`None` where absent); a pass first seen in a later frame is absent before.
    pub fn column(&self, p: usize) -> Vec<Option<f64>> {
        self.frames.iter().map(|row| row.get(p).copied().flatten()).collect()
    }

    /// Sum of the passes of each frame.
    pub fn totals(&self) -> Vec<f64> {
        self.frames.iter().map(|row| row.iter().flatten().sum()).collect()
    }

    /// Order statistics per pass, then the frame total (named [`TOTAL`]).
    pub fn summary(&self) -> Vec<Summary> {
        let mut out = Vec::new();
        let mut add = |name: &str, v: Vec<f64>| {
            let (median, p95, max) = order_stats(&v);
            out.push(Summary { name: name.to_string(), count: v.len(), median, p95, max });
        };
        for (p, name) in self.passes.iter().enumerate() {
            add(name, self.column(p).into_iter().flatten().collect());
        }
        add(TOTAL, self.totals());
        out
    }

    pub fn to_csv(&self) -> String {
        let mut s = String::from("frame");
        for p in &self.passes {
            // Pass names are identifiers like `shade/isg`; quote anyway if one ever holds a comma.
            if p.contains([',', '"']) {
                let _ = write!(s, ",\"{}\"", p.replace('"', "\"\""));
            } else {
                let _ = write!(s, ",{p}");
            }
        }
        let _ = writeln!(s, ",{TOTAL}");
        let totals = self.totals();
        for (f, total) in totals.iter().enumerate() {
            let _ = write!(s, "{f}");
            for p in 0..self.passes.len() {
                match self.frames[f].get(p).copied().flatten() {
                    Some(ms) => {
                        let _ = write!(s, ",{ms:.6}");
                    }
                    None => s.push(','),
                }
            }
            let _ = writeln!(s, ",{total:.6}");
        }
        s
    }

    pub fn to_json(&self, info: &CaptureInfo) -> serde_json::Value {
        let summary = self.summary();
        let stat = |s: &Summary, ms: serde_json::Value| json!({ "name": s.name, "ms": ms, "count": s.count, "median": s.median, "p95": s.p95, "max": s.max });
        let passes: Vec<_> =
            self.passes.iter().enumerate().map(|(p, _)| stat(&summary[p], json!(self.column(p)))).collect();
        json!({
            "device": info.device,
            "scene": info.scene,
            "technique": info.technique,
            "per_vertex": info.per_vertex,
            "width": info.width,
            "height": info.height,
            "frames": self.frames.len(),
            "passes": passes,
            "total": stat(&summary[self.passes.len()], json!(self.totals())),
        })
    }

    /// Per-pass ms against frame index (one line per pass, the total dashed).
    pub fn plot(&self, title: &str) -> plot::Plot {
        let mut pl = plot::Plot::new(title)
            .size(900.0, 500.0)
            .x_axis("frame", plot::Scale::Linear)
            .y_axis("GPU ms", plot::Scale::Linear)
            .legend(plot::Legend::TopRight);
        for (p, name) in self.passes.iter().enumerate() {
            // A missing time is a gap (NaN), never a made-up zero.
            let pts = self.column(p).iter().enumerate().map(|(f, v)| (f as f64, v.unwrap_or(f64::NAN))).collect();
            pl = pl.series(plot::Series::new(name.clone(), pts, plot::Style::LineMarkers));
        }
        let pts = self.totals().iter().enumerate().map(|(f, &v)| (f as f64, v)).collect();
        pl.series(plot::Series::new(TOTAL, pts, plot::Style::Line).color("#000000").dashed())
    }

    /// Write `dir/stem.csv`, `.json` and `.svg`; returns the three paths.
    pub fn write(&self, dir: &Path, stem: &str, info: &CaptureInfo) -> Result<[PathBuf; 3]> {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let paths = ["csv", "json", "svg"].map(|e| dir.join(format!("{stem}.{e}")));
        let write = |p: &Path, s: String| std::fs::write(p, s).with_context(|| format!("writing {}", p.display()));
        write(&paths[0], self.to_csv())?;
        write(&paths[1], serde_json::to_string_pretty(&self.to_json(info))? + "\n")?;
        let title = format!(
            "{} / {}{} {}x{} on {}: GPU time per pass",
            info.scene,
            info.technique,
            if info.per_vertex { " per vertex" } else { "" },
            info.width,
            info.height,
            info.device
        );
        write(&paths[2], self.plot(&title).to_svg())?;
        Ok(paths)
    }

    /// The summary as a text table (one line per pass).
    pub fn summary_table(&self) -> String {
        let mut s = format!("{:<24} {:>10} {:>10} {:>10}\n", "pass", "median ms", "p95 ms", "max ms");
        for x in self.summary() {
            let _ = writeln!(s, "{:<24} {:>10.3} {:>10.3} {:>10.3}", x.name, x.median, x.p95, x.max);
        }
        s
    }
}

/// `demo --capture N`: render N frames, write the files to `out/capture/<name>.*`, print the summary.
pub fn run(
    gpu: &Gpu,
    renderer: &mut Renderer,
    frames: u32,
    out: &Path,
    name: &str,
    info: &CaptureInfo,
    animation: Option<&scenes::Animation>,
) -> Result<()> {
    eprintln!("capturing {frames} frames...");
    renderer.tile_counts(gpu)?; // the blocker tiles' counters restart
    let c = Capture::record(gpu, renderer, frames.max(1), animation)?;
    let paths = c.write(&out.join("capture"), name, info)?;
    println!("per-pass GPU time on {} over {} frames ({}x{}):", info.device, c.frames.len(), info.width, info.height);
    print!("{}", c.summary_table());
    // What the technique's BVH traversals tested (engine::passes::shade::tiles), for techniques that have them.
    if let Some(t) = renderer.tile_counts(gpu)? {
        println!("{}", t.line());
    }
    println!("wrote {}, {} and {}", paths[0].display(), paths[1].display(), paths[2].display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_statistics() {
        assert_eq!(order_stats(&[3.0, 1.0, 2.0]), (2.0, 3.0, 3.0));
        assert_eq!(order_stats(&[4.0, 1.0, 2.0, 3.0]).0, 2.5);
        // 20 values 1..=20: p95 is the 19th smallest.
        let v: Vec<f64> = (1..=20).map(f64::from).collect();
        assert_eq!(order_stats(&v), (10.5, 19.0, 20.0));
        assert!(order_stats(&[]).0.is_nan());
    }

    #[test]
    fn csv_marks_absent_passes_empty() {
        let c = Capture {
            passes: vec!["a".into(), "b".into()],
            frames: vec![vec![Some(1.0), None], vec![Some(2.0), Some(0.5)]],
        };
        let csv = c.to_csv();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], "frame,a,b,total");
        assert_eq!(lines[1], "0,1.000000,,1.000000");
        assert_eq!(lines[2], "1,2.000000,0.500000,2.500000");
        let s = c.summary();
        assert_eq!((s[1].count, s[1].median), (1, 0.5));
        assert_eq!(s[2].name, TOTAL);
        assert_eq!(s[2].max, 2.5);
    }
}
