//! `process-fuzz`: seeded mutations of every loader's files, each run through the real `demo` binary as its own
//! process (issue 38). The in-process `fuzz` targets call a loader on a buffer; this finds what only a whole run
//! shows: an abort under a memory cap, a hang, panic text on stderr, an exit status other than 1, a message that
//! echoes the input at length.
//!
//! Every run gets a mutated file in one place the demo reads — `--scene` (.obj, .gltf, .glb, .toml), `--env`
//! (.exr, .hdr), an OBJ's `mtllib`, a glTF's external buffer, a scene file's `sphere_files` and `material_map` —
//! and is bounded: its address space is capped (`ulimit -v`, default 4 GiB) and it is killed after the timeout
//! (default 30 s). No Vulkan driver is offered (`VK_ICD_FILENAMES` names none), so a file that loads ends the run
//! at the GPU set-up, in milliseconds, and nothing renders.
//!
//! Outcomes per run: `loaded` (it reached the GPU set-up), `refused` (exit 1 with one `error:` line), or a finding:
//! `hang` (timed out), `signal` (an abort or a crash), `panic` (`panicked at` on stderr), `status` (an exit status
//! other than 1), `no-error` (exit 1 without one `error:` line), `echo` (more than 4 kB on stderr), `control` (a
//! control character other than a line break on stderr: input printed raw), `escaped` (a `gltf-outside` seed, a
//! model naming a file outside its folder, loaded). Findings are saved in `--dir`; the exit status is 1 when there
//! is any.
//!
//! `tools/process-fuzz.sh` builds the release binaries and runs this with the counts written to
//! docs/process-fuzz.md.

use engine_fuzz::{mutate, seeds, Rng};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Most bytes of stderr a refusal may print: an error names the file and says what is wrong in a line or two (a
/// TOML error shows the line it stopped in); 4 kB is an input echoed.
const MAX_STDERR: usize = 4096;
/// What a run that loaded its scene prints when the absent Vulkan driver stops it.
const REACHED_GPU: &[&str] = &["no usable Vulkan device", "vkCreateInstance"];

const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// One place the demo reads a file: the mutated file's name, its seeds, the support files around it and the
/// demo's arguments.
struct Place {
    name: &'static str,
    file: &'static str,
    seeds: fn() -> Vec<Vec<u8>>,
    setup: fn(&Path) -> std::io::Result<()>,
    args: &'static [&'static str],
    /// The seeds must be refused (they name files outside the model's folder): a seed run that loads is a
    /// finding (`escaped`).
    seeds_refused: bool,
}

fn repo() -> PathBuf {
    engine_fuzz::crate_dir().join("../..")
}

fn nothing(_: &Path) -> std::io::Result<()> {
    Ok(())
}

fn tri(dir: &Path) -> std::io::Result<()> {
    std::fs::write(dir.join("tri.obj"), TRI)
}

fn mtl_obj(dir: &Path) -> std::io::Result<()> {
    std::fs::write(dir.join("m.obj"), format!("mtllib input.mtl\nusemtl a\n{TRI}usemtl b\nv 0 0 1\nf 1 2 4\n"))
}

/// The glTF seed with its data URI replaced by `uri`.
fn gltf_with_uri(uri: &str) -> String {
    let seed = String::from_utf8(seeds::gltf().remove(0)).unwrap_or_default();
    let start = seed.find("\"uri\"").unwrap_or(0);
    let end = seed[start..].find('}').map_or(seed.len(), |e| start + e);
    format!("{}\"uri\":\"{uri}\"{}", &seed[..start], &seed[end..])
}

fn buffer_gltf(dir: &Path) -> std::io::Result<()> {
    std::fs::write(dir.join("b.gltf"), gltf_with_uri("input.bin"))
}

/// glTF files whose buffer is a valid one outside their folder (e.g. `../../../../etc/passwd`, which must not be read):
/// by `..`, percent-encoded `..`, an absolute path and a `file:` URI (through `/proc/self/cwd`, the run's folder),
/// and a link in the folder to it. Each must be refused; read, it would load.
fn outside_seeds() -> Vec<Vec<u8>> {
    [
        "../outside.bin",
        "%2E%2E/outside.bin",
        "/proc/self/cwd/../outside.bin",
        "file:///proc/self/cwd/../outside.bin",
        "link.bin",
    ]
    .iter()
    .map(|u| gltf_with_uri(u).into_bytes())
    .collect()
}

fn outside_buffer(dir: &Path) -> std::io::Result<()> {
    let outside = dir.join("../outside.bin");
    std::fs::write(&outside, buffer_seeds().remove(0))?;
    match std::os::unix::fs::symlink(&outside, dir.join("link.bin")) {
        Err(e) if e.kind() != std::io::ErrorKind::AlreadyExists => Err(e),
        _ => Ok(()),
    }
}

/// The glTF seed's binary buffer (the seed's data URI decoded).
fn buffer_seeds() -> Vec<Vec<u8>> {
    let seed = String::from_utf8(seeds::gltf().remove(0)).unwrap_or_default();
    let b64 = seed.split("base64,").nth(1).and_then(|s| s.split('"').next()).unwrap_or("");
    vec![base64::decode(b64).unwrap_or_default()]
}

/// The examples' folder as links (the scene files name their models and maps relative to it), beside a link to
/// the assets (`../assets/...`).
fn examples(dir: &Path) -> std::io::Result<()> {
    let ex = dir.join("examples");
    std::fs::create_dir_all(&ex)?;
    let link = |from: PathBuf, to: PathBuf| match std::os::unix::fs::symlink(from, to) {
        Err(e) if e.kind() != std::io::ErrorKind::AlreadyExists => Err(e),
        _ => Ok(()),
    };
    link(repo().join("assets").canonicalize()?, dir.join("assets"))?;
    for e in std::fs::read_dir(repo().join("examples"))? {
        let p = e?.path();
        link(p.canonicalize()?, ex.join(p.file_name().unwrap_or_default()))?;
    }
    Ok(())
}

fn bunny_spheres(dir: &Path) -> std::io::Result<()> {
    std::fs::write(
        dir.join("s.toml"),
        format!(
            "[[model]]\nfile = \"{}\"\nsphere_files = [\"input.json\"]\n",
            repo().join("assets/meshes/bunny.obj").canonicalize()?.display()
        ),
    )
}

fn map_scene(dir: &Path) -> std::io::Result<()> {
    tri(dir)?;
    std::fs::write(
        dir.join("p.toml"),
        "[[model]]\nfile = \"tri.obj\"\nspheres = 0\nmaterial = { brdf = \"phong:e=10\" }\n\
         material_map = { file = \"input.png\", material = { brdf = \"phong:e=100\" }, levels = 8 }\n",
    )
}

const PLACES: &[Place] = &[
    Place {
        name: "obj",
        file: "input.obj",
        seeds: seeds::obj,
        setup: nothing,
        args: &["--scene", "input.obj"],
        seeds_refused: false,
    },
    Place {
        name: "mtl",
        file: "input.mtl",
        seeds: seeds::mtl,
        setup: mtl_obj,
        args: &["--scene", "m.obj"],
        seeds_refused: false,
    },
    Place {
        name: "gltf",
        file: "input.gltf",
        seeds: seeds::gltf,
        setup: nothing,
        args: &["--scene", "input.gltf"],
        seeds_refused: false,
    },
    Place {
        name: "glb",
        file: "input.glb",
        seeds: seeds::glb,
        setup: nothing,
        args: &["--scene", "input.glb"],
        seeds_refused: false,
    },
    Place {
        name: "gltf-buffer",
        file: "input.bin",
        seeds: buffer_seeds,
        setup: buffer_gltf,
        args: &["--scene", "b.gltf"],
        seeds_refused: false,
    },
    Place {
        name: "scene",
        file: "examples/input.toml",
        seeds: seeds::scene,
        setup: examples,
        args: &["--scene", "examples/input.toml"],
        seeds_refused: false,
    },
    Place {
        name: "exr",
        file: "input.exr",
        seeds: seeds::exr,
        setup: tri,
        args: &["--scene", "tri.obj", "--env", "input.exr"],
        seeds_refused: false,
    },
    Place {
        name: "hdr",
        file: "input.hdr",
        seeds: seeds::hdr,
        setup: tri,
        args: &["--scene", "tri.obj", "--env", "input.hdr"],
        seeds_refused: false,
    },
    Place {
        name: "spheres",
        file: "input.json",
        seeds: seeds::spheres,
        setup: bunny_spheres,
        args: &["--scene", "s.toml"],
        seeds_refused: false,
    },
    Place {
        name: "png",
        file: "input.png",
        seeds: seeds::png,
        setup: map_scene,
        args: &["--scene", "p.toml"],
        seeds_refused: false,
    },
    Place {
        name: "gltf-outside",
        file: "input.gltf",
        seeds: outside_seeds,
        setup: outside_buffer,
        args: &["--scene", "input.gltf"],
        seeds_refused: true,
    },
];

#[derive(Default)]
struct Counts {
    runs: u64,
    loaded: u64,
    refused: u64,
    findings: Vec<(String, PathBuf, String)>,
    slowest: Duration,
    seconds: f64,
}

struct Settings {
    demo: PathBuf,
    runs: u64,
    seed: u64,
    timeout: Duration,
    memory_kib: u64,
    dir: PathBuf,
}

/// One run of the demo in `dir`: (exit code, None for a signal; stderr; timed out; elapsed).
fn run_demo(s: &Settings, place: &Place, dir: &Path) -> std::io::Result<(Option<i32>, String, bool, Duration)> {
    let mut c = Command::new("sh");
    c.arg("-c")
        .arg(format!("ulimit -v {} && exec \"$0\" \"$@\"", s.memory_kib))
        .arg(&s.demo)
        .args(place.args)
        .args(["--spheres", "0", "--width", "8", "--height", "6", "--technique", "none"])
        .current_dir(dir)
        .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .env("SOFTSHADOWS_SPHERE_CACHE", dir.join("cache"))
        .env_remove("ENGINE_DEVICE")
        .env_remove("RUST_BACKTRACE")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    let t0 = Instant::now();
    let mut child = c.spawn()?;
    let mut err = child.stderr.take();
    let reader = std::thread::spawn(move || {
        let mut bytes = Vec::new();
        if let Some(e) = err.as_mut() {
            let _ = std::io::Read::read_to_end(e, &mut bytes);
        }
        String::from_utf8_lossy(&bytes).into_owned()
    });
    let (status, timed_out) = loop {
        if let Some(st) = child.try_wait()? {
            break (st, false);
        }
        if t0.elapsed() > s.timeout {
            let _ = child.kill();
            break (child.wait()?, true);
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let elapsed = t0.elapsed();
    Ok((status.code(), reader.join().unwrap_or_default(), timed_out, elapsed))
}

/// The finding of one run, if any.
fn classify(code: Option<i32>, stderr: &str, timed_out: bool) -> Option<&'static str> {
    if timed_out {
        Some("hang")
    } else if code.is_none() {
        Some("signal")
    } else if stderr.contains("panicked at") {
        Some("panic")
    } else if code != Some(1) {
        Some("status")
    } else if stderr.lines().filter(|l| l.starts_with("error: ")).count() != 1 {
        Some("no-error")
    } else if stderr.len() > MAX_STDERR {
        Some("echo")
    } else if engine_fuzz::has_control(stderr) {
        Some("control")
    } else {
        None
    }
}

fn fuzz_place(s: &Settings, place: &Place, rng: &mut Rng) -> std::io::Result<Counts> {
    let dir = s.dir.join(place.name);
    std::fs::create_dir_all(&dir)?;
    (place.setup)(&dir)?;
    let seeds = (place.seeds)();
    let input = dir.join(place.file);
    let mut c = Counts::default();
    let t0 = Instant::now();
    let mut data = Vec::new();
    while c.runs < s.runs {
        data.clear();
        data.extend_from_slice(&seeds[rng.below(seeds.len())]);
        // Every 16th run takes a seed as it is (it must load), the rest mutated.
        if c.runs % 16 != 0 {
            mutate(rng, &mut data, &seeds);
        }
        std::fs::write(&input, &data)?;
        let (code, stderr, timed_out, elapsed) = run_demo(s, place, &dir)?;
        c.runs += 1;
        c.slowest = c.slowest.max(elapsed);
        let seed_run = (c.runs - 1) % 16 == 0;
        let reached_gpu = REACHED_GPU.iter().any(|n| stderr.contains(n));
        match classify(code, &stderr, timed_out) {
            Some(kind) => {
                let saved = s.dir.join(format!(
                    "{kind}-{}-{:016x}-{}",
                    place.name,
                    engine_fuzz::hash(&data),
                    place.file.replace('/', "_")
                ));
                std::fs::write(&saved, &data)?;
                let excerpt = engine::io::shorten(&stderr.chars().take(2000).collect::<String>());
                c.findings.push((kind.to_string(), saved, format!("exit {code:?}: {excerpt}")));
            }
            None if reached_gpu && seed_run && place.seeds_refused => {
                let saved = s.dir.join(format!("escaped-{}-{}", place.name, place.file.replace('/', "_")));
                std::fs::write(&saved, &data)?;
                c.findings.push(("escaped".into(), saved, "a model read a file outside its folder".into()));
            }
            None if reached_gpu => c.loaded += 1,
            None if seed_run && !place.seeds_refused => {
                let saved = s.dir.join(format!("seed-refused-{}-{}", place.name, place.file.replace('/', "_")));
                std::fs::write(&saved, &data)?;
                c.findings.push(("seed-refused".into(), saved, engine::io::shorten(&stderr)));
            }
            None => c.refused += 1,
        }
        if c.runs % 50 == 0 {
            eprintln!("process-fuzz {}: {} runs, {} finding(s)", place.name, c.runs, c.findings.len());
        }
    }
    c.seconds = t0.elapsed().as_secs_f64();
    Ok(c)
}

/// Seeded mutations of every loader's files, each run through the `demo` binary as its own process.
#[derive(clap::Parser, Debug)]
#[command(name = "process-fuzz", after_help = places_help())]
struct Args {
    /// The demo binary (build it: cargo build --release -p demos --bin demo).
    #[arg(long)]
    demo: PathBuf,
    /// Runs per place.
    #[arg(long, default_value_t = 300)]
    runs: u64,
    /// Seed of the mutations.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Seconds before a run counts as a hang (at least 1).
    #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u64).range(1..))]
    timeout: u64,
    /// Address-space cap of each run in MiB (at least 64).
    #[arg(long = "memory-mib", default_value_t = 4096, value_parser = clap::value_parser!(u64).range(64..))]
    memory_mib: u64,
    /// Folder for the runs' files and the findings (emptied first).
    #[arg(long, default_value = "out/process-fuzz")]
    dir: PathBuf,
    /// Only this place.
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(PLACES.iter().map(|p| p.name)))]
    only: Option<String>,
    /// Write the counts as Markdown to this file (docs/process-fuzz.md).
    #[arg(long)]
    markdown: Option<PathBuf>,
}

fn places_help() -> String {
    format!("places: {}", PLACES.iter().map(|p| p.name).collect::<Vec<_>>().join(", "))
}

fn main() {
    scenes::init_logging();
    let a = <Args as clap::Parser>::parse();
    let mut s = Settings {
        demo: a.demo,
        runs: a.runs,
        seed: a.seed,
        timeout: Duration::from_secs(a.timeout),
        memory_kib: a.memory_mib << 10,
        dir: a.dir,
    };
    let (only, markdown) = (a.only, a.markdown);
    if !s.demo.is_file() {
        fail(&format!(
            "--demo '{}' is not the demo binary (build it: cargo build --release -p demos --bin demo)",
            s.demo.display()
        ));
    }
    s.demo = s.demo.canonicalize().unwrap_or_else(|e| fail(&format!("{}: {e}", s.demo.display())));
    let _ = std::fs::remove_dir_all(&s.dir);
    std::fs::create_dir_all(&s.dir).unwrap_or_else(|e| fail(&format!("{}: {e}", s.dir.display())));
    s.dir = s.dir.canonicalize().unwrap_or_else(|e| fail(&format!("{}: {e}", s.dir.display())));
    let mut rng = Rng::new(s.seed);
    let mut rows = Vec::new();
    let mut found = 0;
    for place in PLACES.iter().filter(|p| only.as_deref().is_none_or(|o| o == p.name)) {
        let c = fuzz_place(&s, place, &mut rng).unwrap_or_else(|e| fail(&format!("{}: {e}", place.name)));
        let count = |k: &str| c.findings.iter().filter(|f| f.0 == k).count();
        println!(
            "process-fuzz {}: {} runs in {:.0} s: {} loaded, {} refused; {} hang, {} signal, {} panic, {} status, \
             {} no-error, {} echo, {} seed refused; slowest {:.2} s",
            place.name,
            c.runs,
            c.seconds,
            c.loaded,
            c.refused,
            count("hang"),
            count("signal"),
            count("panic"),
            count("status"),
            count("no-error"),
            count("echo"),
            count("seed-refused"),
            c.slowest.as_secs_f64()
        );
        for (kind, saved, message) in &c.findings {
            println!("  {kind} ({}): {message}", saved.display());
        }
        found += c.findings.len();
        rows.push(format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {:.2} |",
            place.name,
            c.runs,
            c.loaded,
            c.refused,
            count("hang"),
            count("signal"),
            count("panic"),
            c.findings.len() - count("hang") - count("signal") - count("panic"),
            c.slowest.as_secs_f64()
        ));
    }
    if let Some(path) = markdown {
        let text = format!(
            "# Process-level fuzzing: counts\n\n\
             Written by `tools/process-fuzz.sh` (`process-fuzz --runs {} --seed {} --timeout {} --memory-mib {}`) at \
             commit `{}`:\n\
             seeded mutations of every loader's files, each run through the release `demo` binary as its own \
             process, capped at {} MiB of address space and killed after {} s. Columns: runs that loaded (reached \
             the GPU set-up, which has no driver here), runs refused with one `error:` line, and the findings: \
             hangs, aborts or crashes (signal), panic text, and the rest (an exit status other than 1, no `error:` \
             line, more than 4 kB on stderr, a seed refused). See docs/bad-input.md.\n\n\
             | place | runs | loaded | refused | hang | signal | panic text | other | slowest (s) |\n\
             |---|---|---|---|---|---|---|---|---|\n{}\n",
            s.runs,
            s.seed,
            s.timeout.as_secs(),
            s.memory_kib >> 10,
            lab::bench::COMMIT,
            s.memory_kib >> 10,
            s.timeout.as_secs(),
            rows.join("\n")
        );
        std::fs::write(&path, text).unwrap_or_else(|e| fail(&format!("{}: {e}", path.display())));
        println!("wrote {}", path.display());
    }
    if found > 0 {
        std::process::exit(1);
    }
}

fn fail(message: &str) -> ! {
    eprintln!("process-fuzz: {message}");
    std::process::exit(2)
}
