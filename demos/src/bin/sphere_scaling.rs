//! `sphere_scaling`: a technique's shading cost against the number of blocker spheres.
//!
//! Refits mesh 0 of the scene (the bunny) with each `--counts` value (fits cached in `<out>/spheres`),
//! renders every `--technique` for `--frames` frames (median GPU ms of the shading passes), prints a
//! table and writes `<out>/sphere_scaling.svg` (log-log, with a dashed line linear in n through the
//! first point of the first technique: a BVH should stay well below it).
//!
//! `cargo run --release -p demos --bin sphere_scaling -- --counts 16,64,256,1024 --technique isg`

use anyhow::{ensure, Context, Result};
use clap::Parser;
use demos::measure;
use engine::gpu::{Gpu, GpuDesc};
use engine::renderer::RenderSettings;
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(name = "sphere_scaling", about = "Shading cost against the number of blocker spheres")]
struct Args {
    /// Scene (the registry in demos/src/scenes).
    #[arg(long, default_value = "bunny", value_parser = demos::scenes::value_parser())]
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
    #[arg(long, default_value = "out/sphere_scaling")]
    out: PathBuf,
}

fn main() {
    demos::exit_on_error(run());
}

fn run() -> Result<()> {
    let args = Args::parse();
    ensure!(!args.counts.is_empty() && args.counts.iter().all(|&c| c >= 1), "--counts needs positive values");
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let gpu = Gpu::new(&GpuDesc::default())?;
    let result = measure_all(&gpu, &args);
    gpu.shutdown()?;
    let (device, rows) = result?;
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
    let svg = args.out.join("sphere_scaling.svg");
    p.write(&svg).with_context(|| format!("writing {}", svg.display()))?;
    eprintln!("wrote {}", svg.display());
    Ok(())
}

#[allow(clippy::type_complexity)]
fn measure_all(gpu: &Gpu, args: &Args) -> Result<(String, Vec<(usize, Vec<f64>)>)> {
    let mut rows = Vec::new();
    for &count in &args.counts {
        let mut scene = demos::scenes::build(&args.scene, None)?;
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
        }
        rows.push((count, ms));
    }
    Ok((gpu.info.name.clone(), rows))
}
