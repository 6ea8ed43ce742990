//! `report`: the speed-against-error sweep (`cargo xtask report`; see demos/src/report.rs).
//!
//! `cargo run --release -p demos --bin report -- [--tiny | --sweep NAME] [--config FILE] [--out DIR]`

use anyhow::Result;
use clap::Parser;
use engine::gpu::{Gpu, GpuDesc};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(name = "report", about = "Techniques × scenes × shading rates: GPU time and error against the reference")]
struct Args {
    /// Sweep config (JSON; named sweeps). Default: tools/report/sweep.json.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Sweep to run.
    #[arg(long, default_value = "full")]
    sweep: String,
    /// Run the `tiny` sweep (tiny sizes, few samples: seconds).
    #[arg(long)]
    tiny: bool,
    #[arg(long, default_value = "out/report")]
    out: PathBuf,
}

fn main() {
    demos::exit_on_error(run());
}

fn run() -> Result<()> {
    let args = Args::parse();
    let config = args.config.unwrap_or_else(demos::report::default_config);
    let name = if args.tiny { "tiny" } else { args.sweep.as_str() };
    let sweep = demos::report::load_sweep(&config, name)?;
    let gpu = Gpu::new(&GpuDesc::default())?;
    let result = demos::report::run(&gpu, &sweep, &args.out);
    gpu.shutdown()?;
    result.map(|_| ())
}
