//! `report`: the speed-against-error sweep (`cargo xtask report`; see demos/lab/src/report/).
//!
//! `cargo run --release -p lab --bin report -- [--tiny | --sweep NAME] [--config FILE] [--out DIR]`
//!
//! As jobs (docs/sweeps.md): `--emit-jobs FILE [--jobs-dir DIR]` writes the job files, each job runs
//! `--jobs-dir DIR --point POINT`, and `--merge DIR... [--out DIR] [--allow-missing]` writes the outputs.

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
    /// Write one shell command per point of the sweep into FILE (the technique points) and FILE.references (the
    /// scenes' references, to run first), for GNU parallel, a Slurm array or xargs (docs/sweeps.md).
    #[arg(long, value_name = "FILE")]
    emit_jobs: Option<PathBuf>,
    /// The folder the jobs write their points into (DIR/points/<key>); default: the job file's folder.
    #[arg(long, value_name = "DIR")]
    jobs_dir: Option<PathBuf>,
    /// The binary the emitted commands run (default: this one, by its absolute path; every host must have it).
    #[arg(long, value_name = "PATH")]
    job_exe: Option<PathBuf>,
    /// Run one point of the sweep into --jobs-dir (skipped when finished): LABEL/references or
    /// LABEL/SHADING/TECHNIQUE, as the job files write them.
    #[arg(long, requires = "jobs_dir")]
    point: Option<String>,
    /// Merge the finished points found in these jobs folders into the outputs (--out); lists the missing points
    /// and fails if any is missing.
    #[arg(long, num_args = 1.., value_name = "DIR")]
    merge: Vec<PathBuf>,
    /// With --merge: write the outputs from the points there are (the missing ones are still listed).
    #[arg(long, requires = "merge")]
    allow_missing: bool,
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
    if let Some(file) = &args.emit_jobs {
        let dir = args.jobs_dir.clone().unwrap_or_else(|| {
            file.parent().filter(|p| !p.as_os_str().is_empty()).map(PathBuf::from).unwrap_or_else(|| PathBuf::from("."))
        });
        let exe = match &args.job_exe {
            Some(e) => e.clone(),
            None => std::env::current_exe()?,
        };
        let (refs, techs) = lab::report::jobs::emit(&sweep, &config, name, &dir, file, &exe)?;
        let refs_file = lab::report::jobs::references_file(file);
        eprintln!(
            "wrote {refs} reference jobs to {} (run first) and {techs} technique jobs to {}; points go to {}/points",
            refs_file.display(),
            file.display(),
            dir.display()
        );
        return Ok(());
    }
    if !args.merge.is_empty() {
        lab::report::jobs::merge_and_write(&sweep, &args.merge, &out, args.allow_missing, &command.join(" "))?;
        return Ok(());
    }
    let gpu = Gpu::new(&GpuDesc::default())?;
    let result = match (&args.point, &args.jobs_dir) {
        (Some(spec), Some(dir)) => lab::report::jobs::find_point(&sweep, spec)
            .and_then(|p| lab::report::jobs::run_point(&gpu, &sweep, dir, &p))
            .map(|_| ()),
        _ => lab::report::run(&gpu, &sweep, &out, &command.join(" ")).map(|_| ()),
    };
    gpu.shutdown()?;
    result
}
