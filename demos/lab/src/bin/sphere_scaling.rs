//! `sphere_scaling`: a technique's shading cost against the number of blocker spheres.
//!
//! Refits mesh 0 of the scene (the bunny) with each `--counts` value (fits cached in `<out>/spheres`),
//! renders every `--technique` for `--frames` frames (median GPU ms of the shading passes), prints a
//! table and writes `<out>/sphere_scaling.svg` (log-log, with a dashed line linear in n through the
//! first point of the first technique: a BVH should stay well below it).
//!
//! `cargo run --release -p lab --bin sphere_scaling -- --counts 16,64,256,1024 --technique isg`
//!
//! `--counters` adds the ISG cost model: each `isg` spec is also rendered with its counter variants
//! (`counters=traversal` and `counters=marking`) and the mean per covered pixel of each work count is
//! printed (BVH nodes visited by the hemisphere and by the lobe traversals, caps marked, cap rows, map
//! patch lookups, Ŝ corners).

use anyhow::{ensure, Context, Result};
use clap::Parser;
use engine::gpu::{Gpu, GpuDesc};
use engine::renderer::RenderSettings;
use lab::measure;
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(name = "sphere_scaling", about = "Shading cost against the number of blocker spheres")]
struct Args {
    /// Scene (the registry in demos/scenes).
    #[arg(long, default_value = "bunny", value_parser = scenes::value_parser())]
    scene: String,
    /// Sphere counts (comma-separated).
    #[arg(long, value_delimiter = ',', default_values_t = vec![16, 32, 64, 128, 256, 512, 1024])]
    counts: Vec<usize>,
    /// Technique specs (repeatable).
    #[arg(long = "technique", default_values_t = vec!["isg".to_string()])]
    techniques: Vec<String>,
    #[arg(long, default_value_t = 100)]
    width: u32,
    #[arg(long, default_value_t = 75)]
    height: u32,
    /// Frames per measurement (the median is reported).
    #[arg(long, default_value_t = 3)]
    frames: u32,
    #[arg(long)]
    per_vertex: bool,
    /// Also print the ISG cost model (mean work counts per covered pixel) of every `isg` spec.
    #[arg(long)]
    counters: bool,
    #[arg(long, default_value = "out/sphere_scaling")]
    out: PathBuf,
}

fn main() {
    scenes::init_logging();
    scenes::exit_on_error(run());
}

fn run() -> Result<()> {
    let args = Args::parse();
    ensure!(!args.counts.is_empty() && args.counts.iter().all(|&c| c >= 1), "--counts needs positive values");
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let gpu = Gpu::new(&GpuDesc::default())?;
    let result = measure_all(&gpu, &args);
    gpu.shutdown()?;
    let (device, rows, counts) = result?;
    println!(
        "scene {} {}x{}{}, {device}",
        args.scene,
        args.width,
        args.height,
        if args.per_vertex { " per vertex" } else { "" }
    );
    println!("| spheres | {} |", args.techniques.join(" | "));
    println!("|---|{}", "---|".repeat(args.techniques.len()));
    for (count, ms) in &rows {
        let cells: Vec<String> = ms.iter().map(|m| format!("{m:.1}")).collect();
        println!("| {count} | {} |", cells.join(" | "));
    }
    let mut p = plot::Plot::new(format!("shading cost against blocker spheres ({}, {device})", args.scene))
        .size(820.0, 500.0)
        .x_axis("blocker spheres", plot::Scale::Log10)
        .y_axis("GPU ms of the shading passes (median)", plot::Scale::Log10)
        .legend(plot::Legend::TopLeft);
    for (t, spec) in args.techniques.iter().enumerate() {
        let pts: Vec<(f64, f64)> = rows.iter().map(|(c, ms)| (*c as f64, ms[t])).collect();
        p = p.series(plot::Series::new(spec.clone(), pts, plot::Style::LineMarkers));
    }
    if let Some((c0, ms0)) = rows.first() {
        let linear = rows.iter().map(|(c, _)| (*c as f64, ms0[0] * *c as f64 / *c0 as f64)).collect();
        p = p.series(plot::Series::new("linear in n", linear, plot::Style::Line).dashed());
    }
    if !counts.is_empty() {
        println!("\nISG cost model, mean per covered pixel:");
        println!("| spheres | technique | {} |", COUNTER_NAMES.join(" | "));
        println!("|---|---|{}", "---:|".repeat(COUNTER_NAMES.len()));
        for (count, spec, c) in &counts {
            let cells: Vec<String> = c.iter().map(|m| format!("{m:.1}")).collect();
            println!("| {count} | {spec} | {} |", cells.join(" | "));
        }
    }
    let svg = args.out.join("sphere_scaling.svg");
    p.write(&svg).with_context(|| format!("writing {}", svg.display()))?;
    eprintln!("wrote {}", svg.display());
    Ok(())
}

/// The work counts of the ISG counter variants (shaders-glsl/common/isg_visibility.glsl), in order.
const COUNTER_NAMES: [&str; 6] =
    ["hemisphere BVH nodes", "lobe BVH nodes", "caps marked", "cap rows", "map patch lookups", "Ŝ corners"];

/// `spec` with `key=value` appended to its options.
fn with_option(spec: &str, key_value: &str) -> String {
    if spec.contains(':') {
        format!("{spec},{key_value}")
    } else {
        format!("{spec}:{key_value}")
    }
}

/// Mean per covered pixel of the six work counts of ISG spec `spec` (its two counter variants).
fn mean_counters(
    gpu: &Gpu,
    scene: &engine::scene::Scene,
    args: &Args,
    spec: &str,
    covered: &[bool],
) -> Result<Vec<f64>> {
    let n = covered.iter().filter(|&&c| c).count().max(1) as f64;
    let mut out = Vec::new();
    for variant in ["counters=traversal", "counters=marking"] {
        let settings = RenderSettings {
            width: args.width,
            height: args.height,
            technique: with_option(spec, variant),
            per_vertex: args.per_vertex,
            ..Default::default()
        };
        let m = measure::measure_technique(gpu, scene, settings, 1)?;
        for c in 0..3 {
            let sum: f64 = m.hdr.chunks_exact(4).zip(covered).filter(|(_, &k)| k).map(|(p, _)| p[c] as f64).sum();
            out.push(sum / n);
        }
    }
    Ok(out)
}

#[allow(clippy::type_complexity)]
fn measure_all(gpu: &Gpu, args: &Args) -> Result<(String, Vec<(usize, Vec<f64>)>, Vec<(usize, String, Vec<f64>)>)> {
    let mut rows = Vec::new();
    let mut counts = Vec::new();
    for &count in &args.counts {
        let mut scene = scenes::build(&args.scene, None)?;
        measure::refit_first_mesh(&mut scene, &args.scene, count, &args.out.join("spheres"))?;
        let mut ms = Vec::new();
        for spec in &args.techniques {
            let settings = RenderSettings {
                width: args.width,
                height: args.height,
                technique: spec.clone(),
                per_vertex: args.per_vertex,
                ..Default::default()
            };
            let m = measure::measure_technique(gpu, &scene, settings, args.frames)?;
            eprintln!("{count} spheres, {spec}: {:.1} ms", m.shade_ms);
            ms.push(m.shade_ms);
            if args.counters && (spec == "isg" || spec.starts_with("isg:")) {
                let covered: Vec<bool> = measure::object_regions(gpu, &scene, args.width, args.height)?
                    .iter()
                    .fold(vec![false; (args.width * args.height) as usize], |acc, r| {
                        acc.iter().zip(&r.pixels).map(|(a, b)| *a || *b).collect()
                    });
                counts.push((count, spec.clone(), mean_counters(gpu, &scene, args, spec, &covered)?));
            }
        }
        rows.push((count, ms));
    }
    Ok((gpu.info.name.clone(), rows, counts))
}
