//! `fuzz TARGET [--runs N] [--seconds S] [--seed K] [--dir D]`: mutation-fuzz one loader (engine_fuzz), or
//! `all`; prints executions per second and totals; exits 1 on any finding (the input is saved in D).

use engine_fuzz::{target, CountingAlloc, Driver, TARGETS};
use std::time::Duration;

#[global_allocator]
static ALLOC: CountingAlloc = CountingAlloc;

/// Mutation-fuzz one loader of the engine, or all of them.
#[derive(clap::Parser, Debug)]
#[command(name = "fuzz", after_help = targets_help())]
struct Args {
    /// A target (see below) or `all`.
    target: String,
    /// Executions per target.
    #[arg(long, default_value_t = 1_000_000)]
    runs: u64,
    /// Stop each target after this many seconds (> 0).
    #[arg(long, value_parser = seconds)]
    seconds: Option<Duration>,
    /// Seed of the mutations.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Where findings and the input being run are saved.
    #[arg(long, default_value = "out/fuzz")]
    dir: std::path::PathBuf,
}

fn targets_help() -> String {
    let names: Vec<&str> = TARGETS.iter().map(|t| t.name).collect();
    format!("targets: {}", names.join(", "))
}

fn seconds(s: &str) -> Result<Duration, String> {
    let v: f64 = s.parse().map_err(|_| format!("'{s}' is not a number of seconds"))?;
    if !v.is_finite() || v <= 0.0 {
        return Err(format!("{v}: must be a finite number of seconds > 0"));
    }
    Ok(Duration::from_secs_f64(v))
}

fn main() {
    scenes::init_logging();
    let Args { target: name, runs, seconds, seed, dir } = <Args as clap::Parser>::parse();
    let chosen: Vec<_> = match name.as_str() {
        "all" => TARGETS.iter().collect(),
        name => vec![target(name).unwrap_or_else(|| fail(&format!("unknown target '{name}' ({})", targets_help())))],
    };
    let mut found = 0;
    for t in chosen {
        let mut d = Driver::new(t, &dir, seed).unwrap_or_else(|e| fail(&format!("{}: {e}", dir.display())));
        eprintln!("fuzz {}: {runs} runs, seed {seed}; the input being run is {}", t.name, d.pending_path().display());
        let stats = d
            .run(runs, seconds, |s| {
                eprintln!(
                    "fuzz {}: {} executions, {:.0}/s, {} finding(s)",
                    t.name,
                    s.executions,
                    s.per_second(),
                    s.findings.len()
                )
            })
            .unwrap_or_else(|e| fail(&format!("{}: {e}", dir.display())));
        println!("{}", stats.summary(t.name));
        for f in &stats.findings {
            println!("  {} ({}): {}", f.kind, f.saved.display(), f.message);
        }
        found += stats.findings.len();
    }
    if found > 0 {
        std::process::exit(1);
    }
}

fn fail(message: &str) -> ! {
    eprintln!("fuzz: {message}");
    std::process::exit(2)
}
