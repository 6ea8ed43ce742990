//! `compare`: measure techniques against the Monte Carlo reference on one frame of a scene.
//!
//! For each `--technique SPEC` it renders `--frames` frames (median per-pass GPU times), then
//! converges the reference (sphere proxies and/or triangles; always per pixel, also with `--per-vertex`)
//! until its own relative standard error is at most `--fraction` of the error being measured, and prints relative RMSE (%) over covered
//! pixels, max error, FLIP mean, and the technique's shade time against the reference's time per
//! sample. Heat maps and images go to `--out`.
//!
//! `cargo run --release -p lab --bin compare -- --scene bunny --gloss 1000 --ks 0.5 --technique isg`

use anyhow::{bail, Context, Result};
use clap::Parser;
use engine::gpu::{Gpu, GpuDesc};
use engine::passes::shade::reference::Visibility;
use engine::renderer::RenderSettings;
use lab::measure::{self, file_stem};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(name = "compare", about = "Techniques against the Monte Carlo reference: relative RMSE, FLIP, GPU time")]
struct Args {
    /// Scene (the registry in demos/scenes).
    #[arg(long, default_value = "bunny", value_parser = scenes::value_parser())]
    scene: String,
    /// Environment map (.exr or .hdr) instead of the scene's.
    #[arg(long)]
    env: Option<PathBuf>,
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
    /// Specular BRDF of the glossy materials (applied after --gloss/--ks), as `demo --brdf`:
    /// `cook-torrance:roughness=0.1,ks=0.5`, `ashikhmin-shirley:nu=1000,nv=100,ks=0.5`, ….
    #[arg(long, value_name = "SPEC")]
    brdf: Option<String>,
    /// Reference visibility: `spheres` (the proxy ground truth), `triangles`, `both`, `unoccluded` (no
    /// shadows: the techniques' lighting and BRDF representation error alone), or `none` (only the
    /// techniques' times).
    #[arg(long, default_value = "both")]
    visibility: String,
    /// Refit mesh 0 (the bunny) with this many blocker spheres (cached in <out>/spheres/).
    #[arg(long)]
    spheres: Option<usize>,
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
    /// Per-vertex shading for the techniques. The reference is always rendered per pixel: a per-vertex
    /// technique is measured against the per-pixel truth, so its error includes what interpolating between
    /// vertices loses.
    #[arg(long)]
    per_vertex: bool,
    /// Drop the scene's plane blockers (the ground as a blocker): the sphere set alone, as before planes.
    #[arg(long)]
    no_plane_blockers: bool,
    /// Keep converged references in this folder, and reuse them. A file is keyed by everything that determines
    /// its image: the scene's content as built (the scene file and every file it loads, the environment, the
    /// overrides --gloss, --ks, --brdf, --spheres, --no-plane-blockers, --env, --time), the size, the
    /// visibility, --fraction, --max-spp and the reference's code (its version and its shaders' sources); an
    /// edited scene or mesh is a new file. The fraction rule converges against the techniques of the first
    /// run: pass a small `--fraction` (or rely on `--max-spp`) when caching.
    #[arg(long)]
    reference_cache: Option<PathBuf>,
    /// Measure the scene as its motion poses it at this time (s), frozen: instance transforms and bones from
    /// the motion, a simulated cloth run on the GPU to that time (scenes::cloth::frozen_at). With
    /// --reference-cache the time is part of the key (the motion and the cloth simulation are deterministic).
    #[arg(long)]
    time: Option<f32>,
    /// File scenes: the glTF camera N or NAME, or `auto` (as `demo --camera`).
    #[arg(long, value_name = "N|NAME|auto")]
    camera: Option<scenes::user::CameraChoice>,
    /// File scenes: `none`, `auto` or `engine` (as `demo --ground`).
    #[arg(long, value_name = "none|auto|engine")]
    ground: Option<scenes::user::GroundMode>,
    #[command(flatten)]
    env_lights: scenes::env_lights::EnvLightArgs,
    /// Measure one part of the environment split by the scene's settings (and the --env-lights* options), against a
    /// reference of that part alone: `residual` (the environment replaced by its residual, no environment lights)
    /// or `lights` (a black environment, the environment's bright regions as spherical lights beside the scene's).
    #[arg(long, value_enum, default_value = "whole")]
    env_part: scenes::env_lights::EnvPart,
    /// Measure a clip instead of a still: N consecutive frames, from --time (default 0) every --clip-step
    /// seconds, each technique against references of the same frames at --max-spp samples (no early stop, so
    /// every frame's reference has the same noise): error per frame (mean, max), the frame-to-frame change of
    /// the technique and of the reference, the flicker (the change the technique makes that the reference
    /// does not), net of the references' noise (lab::temporal). Writes clip.csv and clip-error-*.svg.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(3..=240))]
    clip: Option<u32>,
    /// Seconds between the clip's frames.
    #[arg(long, value_name = "S", default_value_t = 1.0 / 30.0, value_parser = parse_step)]
    clip_step: f32,
}

fn parse_step(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= 10.0 => Ok(v),
        _ => Err(format!("{s:?}: a number of seconds in (0, 10]")),
    }
}

fn main() {
    scenes::init_logging();
    scenes::exit_on_error(run());
}

fn run() -> Result<()> {
    let args = Args::parse();
    let opts = scenes::user::UserOptions { camera: args.camera.clone(), ground: args.ground, ..Default::default() };
    let mut scene = scenes::load(&args.scene, args.env.as_deref(), &opts)?.scene;
    if let Some(m) = scene.materials.first_mut() {
        if let Some(s) = args.gloss {
            m.shininess = s;
        }
        if let Some(k) = args.ks {
            m.specular = glam::Vec3::splat(k);
        }
    }
    if let Some(spec) = &args.brdf {
        scenes::apply_brdf(&mut scene, spec)?;
    }
    args.env_lights.apply(&mut scene);
    scenes::env_lights::keep_part(&mut scene, args.env_part);
    if args.no_plane_blockers {
        scene.blockers.planes.clear();
        scene.blockers.plane_meshes.clear();
    }
    let visibilities: Vec<(&str, Visibility)> = match args.visibility.as_str() {
        "both" => vec![("spheres", Visibility::Spheres), ("triangles", Visibility::Triangles)],
        "none" => Vec::new(),
        v => match measure::parse_visibility(v) {
            Ok(vis) => vec![(measure::visibility_name(vis), vis)],
            Err(_) => bail!("--visibility {v}: use spheres, triangles, both, unoccluded or none"),
        },
    };
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    if let Some(count) = args.spheres {
        measure::refit_first_mesh(&mut scene, &args.scene, count, &args.out.join("spheres"))?;
    }
    let gpu = Gpu::new(&GpuDesc::default())?;
    if let Some(n) = args.clip {
        let result = measure_clip(&gpu, &scene, &args, &visibilities, n);
        gpu.shutdown()?;
        return result;
    }
    if let Some(t) = args.time {
        scene = measure::freeze_at(&gpu, &args.scene, scene, t).with_context(|| format!("--time {t}"))?;
    }
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
        let m = measure::measure_technique(gpu, scene, settings(args, spec), args.frames)?;
        engine::output::write_png(&args.out.join(format!("{}.png", file_stem(spec))), w, h, &m.ldr)?;
        engine::output::write_exr(&args.out.join(format!("{}.exr", file_stem(spec))), w, h, &m.hdr)?;
        measured.push(m);
    }
    println!(
        "scene {}{}{} {}x{}{}, gloss {:?}, ks {:?}, brdf {}",
        args.scene,
        if args.no_plane_blockers { " (no plane blockers)" } else { "" },
        args.spheres.map(|n| format!(" ({n} spheres)")).unwrap_or_default(),
        w,
        h,
        if args.per_vertex { " per vertex" } else { "" },
        args.gloss,
        args.ks,
        args.brdf.as_deref().unwrap_or("(scene's)")
    );
    if visibilities.is_empty() {
        println!("| technique | shade ms |");
        println!("|---|---|");
        for m in &measured {
            println!("| {} | {:.2} |", m.spec, m.shade_ms);
        }
    }
    for (vis_name, vis) in visibilities {
        // Converge against the most accurate technique measured (the smallest error).
        eprintln!("converging the {vis_name} reference (max {} spp)...", args.max_spp);
        let against: Vec<&[f32]> = measured.iter().map(|m| m.hdr.as_slice()).collect();
        let run = measure::ReferenceRun {
            visibility: *vis,
            fraction: args.fraction,
            max_spp: args.max_spp,
            samples_per_frame: 16,
        };
        let cache = match &args.reference_cache {
            Some(dir) => Some(measure::reference_cache_file(gpu, dir, &args.scene, scene, w, h, &run)?),
            None => None,
        };
        let cached = cache.as_ref().filter(|p| p.exists()).map(|p| {
            eprintln!("reference from the cache {}", p.display());
            measure::ReferenceImage::load(p, *vis, (w * h) as usize)
        });
        let r = match cached {
            Some(r) => r?,
            None => {
                let r = measure::converge_reference(gpu, scene, &settings(args, "reference"), &run, &against)?;
                if let Some(p) = &cache {
                    if let Some(dir) = p.parent() {
                        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
                    }
                    r.save(p)?;
                }
                r
            }
        };
        println!(
            "reference ({vis_name}): {} spp in {:.0} s, relative standard error {:.3} % ({}converged), {:.1} ms per sample per pixel-frame",
            r.report.samples,
            r.seconds,
            100.0 * r.report.relative_stderr,
            if r.report.converged { "" } else { "not " },
            r.ms_per_sample
        );
        engine::output::write_png(&args.out.join(format!("reference-{vis_name}.png")), w, h, &r.ldr)?;
        engine::output::write_exr(&args.out.join(format!("reference-{vis_name}.exr")), w, h, &r.hdr)?;
        println!("| technique | vs {vis_name} reference: rel. RMSE % | minus reference noise % | max error | FLIP mean | shade ms | ref. samples at that time |");
        println!("|---|---|---|---|---|---|---|");
        for m in &measured {
            let e = measure::errors(&m.hdr, &m.ldr, &r, w, h);
            let stem = file_stem(&m.spec);
            measure::write_heatmap(&args.out.join(format!("{stem}-vs-{vis_name}-error.png")), &m.hdr, &r, w, h)?;
            println!(
                "| {} | {:.2} | {:.2} | {:.3} | {:.4} | {:.2} | {:.1} |",
                m.spec,
                e.rmse,
                e.debiased,
                e.max_abs,
                e.flip,
                m.shade_ms,
                m.shade_ms / r.ms_per_sample
            );
        }
    }
    Ok(())
}

/// `--clip N`: every technique and reference at N consecutive frames, then the clip's statistics per technique
/// and visibility (lab::temporal::clip_stats).
fn measure_clip(
    gpu: &Gpu,
    scene: &engine::scene::Scene,
    args: &Args,
    visibilities: &[(&str, Visibility)],
    n: u32,
) -> Result<()> {
    if visibilities.is_empty() {
        bail!("--clip needs a reference: --visibility spheres, triangles, both or unoccluded");
    }
    let (w, h) = (args.width, args.height);
    let t0 = args.time.unwrap_or(0.0);
    // [frame][technique] linear RGB, and [frame][visibility] reference.
    let mut techniques: Vec<Vec<Vec<[f32; 3]>>> = Vec::new();
    let mut references: Vec<Vec<measure::ReferenceImage>> = Vec::new();
    let mut shade_ms: Vec<Vec<f64>> = vec![Vec::new(); args.techniques.len()];
    for k in 0..n {
        let t = t0 + k as f32 * args.clip_step;
        eprintln!("clip frame {}/{n} at t = {t:.4} s...", k + 1);
        let frozen = measure::freeze_at(gpu, &args.scene, scene.clone(), t).with_context(|| format!("time {t}"))?;
        let mut row = Vec::new();
        for (i, spec) in args.techniques.iter().enumerate() {
            let m = measure::measure_technique(gpu, &frozen, settings(args, spec), args.frames)?;
            shade_ms[i].push(m.shade_ms);
            if k == 0 {
                engine::output::write_png(&args.out.join(format!("clip0-{}.png", file_stem(spec))), w, h, &m.ldr)?;
            }
            row.push(measure::rgb_items(&m.hdr));
        }
        techniques.push(row);
        let mut refs = Vec::new();
        for (vis_name, vis) in visibilities {
            let r = measure::reference_at(gpu, &frozen, &settings(args, "reference"), *vis, args.max_spp, 16)?;
            if k == 0 {
                engine::output::write_png(&args.out.join(format!("clip0-reference-{vis_name}.png")), w, h, &r.ldr)?;
            }
            refs.push(r);
        }
        references.push(refs);
    }
    println!(
        "scene {} {}x{}{}, clip of {n} frames from t = {t0} s every {} s, references at {} spp",
        args.scene,
        w,
        h,
        if args.per_vertex { " per vertex" } else { "" },
        args.clip_step,
        args.max_spp
    );
    let mut csv = String::from("technique,visibility,frame,time_s,error_pct\n");
    for (v, (vis_name, _)) in visibilities.iter().enumerate() {
        println!(
            "| technique | vs {vis_name}: mean error % | max error % | max/mean | change % | reference change % | \
             flicker % | step scaling (ref.) | shade ms |"
        );
        println!("|---|---|---|---|---|---|---|---|---|");
        let mut plot =
            lab::plot::Plot::new(format!("{}: error per frame against the {vis_name} reference", args.scene))
                .x_axis("time (s)", lab::plot::Scale::Linear)
                .y_axis("relative RMSE %, net of noise", lab::plot::Scale::Linear);
        for (i, spec) in args.techniques.iter().enumerate() {
            let frames: Vec<lab::temporal::ClipFrame> = (0..n as usize)
                .map(|k| lab::temporal::ClipFrame {
                    technique: &techniques[k][i],
                    reference: &references[k][v].halves,
                    covered: &references[k][v].mask,
                })
                .collect();
            let s = lab::temporal::clip_stats(&frames).context("no pixel is covered in every frame of the clip")?;
            println!(
                "| {spec} | {:.2} | {:.2} | {:.2} | {:.3} | {:.3} | {:.3} | {:.2} ({:.2}) | {:.2} |",
                s.error_mean,
                s.error_max,
                s.error_max / s.error_mean.max(1e-9),
                s.change,
                s.reference_change,
                s.flicker,
                s.step_scaling,
                s.reference_step_scaling,
                measure::median(shade_ms[i].clone())
            );
            let points: Vec<(f64, f64)> = s
                .error_per_frame
                .iter()
                .enumerate()
                .map(|(k, e)| ((t0 + k as f32 * args.clip_step) as f64, *e))
                .collect();
            for (k, (t, e)) in points.iter().enumerate() {
                csv.push_str(&format!("{spec},{vis_name},{k},{t:.6},{e:.4}\n"));
            }
            plot = plot.line(spec.clone(), points);
        }
        let svg = args.out.join(format!("clip-error-{vis_name}.svg"));
        std::fs::write(&svg, plot.to_svg()).with_context(|| format!("writing {}", svg.display()))?;
    }
    let path = args.out.join("clip.csv");
    std::fs::write(&path, csv).with_context(|| format!("writing {}", path.display()))?;
    eprintln!("wrote {} and clip-error-*.svg", path.display());
    Ok(())
}
