//! `sg_fit`: relative L2 error of the greedy K-lobe fit of environment maps, K = 1..=32, at the
//! resolution techniques `isg` and `lobes` fit (128×64), as a table and an SVG plot: spherical Gaussians
//! (`--kernel sg`, technique `isg`) or cosine lobes (`--kernel lobe`, technique `lobes:env=lobes`). The
//! refined fits also get their irradiance error (engine-math `fit_irradiance_error`: what diffuse
//! shading sees of the fit).
//!
//! `cargo run --release -p lab --bin sg_fit [-- --kernel lobe --env assets/envmaps/sunset.exr --plot out/lobe_fit.svg]`

use anyhow::Context;
use clap::Parser;
use engine::math::prefilter::resample;
use engine::math::sg::{fit_envmap, fit_irradiance_error, refine_envmap, EnvKernel};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(about = "SG or cosine-lobe fit error of environment maps against the number of lobes K")]
struct Args {
    /// Environment maps (default: the project's courtyard.exr and sunset.exr).
    #[arg(long)]
    env: Vec<PathBuf>,
    /// Largest K.
    #[arg(long, default_value_t = 32)]
    k_max: usize,
    /// The lobes fitted: sg (spherical Gaussians, technique isg) or lobe (cosine lobes, technique lobes).
    #[arg(long, default_value = "sg", value_parser = ["sg", "lobe"])]
    kernel: String,
    /// The plot (default: out/sg_fit.svg, or out/lobe_fit.svg for --kernel lobe).
    #[arg(long)]
    plot: Option<PathBuf>,
}

const ROWS: [usize; 8] = [1, 2, 4, 8, 10, 16, 20, 32];
const REFINE_ROUNDS: usize = engine::passes::shade::isg::REFINE_ROUNDS;

fn main() {
    scenes::init_logging();
    scenes::exit_on_error(run());
}

fn run() -> anyhow::Result<()> {
    let args = Args::parse();
    let envs = if args.env.is_empty() {
        let dir = scenes::assets_dir().join("envmaps");
        vec![dir.join("courtyard.exr"), dir.join("sunset.exr")]
    } else {
        args.env.clone()
    };
    let (kernel, label) =
        if args.kernel == "lobe" { (EnvKernel::CosineLobe, "cosine-lobe") } else { (EnvKernel::Sg, "SG") };
    let out = args
        .plot
        .clone()
        .unwrap_or_else(|| PathBuf::from(if kernel == EnvKernel::Sg { "out/sg_fit.svg" } else { "out/lobe_fit.svg" }));
    let mut plot = plot::Plot::new(format!("Greedy {label} fit of the environment (128×64)"))
        .x_axis("lobes K", plot::Scale::Linear)
        .y_axis("relative L2 error", plot::Scale::Log10);
    let mut curves: Vec<(String, Vec<f64>)> = Vec::new();
    for path in &envs {
        let env = engine::scene::load_environment(path)?;
        let t0 = std::time::Instant::now();
        let small = resample(&env, 128, 64);
        let (fits, errors) = fit_envmap(&small, args.k_max, kernel);
        eprintln!("{}: fitted K = 1..{} in {:.1} s", path.display(), args.k_max, t0.elapsed().as_secs_f64());
        let name = path.file_stem().and_then(|s| s.to_str()).context("file name")?.to_string();
        plot =
            plot.line(format!("{name} greedy"), errors.iter().enumerate().map(|(k, e)| ((k + 1) as f64, *e)).collect());
        // The refined fit (what `isg` uses) at the K of the table.
        let t0 = std::time::Instant::now();
        let mut irradiance = Vec::new();
        let refined: Vec<(f64, f64)> = ROWS
            .iter()
            .filter(|&&k| k <= args.k_max)
            .map(|&k| {
                let (lobes, e) = refine_envmap(&small, &fits[k - 1], REFINE_ROUNDS, kernel);
                irradiance.push(fit_irradiance_error(&small, &lobes, kernel));
                (k as f64, e)
            })
            .collect();
        eprintln!("{}: refined in {:.1} s", path.display(), t0.elapsed().as_secs_f64());
        plot = plot
            .series(plot::Series::new(format!("{name} refined"), refined.clone(), plot::Style::LineMarkers).dashed());
        curves.push((
            format!("{name} greedy"),
            ROWS.iter().filter(|&&k| k <= args.k_max).map(|&k| errors[k - 1]).collect::<Vec<f64>>(),
        ));
        curves.push((format!("{name} refined"), refined.iter().map(|r| r.1).collect()));
        curves.push((format!("{name} refined, irradiance"), irradiance));
    }
    let header: Vec<&str> = curves.iter().map(|(n, _)| n.as_str()).collect();
    println!("| K | {} |", header.join(" | "));
    println!("|---|{}", "---|".repeat(curves.len()));
    for (r, k) in ROWS.iter().filter(|&&k| k <= args.k_max).enumerate() {
        let row: Vec<String> = curves.iter().map(|(_, e)| format!("{:.3}", e[r])).collect();
        println!("| {k} | {} |", row.join(" | "));
    }
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir)?;
    }
    plot.write(&out)?;
    println!("wrote {}", out.display());
    Ok(())
}
