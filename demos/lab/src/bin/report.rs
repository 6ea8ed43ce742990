//! `report`: the speed-against-error sweep (`cargo xtask report`; see demos/lab/src/report/).
//!
//! `cargo run --release -p lab --bin report -- [--tiny | --sweep NAME] [--config FILE] [--out DIR]`

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
    /// Sweep to run (`readme` writes the results page docs/results/ and the README's summary).
    #[arg(long, default_value = "full")]
    sweep: String,
    /// Run the `tiny` sweep (tiny sizes, few samples: seconds).
    #[arg(long)]
    tiny: bool,
    /// Output folder (default: the sweep's site folder, e.g. docs/results, else out/report).
    #[arg(long)]
    out: Option<PathBuf>,
}

fn main() {
    scenes::init_logging();
    scenes::exit_on_error(run());
}

fn run() -> Result<()> {
    let args = Args::parse();
    let config = args.config.clone().unwrap_or_else(lab::report::default_config);
    let name = if args.tiny { "tiny" } else { args.sweep.as_str() };
    let sweep = lab::report::load_sweep(&config, name)?;
    let out = match (&args.out, &sweep.site) {
        (Some(o), _) => o.clone(),
        (None, Some(site)) => lab::report::workspace_root().join(&site.out),
        (None, None) => PathBuf::from("out/report"),
    };
    // The command as `cargo xtask report` takes it (xtask passes its arguments through unchanged).
    let command = std::iter::once("cargo xtask report".to_string()).chain(std::env::args().skip(1)).collect::<Vec<_>>();
    let gpu = Gpu::new(&GpuDesc::default())?;
    let result = lab::report::run(&gpu, &sweep, &out, &command.join(" "));
    gpu.shutdown()?;
    result.map(|_| ())
}
