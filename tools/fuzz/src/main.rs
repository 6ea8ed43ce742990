//! `fuzz TARGET [--runs N] [--seconds S] [--seed K] [--dir D]`: mutation-fuzz one loader (engine_fuzz), or
//! `all`; prints executions per second and totals; exits 1 on any finding (the input is saved in D).

use engine_fuzz::{target, CountingAlloc, Driver, TARGETS};
use std::time::Duration;

#[global_allocator]
static ALLOC: CountingAlloc = CountingAlloc;

const USAGE: &str =
    "usage: fuzz TARGET|all [--runs N (default 1000000)] [--seconds S] [--seed K] [--dir D (default out/fuzz)]";

fn main() {
    // The workspace's logger set-up (demos::init_logging): RUST_LOG, warnings by default.
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.is_empty() || args.iter().any(|a| a == "--help" || a == "-h") {
        let names: Vec<&str> = TARGETS.iter().map(|t| t.name).collect();
        println!("{USAGE}\ntargets: {}", names.join(", "));
        return;
    }
    let (mut runs, mut seconds, mut seed, mut dir) = (1_000_000u64, None, 1u64, std::path::PathBuf::from("out/fuzz"));
    let mut it = args[1..].iter();
    while let Some(a) = it.next() {
        let v = it.next().unwrap_or_else(|| fail(&format!("{a} needs a value")));
        match a.as_str() {
            "--runs" => runs = v.parse().unwrap_or_else(|_| fail("--runs: not a count")),
            "--seconds" => {
                let s: f64 = v.parse().unwrap_or_else(|_| fail("--seconds: not a number"));
                if !s.is_finite() || s <= 0.0 {
                    fail("--seconds: must be > 0");
                }
                seconds = Some(Duration::from_secs_f64(s));
            }
            "--seed" => seed = v.parse().unwrap_or_else(|_| fail("--seed: not a number")),
            "--dir" => dir = v.into(),
            _ => fail(&format!("unknown option {a}")),
        }
    }
    let chosen: Vec<_> = match args[0].as_str() {
        "all" => TARGETS.iter().collect(),
        name => vec![target(name).unwrap_or_else(|| fail(&format!("unknown target '{name}'")))],
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
    eprintln!("fuzz: {message}\n{USAGE}");
    std::process::exit(2)
}
