//! `demo`: render a scene headless (EXR + PNG + per-pass GPU times), or open the viewer.

use anyhow::Context;
use clap::Parser;
use engine::gpu::{Gpu, GpuDesc};
use engine::renderer::{RenderSettings, Renderer};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(name = "demo", about = "Soft-shadow renderer: render a scene headless or in a window")]
struct Args {
    /// Scene (the registry in demos/src/scenes).
    #[arg(long, default_value = "bunny", value_parser = demos::scenes::value_parser())]
    scene: String,
    /// Shading technique `NAME[:key=value,...]` (`--help` lists every registered technique and its
    /// options).
    #[arg(long, default_value = engine::renderer::DEFAULT_TECHNIQUE)]
    technique: String,
    /// Shade per vertex (interpolated) instead of per pixel.
    #[arg(long)]
    per_vertex: bool,
    /// Image width in pixels (default: 640 on a GPU, 320 on a CPU adapter such as lavapipe, where the
    /// default isg frame would otherwise take tens of seconds).
    #[arg(long)]
    width: Option<u32>,
    /// Image height in pixels (default: 480 on a GPU, 240 on a CPU adapter).
    #[arg(long)]
    height: Option<u32>,
    /// Environment map (.exr or .hdr, equirectangular, row 0 at the zenith) instead of the scene's (the furnace
    /// refuses it: its constant environment is what it tests).
    #[arg(long)]
    env: Option<PathBuf>,
    /// Exposure multiplier before tone mapping.
    #[arg(long, default_value_t = 1.0)]
    exposure: f32,
    /// Frames to render (times are reported as the median over them; --spp sets it for the reference).
    #[arg(long, default_value_t = 5)]
    frames: u32,
    /// Output folder.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Output file stem (<out>/<name>.exr and .png).
    #[arg(long, default_value = "default")]
    name: String,
    /// With --technique reference: accumulate N samples per pixel (at most 64 per frame; sets
    /// --frames) and print the reference's relative standard error (other techniques: ignored, with a warning).
    #[arg(long)]
    spp: Option<u32>,
    /// Use the Vulkan adapter whose name contains this text.
    #[arg(long)]
    device: Option<String>,
    /// Print device memory after the first frame and the allocations the later (steady) frames made.
    #[arg(long)]
    memory: bool,
    /// Open the interactive viewer instead of rendering to files (drag: orbit, wheel: zoom,
    /// T: technique, V: per-vertex/per-pixel, +/-: exposure, R: reset, Esc: quit).
    #[arg(long)]
    window: bool,
    /// With --window: quit after this many presented frames (0: when the window closes), printing
    /// `presented frame N` for each.
    #[arg(long, default_value_t = 0)]
    exit_after: u64,
    /// Performance capture: render N frames and write every frame's per-pass GPU times to
    /// <out>/capture/<name>.csv, .json and .svg (frame-time plot); prints median, p95 and max per pass.
    #[arg(long, value_name = "N")]
    capture: Option<u32>,
    #[arg(long, help = demos::scenes::animate_help())]
    animate: bool,
    /// Specular BRDF of material 0 (the bunny, sphere, plane or arm), `MODEL[:key=value,...]`
    /// (`--help` lists the models and their keys).
    #[arg(long, value_name = "SPEC")]
    brdf: Option<String>,
    /// Export the frame as a Mitsuba 3 scene into DIR (scene.xml, meshes/*.ply, envmap.exr; see
    /// demos/src/export.rs) and write our render of the same frame there as engine.exr / engine.png.
    #[arg(long, value_name = "DIR")]
    export: Option<PathBuf>,
}

fn main() {
    demos::exit_on_error(run());
}

/// The arguments, with `--technique` and `--brdf` help generated from the technique registry and the
/// BRDF schemas.
fn parse_args() -> Args {
    use clap::{CommandFactory, FromArgMatches};
    let technique_help = format!(
        "Shading technique NAME[:key=value,...] (default {}). Registered techniques and their options:\n{}",
        engine::renderer::DEFAULT_TECHNIQUE,
        engine::passes::shade::techniques_help()
    );
    let brdf_help = format!(
        "Specular BRDF of material 0 (the bunny, sphere, plane or arm), MODEL[:key=value,...]; keys not \
         given keep the material's values:\n{}",
        engine::scene::brdf_help()
    );
    let cmd = Args::command()
        .mut_arg("technique", |a| a.long_help(technique_help))
        .mut_arg("brdf", |a| a.long_help(brdf_help));
    Args::from_arg_matches(&cmd.get_matches()).unwrap_or_else(|e| e.exit())
}

fn run() -> anyhow::Result<()> {
    let mut args = parse_args();
    // Bad technique specs fail before any GPU work, naming the bad key.
    engine::passes::shade::parse_technique(&args.technique)?;
    let entry = demos::scenes::find(&args.scene)?;
    let mut scene = demos::scenes::build(entry.name, args.env.as_deref())?;
    if let Some(spec) = &args.brdf {
        demos::apply_brdf(&mut scene, spec)?;
    }
    // A window needs its display's surface extensions on the instance: open the display first.
    let (event_loop, surface_extensions) = match args.window {
        true => {
            let (el, ext) = demos::viewer::event_loop()?;
            (Some(el), ext)
        }
        false => (None, Vec::new()),
    };
    let gpu = Gpu::new(&GpuDesc { device_name: args.device.clone(), surface_extensions, ..GpuDesc::default() })?;
    let (default_w, default_h) = default_size(&gpu);
    let (width, height) = (args.width.unwrap_or(default_w), args.height.unwrap_or(default_h));
    (args.width, args.height) = (Some(width), Some(height));
    let settings = RenderSettings {
        width,
        height,
        technique: args.technique.clone(),
        per_vertex: args.per_vertex,
        exposure: args.exposure,
    };
    eprintln!("preparing scene '{}' with technique '{}' at {}x{}...", args.scene, args.technique, width, height);
    let t0 = std::time::Instant::now();
    let mut renderer = Renderer::new(&gpu, &scene, settings)?;
    eprintln!("prepared in {:.2} s", t0.elapsed().as_secs_f64());
    if args.spp.is_some() && engine::converge::reference_mut(&mut renderer).is_none() {
        eprintln!("warning: --spp applies to --technique reference only; ignored by '{}'", args.technique);
    }
    if let (Some(spp), Some(r)) = (args.spp, engine::converge::reference_mut(&mut renderer)) {
        let per_frame = spp.clamp(1, 64);
        r.set_options(engine::passes::shade::reference::ReferenceOptions {
            samples_per_frame: per_frame,
            ..r.options()
        })?;
        args.frames = spp.div_ceil(per_frame);
    }
    if let Some(dir) = &args.export {
        let opts = demos::export::ExportOptions { width, height, spp: 256, camera: None };
        let e = demos::export::export_mitsuba(&scene, dir, &opts)?;
        println!("wrote Mitsuba 3 scene {} ({} meshes, {})", e.xml.display(), e.meshes.len(), e.envmap.display());
        (args.out, args.name) = (dir.clone(), "engine".into());
    }
    let animation = if args.animate { demos::Animation::for_entry(entry, &scene) } else { None };
    if animation.is_some() && args.technique.starts_with("reference") {
        eprintln!(
            "warning: the reference's triangle BVH is built once at the first pose; with --animate its \
             triangle visibility does not follow the motion (sphere visibility does)"
        );
    }
    if args.animate && animation.is_none() {
        eprintln!(
            "warning: scene '{}' has no animation ({} do); rendering it static",
            args.scene,
            demos::scenes::animated_names()
        );
    }
    let result = match event_loop {
        Some(el) => demos::viewer::run(
            el,
            &gpu,
            &mut renderer,
            demos::viewer::ViewerOptions { exit_after: args.exit_after, animation },
        ),
        None => match args.capture {
            Some(n) => demos::capture::run(
                &gpu,
                &mut renderer,
                n,
                &args.out,
                &args.name,
                &capture_info(&gpu, &args),
                animation.as_ref(),
            ),
            None => render_frames(&gpu, &mut renderer, &args, animation.as_ref()),
        },
    };
    renderer.destroy(&gpu);
    gpu.shutdown()?;
    result
}

fn capture_info(gpu: &Gpu, args: &Args) -> demos::capture::CaptureInfo {
    demos::capture::CaptureInfo {
        device: gpu.info.name.clone(),
        scene: args.scene.clone(),
        technique: args.technique.clone(),
        per_vertex: args.per_vertex,
        width: args.width.unwrap_or(0),
        height: args.height.unwrap_or(0),
    }
}

/// The resolution when none is given: 640×480 on a GPU; 320×240 on a CPU adapter (lavapipe), where the
/// default technique costs ~20 s per 640×480 frame.
fn default_size(gpu: &Gpu) -> (u32, u32) {
    if gpu.info.device_type == "CPU" {
        (320, 240)
    } else {
        (640, 480)
    }
}

fn render_frames(
    gpu: &Gpu,
    renderer: &mut Renderer,
    args: &Args,
    animation: Option<&demos::Animation>,
) -> anyhow::Result<()> {
    let frames = args.frames.max(1);
    let mut per_pass: Vec<(String, Vec<f64>)> = Vec::new();
    let mut after_first = None;
    for f in 0..frames {
        if let Some(a) = animation {
            a.apply(renderer, f as f32 / 30.0)?;
        }
        let timings = renderer.render(gpu)?;
        if f == 0 {
            after_first = Some(gpu.memory_stats());
        }
        for t in timings {
            match per_pass.iter_mut().find(|(n, _)| *n == t.name) {
                Some((_, v)) => v.push(t.ms),
                None => per_pass.push((t.name, vec![t.ms])),
            }
        }
    }
    let after_last = gpu.memory_stats();
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let (w, h) = (renderer.settings.width, renderer.settings.height);
    let hdr = renderer.read_radiance(gpu)?;
    let bad = hdr.iter().filter(|v| !v.is_finite()).count();
    if bad > 0 {
        anyhow::bail!("{bad} non-finite values in the rendered image");
    }
    let exr = args.out.join(format!("{}.exr", args.name));
    let png = args.out.join(format!("{}.png", args.name));
    engine::output::write_exr(&exr, w, h, &hdr)?;
    engine::output::write_png(&png, w, h, &renderer.read_ldr(gpu)?)?;
    println!("wrote {} and {}", exr.display(), png.display());
    println!("per-pass GPU time on {} (median of {frames} frames, {w}x{h}):", gpu.info.name);
    let mut total = 0.0;
    for (name, mut v) in per_pass {
        v.sort_by(|a, b| a.total_cmp(b));
        let med = v[v.len() / 2];
        total += med;
        println!("  {name:<24} {med:>10.3} ms");
    }
    println!("  {:<24} {total:>10.3} ms", "total");
    let per_vertex = renderer.settings.per_vertex;
    if let Some(r) = engine::converge::reference_mut(renderer) {
        let stats = r.stats(gpu, per_vertex)?;
        println!(
            "reference: {} samples per item, relative standard error {:.3e}",
            stats.samples,
            stats.relative_stderr()
        );
    }
    if args.memory {
        let first = after_first.unwrap_or_default();
        let last = after_last;
        println!(
            "device memory after the first frame: {:.2} MiB in {} allocations ({:.2} MiB reserved in blocks)",
            first.allocated_bytes as f64 / 1048576.0,
            first.live_allocations,
            first.reserved_bytes as f64 / 1048576.0
        );
        println!(
            "allocations made by the {} steady frames after it: {} (live allocations {} -> {})",
            frames - 1,
            last.allocations_made - first.allocations_made,
            first.live_allocations,
            last.live_allocations
        );
    }
    Ok(())
}
