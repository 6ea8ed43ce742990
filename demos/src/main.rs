//! `demo`: render a scene headless (EXR + PNG + per-pass GPU times), or open the viewer.

use anyhow::Context;
use clap::Parser;
use engine::gpu::{Gpu, GpuDesc};
use engine::io::excerpt;
use engine::renderer::{RenderSettings, Renderer};
use scenes::limits;
use std::path::{Path, PathBuf};

/// The most samples per pixel `--spp` accepts: 1024 frames of [`SPP_PER_FRAME`]. Measured on lavapipe (2 cores), a
/// 64-sample bunny frame at 64×48 takes 0.54 s, so the maximum costs about 9 minutes there, with progress on
/// stderr; 4294967295 would have been 67 million frames. (The reference's own limit, `reference::MAX_SAMPLES`, is
/// 2^24.)
const MAX_SPP: u32 = 1 << 16;
/// The most samples one reference frame adds (one submission; keeps each frame's GPU time bounded).
const SPP_PER_FRAME: u32 = 64;
/// The longest `--name`: the file name `<name>.exr` must fit the file system's 255 bytes.
const MAX_NAME_BYTES: usize = 255 - ".exr".len();
/// A long run reports progress on stderr this often (seconds; `DEMO_PROGRESS_S` overrides, 0: every frame).
const PROGRESS_EVERY_S: f64 = 2.0;
/// Largest `DEMO_PROGRESS_S`: a day.
const MAX_PROGRESS_S: f64 = 86400.0;

#[derive(Parser, Debug)]
#[command(name = "demo", about = "Soft-shadow renderer: render a scene headless or in a window")]
struct Args {
    /// Scene: a registered name (the registry in demos/scenes), or a file: .gltf, .glb or .obj (one model on a
    /// ground plane, framed, spheres fitted and cached) or .toml (a scene description; docs/scene-files.md).
    #[arg(long, default_value = "bunny", value_parser = scenes::value_parser())]
    scene: String,
    /// File scenes: blocker spheres fitted per mesh (0: none; a scene file's `spheres` key wins) [default: 32].
    /// Fits are cached by mesh content in $SOFTSHADOWS_SPHERE_CACHE (default ~/.cache/softshadows/spheres).
    #[arg(long, allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(0..=limits::MODEL_SPHERES.hi as i64))]
    spheres: Option<u32>,
    /// File scenes with --animate: play only the animation clip NAME (default: every clip in turn).
    #[arg(long, value_name = "NAME", requires = "animate")]
    clip: Option<String>,
    /// File scenes: the glTF camera N (its index in the file's `cameras`) or NAME, or `auto` (framed) [default: the
    /// file's first camera, else framed; a scene file's [camera]].
    #[arg(long, value_name = "N|NAME|auto")]
    camera: Option<scenes::user::CameraChoice>,
    /// File scenes: `engine` (a ground plane under the models), `none`, or `auto` (the engine's ground unless the
    /// model brings its own floor) [default: auto, or a scene file's ground.mode].
    #[arg(long, value_name = "none|auto|engine")]
    ground: Option<scenes::user::GroundMode>,
    /// Shading technique `NAME[:key=value,...]` (`--help` lists every registered technique and its
    /// options).
    #[arg(long, default_value = engine::renderer::DEFAULT_TECHNIQUE)]
    technique: String,
    /// Shade per vertex (interpolated) instead of per pixel.
    #[arg(long)]
    per_vertex: bool,
    /// Image width in pixels, 1 to 16384 (default: 640 on a GPU, 320 on a CPU adapter such as lavapipe, where the
    /// default isg frame would otherwise take tens of seconds).
    #[arg(long, allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(1..=engine::renderer::MAX_RESOLUTION as i64))]
    width: Option<u32>,
    /// Image height in pixels, 1 to 16384 (default: 480 on a GPU, 240 on a CPU adapter).
    #[arg(long, allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(1..=engine::renderer::MAX_RESOLUTION as i64))]
    height: Option<u32>,
    /// Environment map (.exr or .hdr, equirectangular, row 0 at the zenith) instead of the scene's (every scene
    /// loads it, except the furnace, which refuses it: its constant environment is what it tests).
    #[arg(long)]
    env: Option<PathBuf>,
    /// Rotate the environment about +y by DEG degrees (within ±100000; the viewer's E key turns it further in 30°
    /// steps).
    #[arg(long, value_name = "DEG", default_value_t = 0.0, value_parser = parse_rotation, allow_negative_numbers = true)]
    env_rotation: f32,
    /// Turn the environment continuously about +y by DEG degrees per second of animation time (frame f at f/30 s,
    /// on top of --env-rotation; the viewer follows its clock): the chess scene's rotating environment (ISG
    /// Fig. 7). Each frame rebuilds the environment's maps and prepares the technique again (as the viewer's E
    /// key: ~0.7 s at 32×24 on lavapipe), so it is an event per frame, not a shader rotation.
    #[arg(long, value_name = "DEG", value_parser = parse_spin, allow_negative_numbers = true)]
    env_spin: Option<f32>,
    /// Exposure multiplier before tone mapping (a number in [1e-6, 1e6]).
    #[arg(long, default_value_t = 1.0, value_parser = parse_exposure, allow_negative_numbers = true)]
    exposure: f32,
    /// Frames to render, at least 1 (times are reported as the median over them) [default: 5; with --spp:
    /// as many as the samples need].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..), conflicts_with = "spp")]
    frames: Option<u32>,
    /// Output folder (checked writable before anything renders, created when the images are written).
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Output file stem (<out>/<name>.exr and .png): not empty, no path separator, not `.` or `..`.
    #[arg(long, default_value = "default", value_parser = parse_name)]
    name: String,
    /// With --technique reference only: accumulate exactly N samples per pixel (N in 1..=65536; at most 64 per
    /// frame, so ⌈N/64⌉ frames) and print the reference's relative standard error. Runs longer than 2 s print
    /// their progress on stderr every 2 s (DEMO_PROGRESS_S sets the interval).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=MAX_SPP as i64))]
    spp: Option<u32>,
    /// Use the Vulkan adapter whose name contains this text (default: $ENGINE_DEVICE if set, else automatic:
    /// discrete > integrated > virtual > CPU). Not empty.
    #[arg(long, value_parser = clap::builder::NonEmptyStringValueParser::new())]
    device: Option<String>,
    /// Print device memory after the first frame and the allocations the later (steady) frames made.
    #[arg(long, conflicts_with_all = ["window", "capture"])]
    memory: bool,
    /// Open the interactive viewer instead of rendering to files (drag: orbit, wheel: zoom,
    /// T: technique, B: BRDF of the glossy materials (diffuse, Blinn-Phong, Ashikhmin-Shirley, GGX),
    /// E: turn the environment 30°, V: per-vertex/per-pixel, +/-: exposure, R: reset, with --animate P/space: pause, ./,: step a
    /// frame, Esc: quit).
    #[arg(long, conflicts_with_all = ["frames", "spp", "capture", "export"])]
    window: bool,
    /// With --window: quit after this many presented frames (0: when the window closes), printing
    /// `presented frame N` for each.
    #[arg(long, requires = "window")]
    exit_after: Option<u64>,
    /// Performance capture: render N ≥ 1 frames and write every frame's per-pass GPU times to
    /// <out>/capture/<name>.csv, .json and .svg (frame-time plot); prints median, p95 and max per pass.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..), conflicts_with_all = ["frames", "spp"])]
    capture: Option<u32>,
    #[arg(long, help = scenes::animate_help())]
    animate: bool,
    /// Specular BRDF of the scene's glossy materials (k_s > 0; material 0 if none is glossy), `MODEL[:key=value,...]`
    /// (`--help` lists the models and their keys).
    #[arg(long, value_name = "SPEC")]
    brdf: Option<String>,
    /// Export the frame as a Mitsuba 3 scene into DIR (scene.xml, meshes/*.ply, envmap.exr, the BRDF plugin
    /// ours_bsdf.py and the runner render.py; see demos/lab/src/export.rs) and write our render of the same frame
    /// there as engine.exr / engine.png. `python3 DIR/render.py --spp N` renders it and compares.
    #[arg(long, value_name = "DIR")]
    export: Option<PathBuf>,
    /// With --export: `plugin` writes our exact BRDFs as a Mitsuba Python plugin (ours_bsdf.py; the scene then
    /// loads from Python only), `builtin` Mitsuba's own diffuse + roughconductor approximation of Blinn-Phong
    /// (loads in the `mitsuba` command line; refuses the other models).
    #[arg(long, value_name = "KIND", default_value = "plugin", requires = "export",
          value_parser = lab::export::ExportBsdf::parse)]
    export_bsdf: lab::export::ExportBsdf,
    #[command(flatten)]
    env_lights: scenes::env_lights::EnvLightArgs,
    /// Split the scene's environment into lights and a residual (as `env_lights=on` does), print the lights and
    /// write <out>/<name>-env-lights.png: the map over the residual, each light's cap outlined. No GPU is used.
    #[arg(long, conflicts_with_all = ["window", "capture", "export", "spp", "frames", "memory"])]
    env_lights_preview: bool,
}

/// `--exposure`: in [1e-6, 1e6] (NaN, infinities, zero and negative values give a black or undefined image; a
/// denormal a black one). The range is the shared table's (`scenes::limits`).
fn parse_exposure(s: &str) -> Result<f32, String> {
    limits::EXPOSURE
        .parse(s)
        .map(|x| x as f32)
        .map_err(|m| format!("{m}: the exposure multiplies the radiance before tone mapping"))
}

/// `--env-rotation` (degrees): finite, within ±100000, the range of a scene file's `environment.rotation`
/// (`scenes::limits`).
fn parse_rotation(s: &str) -> Result<f32, String> {
    limits::ENV_ROTATION.parse(s).map(|x| x as f32)
}

/// `--env-spin` (degrees per second): finite, within ±100000 (`scenes::limits`).
fn parse_spin(s: &str) -> Result<f32, String> {
    limits::ENV_SPIN.parse(s).map(|x| x as f32)
}

/// `--name`: a file stem inside `--out`, never a path that leaves it or names the folder itself, and short enough
/// for `<name>.exr` to be a file name (checked here, before any work: it used to fail after the frame rendered).
fn parse_name(s: &str) -> Result<String, String> {
    if s.is_empty() || s == "." || s == ".." || s.contains(['/', '\\', '\0']) {
        Err(format!(
            "'{}' is not a file name (it must be non-empty, without '/' or '\\', and not '.' or '..')",
            excerpt(s)
        ))
    } else if s.len() > MAX_NAME_BYTES {
        Err(format!(
            "'{}' is {} bytes: a name holds at most {MAX_NAME_BYTES} (the file <name>.exr must fit 255 bytes)",
            excerpt(s),
            s.len()
        ))
    } else {
        Ok(s.to_string())
    }
}

fn main() {
    scenes::init_logging();
    scenes::exit_on_error(run());
}

/// The arguments, with `--technique` and `--brdf` help generated from the technique registry and the
/// BRDF schemas.
fn parse_args() -> Args {
    use clap::{CommandFactory, FromArgMatches};
    let technique_help = format!(
        "Shading technique NAME[:key=value,...] (default {}; each key at most once). Registered techniques and \
         their options:\n{}",
        engine::renderer::DEFAULT_TECHNIQUE,
        engine::passes::shade::techniques_help()
    );
    let brdf_help = format!(
        "Specular BRDF of the scene's glossy materials (k_s > 0; material 0 if none is glossy: the bunny, the \
         chess pieces, the sphere, the arm), MODEL[:key=value,...]; keys not \
         given keep the material's values:\n{}",
        engine::scene::brdf_help()
    );
    let mut cmd = Args::command()
        .mut_arg("technique", |a| a.long_help(technique_help))
        .mut_arg("brdf", |a| a.long_help(brdf_help));
    let args = cmd.try_get_matches_from_mut(std::env::args_os()).and_then(|m| Args::from_arg_matches(&m));
    let args = args.unwrap_or_else(|e| exit_on_usage_error(e));
    // clap skips `requires = "window"` when an option that conflicts with --window is given (--frames,
    // --capture): the run then ignored --exit-after and exited 0.
    if args.exit_after.is_some() && !args.window {
        let e = cmd.error(
            clap::error::ErrorKind::MissingRequiredArgument,
            "--exit-after applies to --window only (it counts presented frames)",
        );
        exit_on_usage_error(e);
    }
    args
}

/// Print a usage error as clap does, but with any input it quotes cut short (`engine::io::shorten`: a 100 kB
/// value was echoed whole), and exit with its status (2). Help and version go out unchanged.
fn exit_on_usage_error(e: clap::Error) -> ! {
    if !e.use_stderr() {
        e.exit();
    }
    eprint!("{}", engine::io::shorten(&e.render().to_string()));
    std::process::exit(e.exit_code());
}

/// Samples per frame for `--spp n`: ⌈n / 64⌉ frames, spread evenly (counts differ by at most one and sum to
/// exactly `n`; the reference merges batches of any size, integrate.glsl's Chan et al. update).
fn spp_schedule(n: u32) -> Vec<u32> {
    let frames = n.div_ceil(SPP_PER_FRAME);
    (0..frames).map(|f| n / frames + u32::from(f < n % frames)).collect()
}

/// Check, before any GPU work, that `dir` is or can become a folder the demo writes in: an unusable output folder
/// is found in milliseconds, not after every frame has rendered. Nothing is created: the probe file goes into
/// `dir`, or into its nearest existing ancestor when `dir` does not exist yet (the writes create it).
fn check_output_dir(dir: &Path, what: &str) -> anyhow::Result<()> {
    let mut existing = dir;
    while !existing.exists() {
        existing = match existing.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
    }
    anyhow::ensure!(existing.is_dir(), "{what} {}: {} is not a folder", dir.display(), existing.display());
    let probe = existing.join(format!(".demo-write-check-{}", std::process::id()));
    std::fs::write(&probe, b"")
        .with_context(|| format!("{what} {}: cannot write in {}", dir.display(), existing.display()))?;
    std::fs::remove_file(&probe).with_context(|| format!("removing {}", probe.display()))?;
    Ok(())
}

/// An output file that exists must be a file (a folder in its place would only fail at the write).
fn check_output_file(path: &Path) -> anyhow::Result<()> {
    anyhow::ensure!(!path.is_dir(), "cannot write {}: it is a folder", path.display());
    Ok(())
}

/// The progress interval: `DEMO_PROGRESS_S` (a number of seconds ≥ 0; 0: every frame), else
/// [`PROGRESS_EVERY_S`]. A value that is not such a number is an error naming it (it used to be ignored).
fn progress_interval() -> anyhow::Result<f64> {
    match std::env::var("DEMO_PROGRESS_S") {
        Err(std::env::VarError::NotPresent) => Ok(PROGRESS_EVERY_S),
        Err(std::env::VarError::NotUnicode(v)) => anyhow::bail!("DEMO_PROGRESS_S={v:?}: not a number of seconds"),
        Ok(v) => match v.trim().parse::<f64>() {
            Ok(s) if s.is_finite() && (0.0..=MAX_PROGRESS_S).contains(&s) => Ok(s),
            _ => anyhow::bail!(
                "DEMO_PROGRESS_S={}: not a number of seconds in [0, {MAX_PROGRESS_S}] (0: a line every frame)",
                excerpt(&v)
            ),
        },
    }
}

/// Everything the arguments say that can be checked without a GPU: the technique spec (each key once), the
/// reference-only options, the progress interval, the output folders and files.
fn check_args(args: &Args) -> anyhow::Result<()> {
    progress_interval()?;
    let (technique, _) = engine::passes::shade::parse_technique(&args.technique).context("--technique")?;
    if args.spp.is_some() && technique.name != engine::passes::shade::reference::ENTRY.name {
        anyhow::bail!(
            "--spp applies to --technique reference only ('{}' renders one deterministic image per frame)",
            technique.name
        );
    }
    if args.window {
        return Ok(());
    }
    let (out, name) = output_target(args);
    if args.env_lights_preview {
        check_output_dir(&out, "--out")?;
        return check_output_file(&out.join(format!("{name}-env-lights.png")));
    }
    if args.capture.is_some() {
        check_output_dir(&out.join("capture"), "--out")?;
        for ext in ["csv", "json", "svg"] {
            check_output_file(&out.join("capture").join(format!("{name}.{ext}")))?;
        }
    } else {
        check_output_dir(&out, if args.export.is_some() { "--export" } else { "--out" })?;
        for ext in ["exr", "png"] {
            check_output_file(&out.join(format!("{name}.{ext}")))?;
        }
    }
    Ok(())
}

/// Where the images go: `--out`/`--name`, or the export folder as `engine.exr`/`engine.png`.
fn output_target(args: &Args) -> (PathBuf, String) {
    match &args.export {
        Some(dir) => (dir.clone(), "engine".into()),
        None => (args.out.clone(), args.name.clone()),
    }
}

fn run() -> anyhow::Result<()> {
    let mut args = parse_args();
    // Bad specs, options that do not apply and unusable outputs fail before any GPU work.
    check_args(&args)?;
    let opts = scenes::user::UserOptions {
        spheres: args.spheres.map(|n| n as usize),
        clip: args.clip.clone(),
        camera: args.camera.clone(),
        ground: args.ground,
        ..Default::default()
    };
    let loaded = scenes::load(&args.scene, args.env.as_deref(), &opts)?;
    let mut scene = loaded.scene;
    if args.env_rotation.rem_euclid(360.0) != 0.0 {
        scene.environment = scene.environment.rotated_y(args.env_rotation);
    }
    if let Some(spec) = &args.brdf {
        scenes::apply_brdf(&mut scene, spec)?;
    }
    args.env_lights.apply(&mut scene);
    if args.env_lights_preview {
        let path = args.out.join(format!("{}-env-lights.png", args.name));
        for line in scenes::env_lights::write_preview(&scene, &path)? {
            println!("{line}");
        }
        return Ok(());
    }
    let animation = if args.animate { loaded.animation } else { None };
    if args.animate && animation.is_none() {
        eprintln!(
            "warning: scene '{}' has no animation ({} do, and files with glTF clips); rendering it static",
            args.scene,
            scenes::animated_names()
        );
    }
    if args.env_spin.is_some() && (args.spp.is_some() || args.capture.is_some()) {
        anyhow::bail!(
            "--env-spin with {}: every turn of the environment restarts the technique's preparation; drop one of them",
            if args.spp.is_some() {
                "--spp (the reference would restart its samples every frame)"
            } else {
                "--capture"
            }
        );
    }
    if animation.is_some() && args.spp.is_some() {
        // Every frame is a new pose and the reference restarts its accumulation at each one.
        anyhow::bail!("--spp with --animate: the reference restarts its samples at every new pose; drop one of them");
    }
    // A window needs its display's surface extensions on the instance: open the display first.
    let (event_loop, surface_extensions) = match args.window {
        true => {
            let (el, ext) = demos::viewer::event_loop()?;
            (Some(el), ext)
        }
        false => (None, Vec::new()),
    };
    // `--device` wins; without it, GpuDesc::default() reads ENGINE_DEVICE (an empty value counts as unset).
    let defaults = GpuDesc::default();
    let device_name = args.device.clone().or(defaults.device_name.clone().filter(|d| !d.is_empty()));
    let from_env = args.device.is_none().then(|| device_name.clone()).flatten();
    let gpu = Gpu::new(&GpuDesc { device_name, surface_extensions, ..defaults }).map_err(|e| match &from_env {
        // The engine's message speaks of --device; say where the text came from.
        Some(name) => anyhow::Error::new(e).context(format!("ENGINE_DEVICE={name}")),
        None => e.into(),
    })?;
    // From here on every error path releases what it made before returning, so the error prints alone.
    let result = render_on(&gpu, &mut args, &scene, &loaded.label, animation, event_loop);
    let teardown = gpu.shutdown();
    match (result, teardown) {
        (Ok(()), t) => t.map_err(Into::into),
        // A teardown problem after an error is a second fault; name it after the first, in one message.
        (Err(e), Err(t)) => Err(anyhow::anyhow!("{e:#}\n(and the teardown after it failed: {t})")),
        (Err(e), Ok(())) => Err(e),
    }
}

/// Everything that needs the GPU: the renderer is destroyed on every path out.
fn render_on(
    gpu: &Gpu,
    args: &mut Args,
    scene: &engine::scene::Scene,
    label: &str,
    animation: Option<scenes::Animation>,
    event_loop: Option<winit::event_loop::EventLoop<()>>,
) -> anyhow::Result<()> {
    let (default_w, default_h) = default_size(gpu);
    let (width, height) = (args.width.unwrap_or(default_w), args.height.unwrap_or(default_h));
    (args.width, args.height) = (Some(width), Some(height));
    let settings = RenderSettings {
        width,
        height,
        technique: args.technique.clone(),
        per_vertex: args.per_vertex,
        exposure: args.exposure,
    };
    eprintln!("preparing scene '{label}' with technique '{}' at {}x{}...", args.technique, width, height);
    let t0 = std::time::Instant::now();
    let mut renderer = Renderer::new(gpu, scene, settings)?;
    if let Some(split) = renderer.scene.env_split_if_made() {
        let d = &split.decomposition;
        eprintln!(
            "environment lights: {} light(s), {:.1} % of the environment's power (decomposed in {:.1} ms, residual \
             maps {:.0} ms){}",
            d.lights.len(),
            100.0 * d.share,
            split.decompose_seconds * 1e3,
            split.build_seconds * 1e3,
            d.note.as_ref().map(|n| format!("; {n}")).unwrap_or_default()
        );
    }
    eprintln!("prepared in {:.2} s", t0.elapsed().as_secs_f64());
    let result = drive(gpu, &mut renderer, args, scene, animation, event_loop);
    renderer.destroy(gpu);
    result
}

/// Render what the arguments ask for with a prepared renderer.
fn drive(
    gpu: &Gpu,
    renderer: &mut Renderer,
    args: &mut Args,
    scene: &engine::scene::Scene,
    animation: Option<scenes::Animation>,
    event_loop: Option<winit::event_loop::EventLoop<()>>,
) -> anyhow::Result<()> {
    let schedule = args.spp.map(spp_schedule);
    if let (Some(s), Some(r)) = (&schedule, lab::converge::reference_mut(renderer)) {
        r.set_options(engine::passes::shade::reference::ReferenceOptions { samples_per_frame: s[0], ..r.options() })?;
    }
    if animation.is_some() && args.technique.starts_with("reference") {
        eprintln!(
            "note: the reference restarts its accumulation at every new pose: each --animate frame holds that \
             frame's samples only"
        );
    }
    if let Some(dir) = &args.export {
        let (width, height) = (args.width.unwrap_or(0), args.height.unwrap_or(0));
        let opts = lab::export::ExportOptions { width, height, spp: 256, camera: None, bsdf: args.export_bsdf };
        let e = lab::export::export_mitsuba(scene, dir, &opts)?;
        println!("wrote Mitsuba 3 scene {} ({} meshes, {})", e.xml.display(), e.meshes.len(), e.envmap.display());
    }
    (args.out, args.name) = output_target(args);
    match event_loop {
        Some(el) => demos::viewer::run(
            el,
            gpu,
            renderer,
            demos::viewer::ViewerOptions {
                exit_after: args.exit_after.unwrap_or(0),
                animation,
                brdf: scenes::BrdfCycle::new(scene),
                env_spin: args.env_spin,
            },
        ),
        None => match args.capture {
            Some(n) => {
                lab::capture::run(gpu, renderer, n, &args.out, &args.name, &capture_info(gpu, args), animation.as_ref())
            }
            None => render_frames(gpu, renderer, args, animation.as_ref(), schedule.as_deref()),
        },
    }
}

fn capture_info(gpu: &Gpu, args: &Args) -> lab::capture::CaptureInfo {
    lab::capture::CaptureInfo {
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
    animation: Option<&scenes::Animation>,
    schedule: Option<&[u32]>,
) -> anyhow::Result<()> {
    let frames = schedule.map_or(args.frames.unwrap_or(5), |s| s.len() as u32);
    let total_spp: u32 = schedule.map_or(0, |s| s.iter().sum());
    let mut per_pass: Vec<(String, Vec<f64>)> = Vec::new();
    let mut after_first = None;
    // The environment's split (env_lights=on): its CPU time at upload and, with --env-spin, at every turn.
    let mut split_ms: Vec<(f64, f64)> = Vec::new();
    let mut progress = Progress::new(frames);
    for f in 0..frames {
        if let Some(a) = animation {
            a.apply(renderer, f as f32 / 30.0)?;
        }
        if let Some(spin) = args.env_spin {
            scenes::spin_environment(gpu, renderer, spin, f as f32 / 30.0)?;
        }
        if let (Some(s), Some(r)) = (schedule, lab::converge::reference_mut(renderer)) {
            r.set_samples_per_frame(s[f as usize])?;
        }
        if f == 0 || args.env_spin.is_some() {
            if let Some(split) = renderer.scene.env_split_if_made() {
                split_ms.push((split.decompose_seconds * 1e3, split.build_seconds * 1e3));
            }
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
        let per_vertex = renderer.settings.per_vertex;
        let samples = lab::converge::reference_mut(renderer).map(|r| r.samples(per_vertex));
        progress.frame_done(f + 1, samples.filter(|_| schedule.is_some()).map(|n| (n, total_spp)));
    }
    let after_last = gpu.memory_stats();
    let report = renderer.technique_report(gpu)?;
    for w in report.warnings {
        eprintln!("warning: {w}");
    }
    for c in report.counts {
        eprintln!("{c}");
    }
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
    if !split_ms.is_empty() {
        let median = |k: usize| {
            let mut v: Vec<f64> = split_ms.iter().map(|m| if k == 0 { m.0 } else { m.1 }).collect();
            v.sort_by(|a, b| a.total_cmp(b));
            v[v.len() / 2]
        };
        println!(
            "environment lights (CPU, median of {} split(s)): decomposition {:.3} ms, residual maps and lights {:.1} ms",
            split_ms.len(),
            median(0),
            median(1)
        );
    }
    let per_vertex = renderer.settings.per_vertex;
    if let Some(r) = lab::converge::reference_mut(renderer) {
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

/// Progress of a long headless run on stderr: nothing for runs under [`PROGRESS_EVERY_S`], then one line per
/// interval with the frames (and the reference's samples) done and the time left at the rate so far.
struct Progress {
    frames: u32,
    every: f64,
    start: std::time::Instant,
    last: f64,
}

impl Progress {
    fn new(frames: u32) -> Self {
        // Checked before any work (check_args).
        let every = progress_interval().unwrap_or(PROGRESS_EVERY_S);
        Self { frames, every, start: std::time::Instant::now(), last: 0.0 }
    }

    fn frame_done(&mut self, done: u32, samples: Option<(u32, u32)>) {
        let t = self.start.elapsed().as_secs_f64();
        if done == self.frames || t - self.last < self.every {
            return;
        }
        self.last = t;
        let left = t / done as f64 * (self.frames - done) as f64;
        let spp = samples.map(|(n, of)| format!(", {n} of {of} samples per pixel")).unwrap_or_default();
        eprintln!(
            "frame {done} of {} ({:.0} %{spp}), {t:.1} s so far, about {left:.0} s left",
            self.frames,
            100.0 * done as f64 / self.frames as f64
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spp_schedules_sum_to_the_request() {
        assert_eq!(spp_schedule(1), vec![1]);
        assert_eq!(spp_schedule(64), vec![64]);
        assert_eq!(spp_schedule(65), vec![33, 32]);
        assert_eq!(spp_schedule(256), vec![64; 4]);
        for n in [1, 2, 63, 64, 65, 127, 128, 129, 1000, 4097, MAX_SPP - 1, MAX_SPP] {
            let s = spp_schedule(n);
            assert_eq!(s.iter().sum::<u32>(), n, "{n}");
            assert_eq!(s.len() as u32, n.div_ceil(SPP_PER_FRAME), "{n}");
            assert!(s.iter().all(|&k| (1..=SPP_PER_FRAME).contains(&k)), "{n}: {s:?}");
        }
    }

    #[test]
    fn exposure_and_name_parsers() {
        for bad in ["nan", "NaN", "inf", "-inf", "-1", "0", "1e7", "x", "", "1e-45", "9e-7"] {
            assert!(parse_exposure(bad).is_err(), "{bad}");
        }
        assert_eq!(parse_exposure("1e-6"), Ok(1e-6));
        for bad in ["1e38", "-1e38", "100001", "nan", "inf"] {
            assert!(parse_rotation(bad).is_err(), "{bad}");
        }
        assert_eq!(parse_rotation("-720"), Ok(-720.0));
        assert!(parse_name(&"n".repeat(MAX_NAME_BYTES + 1)).is_err());
        assert!(parse_name(&"n".repeat(MAX_NAME_BYTES)).is_ok());
        assert_eq!(parse_exposure("2.5"), Ok(2.5));
        for bad in ["", ".", "..", "a/b", "a\\b", "/abs"] {
            assert!(parse_name(bad).is_err(), "{bad:?}");
        }
        assert_eq!(parse_name("shot-1").as_deref(), Ok("shot-1"));
    }
}
