//! `compare`: measure techniques against the Monte Carlo reference on one frame of a scene.
//!
//! For each `--technique SPEC` it renders `--frames` frames (median per-pass GPU times), then
//! converges the reference (sphere proxies and/or triangles) until its own relative standard error
//! is at most `--fraction` of the error being measured, and prints relative RMSE (%) over covered
//! pixels, max error, FLIP mean, and the technique's shade time against the reference's time per
//! sample. Heat maps and images go to `--out`.
//!
//! `cargo run --release -p demos --bin compare -- --scene bunny --gloss 1000 --ks 0.5 --technique isg`

use anyhow::{bail, Context, Result};
use clap::Parser;
use engine::gpu::{Gpu, GpuDesc};
use engine::metrics;
use engine::passes::shade::reference::{self, ReferenceOptions, Visibility};
use engine::renderer::{RenderSettings, Renderer};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(name = "compare", about = "Techniques against the Monte Carlo reference: relative RMSE, FLIP, GPU time")]
struct Args {
    #[arg(long, default_value = "bunny")]
    scene: String,
    /// Technique specs to measure (repeatable), e.g. `isg`, `isg:patches=8,K=4`, `none`.
    #[arg(long = "technique", default_values_t = vec!["isg".to_string()])]
    techniques: Vec<String>,
    #[arg(long, default_value_t = 200)]
    width: u32,
    #[arg(long, default_value_t = 150)]
    height: u32,
    /// Override the Blinn-Phong exponent of material 0 (the bunny).
    #[arg(long)]
    gloss: Option<f32>,
    /// Override k_s of material 0.
    #[arg(long)]
    ks: Option<f32>,
    /// Reference visibility: `spheres` (the proxy ground truth), `triangles`, or `both`.
    #[arg(long, default_value = "both")]
    visibility: String,
    /// Stop the reference when its relative standard error is this fraction of the measured error.
    #[arg(long, default_value_t = 0.2)]
    fraction: f64,
    /// Most samples per pixel for the reference.
    #[arg(long, default_value_t = 4096)]
    max_spp: u32,
    /// Frames per technique (times are medians).
    #[arg(long, default_value_t = 3)]
    frames: u32,
    #[arg(long, default_value = "out/compare")]
    out: PathBuf,
    /// Per-vertex shading for the techniques and the reference.
    #[arg(long)]
    per_vertex: bool,
}

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

struct Measured {
    spec: String,
    shade_ms: f64,
    hdr: Vec<f32>,
    ldr: Vec<u8>,
}

fn run() -> Result<()> {
    let args = Args::parse();
    let mut scene = demos::build_scene(&args.scene, None)?;
    if let Some(m) = scene.materials.first_mut() {
        if let Some(s) = args.gloss {
            m.shininess = s;
        }
        if let Some(k) = args.ks {
            m.specular = glam::Vec3::splat(k);
        }
    }
    let visibilities: Vec<(&str, Visibility)> = match args.visibility.as_str() {
        "spheres" => vec![("spheres", Visibility::Spheres)],
        "triangles" => vec![("triangles", Visibility::Triangles)],
        "both" => vec![("spheres", Visibility::Spheres), ("triangles", Visibility::Triangles)],
        v => bail!("--visibility {v}: use spheres, triangles or both"),
    };
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let gpu = Gpu::new(&GpuDesc::default())?;
    let result = measure(&gpu, &scene, &args, &visibilities);
    gpu.shutdown()?;
    result
}

fn settings(args: &Args, technique: &str) -> RenderSettings {
    RenderSettings {
        width: args.width,
        height: args.height,
        technique: technique.into(),
        per_vertex: args.per_vertex,
        ..Default::default()
    }
}

fn measure(gpu: &Gpu, scene: &engine::scene::Scene, args: &Args, visibilities: &[(&str, Visibility)]) -> Result<()> {
    let (w, h) = (args.width, args.height);
    let mut measured = Vec::new();
    for spec in &args.techniques {
        eprintln!("rendering {spec} ({} frames)...", args.frames);
        let mut r = Renderer::new(gpu, scene, settings(args, spec))?;
        let mut times = Vec::new();
        let frames = (|| -> Result<()> {
            for _ in 0..args.frames.max(1) {
                let t = r.render(gpu)?;
                times.push(t.iter().filter(|p| p.name.starts_with("shade/")).map(|p| p.ms).sum::<f64>());
            }
            Ok(())
        })();
        let images = frames.and_then(|_| Ok((r.read_radiance(gpu)?, r.read_ldr(gpu)?)));
        r.destroy(gpu);
        let (hdr, ldr) = images?;
        engine::output::write_png(&args.out.join(format!("{}.png", file_stem(spec))), w, h, &ldr)?;
        measured.push(Measured { spec: spec.clone(), shade_ms: median(times), hdr, ldr });
    }
    println!(
        "scene {} {}x{}{}, gloss {:?}, ks {:?}",
        args.scene,
        w,
        h,
        if args.per_vertex { " per vertex" } else { "" },
        args.gloss,
        args.ks
    );
    for (vis_name, vis) in visibilities {
        let mut r = Renderer::new(gpu, scene, settings(args, "reference"))?;
        let out = (|| -> Result<()> {
            let opts = ReferenceOptions { samples_per_frame: 16, seed: 1, visibility: *vis, ..Default::default() };
            reference::reference_mut(&mut r).context("reference technique")?.set_options(opts)?;
            // Converge against the most accurate technique measured (the smallest error).
            let items = |hdr: &[f32]| -> Vec<[f32; 3]> { hdr.chunks_exact(4).map(|p| [p[0], p[1], p[2]]).collect() };
            let first = items(&measured[0].hdr);
            eprintln!("converging the {vis_name} reference (max {} spp)...", args.max_spp);
            let t0 = std::time::Instant::now();
            let (report, stats) = reference::converge_against(gpu, &mut r, &first, args.fraction, args.max_spp)?;
            let ref_hdr: Vec<f32> = stats.mean.iter().flat_map(|m| [m[0], m[1], m[2], 1.0]).collect();
            let mask = &stats.covered;
            // One reference frame's time per sample, for the speed ratio at equal error.
            let t = r.render(gpu)?;
            let ref_ms_per_frame: f64 = t.iter().filter(|p| p.name.starts_with("shade/")).map(|p| p.ms).sum();
            let ref_ms_per_sample = ref_ms_per_frame / opts.samples_per_frame as f64;
            println!(
                "reference ({vis_name}): {} spp in {:.0} s, relative standard error {:.3} % ({}converged), {:.1} ms per sample per pixel-frame",
                report.samples,
                t0.elapsed().as_secs_f64(),
                100.0 * report.relative_stderr,
                if report.converged { "" } else { "not " },
                ref_ms_per_sample
            );
            let ref_ldr = r.read_ldr(gpu)?;
            engine::output::write_png(&args.out.join(format!("reference-{vis_name}.png")), w, h, &ref_ldr)?;
            println!("| technique | vs {vis_name} reference: rel. RMSE % | minus reference noise % | max error | FLIP mean | shade ms | ref. samples at that time |");
            println!("|---|---|---|---|---|---|---|");
            for m in &measured {
                let rmse = metrics::relative_rmse_percent(&m.hdr, &ref_hdr, mask);
                let max = metrics::max_error(&m.hdr, &ref_hdr, mask);
                let flip = metrics::flip_mean(&m.ldr, &ref_ldr, w, h, Some(mask));
                let stem = file_stem(&m.spec);
                let scale = ref_hdr.iter().copied().fold(0.0f32, f32::max).max(1e-6) * 0.1;
                metrics::write_error_heatmap(
                    &args.out.join(format!("{stem}-vs-{vis_name}-error.png")),
                    &m.hdr,
                    &ref_hdr,
                    mask,
                    w,
                    h,
                    scale,
                )?;
                // The measured RMSE² is the technique's error² plus the reference's own noise².
                let noise = 100.0 * report.relative_stderr;
                let debiased = (rmse * rmse - noise * noise).max(0.0).sqrt();
                println!(
                    "| {} | {:.2} | {:.2} | {:.3} | {:.4} | {:.2} | {:.1} |",
                    m.spec,
                    rmse,
                    debiased,
                    max.abs,
                    flip,
                    m.shade_ms,
                    m.shade_ms / ref_ms_per_sample
                );
            }
            Ok(())
        })();
        r.destroy(gpu);
        out?;
    }
    Ok(())
}

fn file_stem(spec: &str) -> String {
    spec.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect()
}
