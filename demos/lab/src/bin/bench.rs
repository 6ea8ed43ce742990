//! `bench` (`cargo xtask bench`): per-pass GPU times of every scene × technique × shading rate × size,
//! written into `--out` (default `out/bench/`) as CSV, JSON, Markdown and SVG plots. See `lab::bench`.
//!
//! `cargo xtask bench --scene bunny --technique isg --size 128x96 --size 256x192`
//! `cargo xtask bench --compare out/bench-before/bench.csv`

use anyhow::{Context, Result};
use clap::Parser;
use engine::gpu::{Gpu, GpuDesc};
use lab::bench::{self, BenchPlan, Machine};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(
    name = "bench",
    about = "Per-pass GPU times of every scene × technique × shading rate (CSV, JSON, Markdown, plots)",
    after_help = "Defaults: every registered scene and technique, per pixel and per vertex; 128x96 with 2 warm-up \
                  and 10 timed frames on a CPU driver (lavapipe), 1920x1080 with 10 + 100 frames on a GPU. Animated \
                  scenes play their animation (t = frame / 30 s). fps = 1000 / median frame GPU time (the sum of \
                  the passes' timestamps)."
)]
struct Args {
    /// Scenes to measure (repeatable; default: every registered scene).
    #[arg(long = "scene", value_parser = scenes::value_parser())]
    scenes: Vec<String>,
    /// Technique specs (repeatable; default: every registered technique), e.g. `isg`, `isg:patches=8`.
    #[arg(long = "technique")]
    techniques: Vec<String>,
    /// Shading rate: pixel, vertex or both.
    #[arg(long, default_value = "both", value_parser = ["pixel", "vertex", "both"])]
    rate: String,
    /// Resolution WIDTHxHEIGHT (repeatable; default by adapter kind).
    #[arg(long = "size", value_parser = bench::parse_size)]
    sizes: Vec<(u32, u32)>,
    /// Frames rendered before timing (default by adapter kind).
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=100_000))]
    warmup: Option<u32>,
    /// Timed frames per row (default by adapter kind).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    frames: Option<u32>,
    /// Output folder.
    #[arg(long, default_value = "out/bench")]
    out: PathBuf,
    /// An earlier run's bench.csv: print and write (compare.md) the per-line ratios against it.
    #[arg(long, value_name = "CSV")]
    compare: Option<PathBuf>,
    /// Case-insensitive substring of the adapter name (default: ENGINE_DEVICE, else the automatic choice).
    #[arg(long)]
    device: Option<String>,
}

fn main() {
    scenes::init_logging();
    scenes::exit_on_error(run());
}

fn run() -> Result<()> {
    let args = Args::parse();
    // Everything that needs no GPU is checked first: the earlier CSV, the output folder.
    let earlier = args.compare.as_deref().map(bench::read_csv).transpose()?;
    plan(&args, true).check()?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("--out: creating {}", args.out.display()))?;
    let defaults = GpuDesc::default();
    let device_name = args.device.clone().or(defaults.device_name.clone().filter(|d| !d.is_empty()));
    let gpu = Gpu::new(&GpuDesc { device_name, ..defaults })?;
    let result = measure(&gpu, &args, earlier.as_deref());
    let teardown = gpu.shutdown();
    result?;
    teardown?;
    Ok(())
}

/// The plan the arguments ask for, with the defaults of a CPU or a GPU adapter where they are silent.
fn plan(args: &Args, cpu_adapter: bool) -> BenchPlan {
    let mut plan = BenchPlan::defaults(cpu_adapter);
    if !args.scenes.is_empty() {
        plan.scenes = args.scenes.clone();
    }
    if !args.techniques.is_empty() {
        plan.techniques = args.techniques.clone();
    }
    plan.rates = match args.rate.as_str() {
        "pixel" => vec![false],
        "vertex" => vec![true],
        _ => vec![false, true],
    };
    if !args.sizes.is_empty() {
        plan.sizes = args.sizes.clone();
    }
    plan.warmup = args.warmup.unwrap_or(plan.warmup);
    plan.frames = args.frames.unwrap_or(plan.frames);
    plan
}

fn measure(gpu: &Gpu, args: &Args, earlier: Option<&[bench::CsvLine]>) -> Result<()> {
    let plan = plan(args, gpu.info.device_type == "CPU");
    plan.check()?;
    let machine = Machine::of(gpu);
    eprintln!(
        "bench: {} rows ({} scenes × {} techniques × {} rates × {} sizes), {} warm-up + {} timed frames each, on {}",
        plan.row_count(),
        plan.scenes.len(),
        plan.techniques.len(),
        plan.rates.len(),
        plan.sizes.len(),
        plan.warmup,
        plan.frames,
        machine.adapter
    );
    let (rows, skipped) = bench::run(gpu, &plan)?;
    let paths = bench::write(&args.out, &machine, &rows, &skipped)?;
    print!("{}", bench::to_markdown(&machine, &rows, &skipped));
    if let Some(old) = earlier {
        let md = bench::compare(old, &bench::csv_lines(&machine, &rows));
        let p = args.out.join("compare.md");
        std::fs::write(&p, &md).with_context(|| format!("writing {}", p.display()))?;
        println!("\n{md}");
        println!("wrote {}", p.display());
    }
    for p in paths {
        println!("wrote {}", p.display());
    }
    Ok(())
}
