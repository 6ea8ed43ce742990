//! `soak`: render many animated frames through the viewer's per-frame path without a window and check that
//! host and device memory stay flat and no validation error appears (lab::soak). Run by `cargo xtask soak`.

use anyhow::Context;
use clap::Parser;
use engine::gpu::{Gpu, GpuDesc};

#[derive(Parser, Debug)]
#[command(name = "soak", about = "Soak test: many animated frames, every technique in turn, memory must stay flat")]
struct Args {
    /// Frames in all, the warm-up cycle included.
    #[arg(long, default_value_t = 10_000, value_parser = clap::value_parser!(u64).range(1..))]
    frames: u64,
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=4096))]
    width: u32,
    #[arg(long, default_value_t = 48, value_parser = clap::value_parser!(u32).range(1..=4096))]
    height: u32,
    /// Scenes, comma-separated (default: every scene with an animation).
    #[arg(long, value_delimiter = ',')]
    scenes: Vec<String>,
    /// Frames per technique before the next one (half per pixel, half per vertex).
    #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u64).range(2..))]
    switch_every: u64,
    /// Allowed host (VmRSS) growth after the warm-up, MiB.
    #[arg(long, default_value_t = 8.0)]
    host_bound_mib: f64,
    /// Seconds between progress lines.
    #[arg(long, default_value_t = 10.0)]
    progress_s: f64,
}

fn main() {
    scenes::init_logging();
    scenes::exit_on_error(run());
}

fn run() -> anyhow::Result<()> {
    let args = Args::parse();
    let mut options = lab::soak::SoakOptions::new(args.frames);
    options.width = args.width;
    options.height = args.height;
    options.switch_every = args.switch_every;
    if !args.scenes.is_empty() {
        options.scenes = args.scenes;
    }
    anyhow::ensure!(args.host_bound_mib.is_finite() && args.host_bound_mib >= 0.0, "--host-bound-mib: not a size");
    options.host_growth_bound = (args.host_bound_mib * 1048576.0) as u64;
    anyhow::ensure!(args.progress_s.is_finite() && args.progress_s >= 0.0, "--progress-s: not a duration");
    options.progress_every = std::time::Duration::from_secs_f64(args.progress_s);
    eprintln!(
        "soak: {} frames at {}x{} over {} (a cycle is {} frames; the first is the warm-up)",
        options.frames,
        options.width,
        options.height,
        options.scenes.join(", "),
        options.cycle_frames()
    );
    let gpu = Gpu::new(&GpuDesc::default())?;
    let result = lab::soak::run(&gpu, &options);
    let teardown = gpu.shutdown().context("teardown after the soak");
    let report = result?;
    teardown?;
    println!("{}", report.summary());
    println!(
        "soak: passed (bounds after the warm-up: host +{:.1} MiB, device +{:.1} MiB and no more live allocations; no \
         validation error)",
        args.host_bound_mib,
        options.device_growth_bound as f64 / 1048576.0
    );
    Ok(())
}
