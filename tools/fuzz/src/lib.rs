//! Mutation fuzzing of the engine's file loaders, on the stable toolchain (`cargo xtask fuzz TARGET --runs N`;
//! a bounded run and the regression corpus are tests of this crate, so `cargo xtask test` runs them).
//!
//! Why not cargo-fuzz or a coverage-guided engine: cargo-fuzz (libFuzzer) and `cargo bolero` need a nightly
//! toolchain for their instrumentation, which this project does not use; bolero's stable engine generates
//! random values from a type, which would rarely get past a file's magic number. What finds loader bugs without
//! coverage feedback is mutating valid files, as the issue's hostile-input round did by hand (seventy-seven
//! mutated EXR files crashed the same place): this driver takes small valid seed files of each format (made
//! here, and the shipped assets where small), applies libFuzzer's byte mutations plus number replacements for
//! the text formats, writes each input to a file and calls the real loader on it.
//!
//! Each execution is checked for: a panic that escapes the loader (caught, reported with the input saved), an
//! allocation peak over [`ALLOC_BOUND`] (with the [`CountingAlloc`] global allocator installed by the binary
//! and the tests), and a run over [`HANG_BOUND`]. A process abort (a failed allocation) cannot be caught: the
//! input being run is always on disk ([`Driver::pending_path`]) before the loader starts, so it survives.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

pub mod seeds;

/// Largest allocation peak one execution may reach: 256 MiB. The loaders bound what a header may ask for by the
/// file's length (engine/src/scene/env.rs); the seeds and their mutations are a few KiB, so a legitimate peak is
/// a few MiB (a 16K environment map from a real file would be 1.5 GiB, but no fuzz input is that file).
pub const ALLOC_BOUND: usize = 256 << 20;
/// Longest one execution may take: 1 s (the issue's bound for a hang).
pub const HANG_BOUND: Duration = Duration::from_secs(1);
/// Longest input the mutator makes: 64 KiB.
pub const MAX_INPUT: usize = 64 << 10;

/// A global allocator that counts live bytes and their peak (wrapping the system allocator).
pub struct CountingAlloc;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

// SAFETY: every call is forwarded to `System` unchanged; the counters are only statistics.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded with the caller's layout.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let live = LIVE.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(live, Ordering::Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded; ptr came from alloc with this layout.
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded with the caller's layout.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            let live = LIVE.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(live, Ordering::Relaxed);
        }
        p
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: forwarded; ptr came from alloc with this layout.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            if new_size >= layout.size() {
                let live = LIVE.fetch_add(new_size - layout.size(), Ordering::Relaxed) + new_size - layout.size();
                PEAK.fetch_max(live, Ordering::Relaxed);
            } else {
                LIVE.fetch_sub(layout.size() - new_size, Ordering::Relaxed);
            }
        }
        p
    }
}

/// Whether [`CountingAlloc`] is the global allocator of this process (it counted something).
pub fn counting() -> bool {
    PEAK.load(Ordering::Relaxed) > 0
}

/// A small, fast, deterministic generator (SplitMix64): a run is reproducible from its seed.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in `0..n` (n > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }
}

/// Numbers that break parsers: bounds of the integer types, zero, negatives, huge and non-finite floats.
const NUMBERS: &[&str] = &[
    "0",
    "-1",
    "1",
    "2",
    "-0",
    "255",
    "256",
    "65535",
    "65536",
    "2147483647",
    "2147483648",
    "-2147483648",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "99999999999999999999",
    "1e38",
    "1e309",
    "-1e309",
    "nan",
    "inf",
    "-inf",
    "0.0000001",
    "3.4e38",
    "1e-45",
    // f32's limits and just beyond them: every numeric key at the edge of what f32 holds.
    "3.4028235e38",
    "-3.4028235e38",
    "3.4028236e38",
    "3.5e38",
    "1.1754944e-38",
    "-9223372036854775808",
    "9223372036854775807",
    "340282350000000000000000000000000000000",
];

/// Control bytes and escape sequences a crafted file could aim at the user's terminal: inserted
/// anywhere, so every text field (names, URIs, header lines, keys) gets them. No error may print them raw.
const CONTROL: &[&[u8]] = &[
    b"\0",
    b"\x02\x10\x1c\x7f",
    b"\x1b[2J",
    b"\x1b]0;owned\x07",
    b"\r",
    "\u{9b}31m".as_bytes(),
    "\u{202e}".as_bytes(),
];

/// Byte values of libFuzzer's "interesting" set.
const BYTES: &[u8] = &[0, 1, 0x7f, 0x80, 0xff, b'\n', b' ', b'/', b'-', b'{', b'}', b'[', b']', b'"', b','];

/// Apply one to four random mutations to `data` (libFuzzer's byte mutations, a splice with another seed, and,
/// for text, replacing a number with one of [`NUMBERS`]); the result is at most [`MAX_INPUT`] bytes.
pub fn mutate(rng: &mut Rng, data: &mut Vec<u8>, seeds: &[Vec<u8>]) {
    let rounds = 1 + rng.below(4);
    for _ in 0..rounds {
        if data.is_empty() {
            data.push(rng.next_u64() as u8);
            continue;
        }
        let n = data.len();
        match rng.below(12) {
            // Control bytes or an escape sequence at a random place.
            11 => {
                let i = rng.below(n + 1);
                data.splice(i..i, CONTROL[rng.below(CONTROL.len())].iter().copied());
            }
            // Flip a bit.
            0 => {
                let i = rng.below(n);
                data[i] ^= 1 << rng.below(8);
            }
            // A random byte.
            1 => {
                let i = rng.below(n);
                data[i] = rng.next_u64() as u8;
            }
            // An interesting byte.
            2 => {
                let i = rng.below(n);
                data[i] = BYTES[rng.below(BYTES.len())];
            }
            // An interesting 16/32/64-bit value, either endianness (headers hold little-endian sizes).
            3 => {
                let width = [2usize, 4, 8][rng.below(3)];
                if n >= width {
                    let i = rng.below(n - width + 1);
                    let v: u64 =
                        [0, 1, u64::MAX, 0x7fff_ffff, 0x8000_0000, 0xffff, 0x1_0000, rng.next_u64()][rng.below(8)];
                    let bytes = if rng.below(2) == 0 { v.to_le_bytes() } else { v.to_be_bytes() };
                    data[i..i + width].copy_from_slice(&bytes[..width]);
                }
            }
            // Insert random bytes.
            4 => {
                let i = rng.below(n + 1);
                let k = 1 + rng.below(16);
                let ins: Vec<u8> = (0..k).map(|_| rng.next_u64() as u8).collect();
                data.splice(i..i, ins);
            }
            // Delete a range.
            5 => {
                let i = rng.below(n);
                let k = 1 + rng.below((n - i).min(64));
                data.drain(i..i + k);
            }
            // Duplicate a range in place.
            6 => {
                let i = rng.below(n);
                let k = 1 + rng.below((n - i).min(256));
                let copy = data[i..i + k].to_vec();
                let at = rng.below(n + 1);
                data.splice(at..at, copy);
            }
            // Overwrite with a copy of another range.
            7 => {
                let (a, b) = (rng.below(n), rng.below(n));
                let k = 1 + rng.below((n - a.max(b)).min(64));
                let copy = data[a..a + k].to_vec();
                data[b..b + k].copy_from_slice(&copy);
            }
            // Splice: our head with another seed's tail.
            8 => {
                let other = &seeds[rng.below(seeds.len())];
                if !other.is_empty() {
                    let cut = rng.below(n);
                    let from = rng.below(other.len());
                    data.truncate(cut);
                    data.extend_from_slice(&other[from..]);
                }
            }
            // Truncate.
            9 => {
                data.truncate(rng.below(n));
            }
            // Replace a number (an ASCII digit run, with its sign and fraction) with an interesting one.
            _ => {
                let starts: Vec<usize> =
                    (0..n).filter(|&i| data[i].is_ascii_digit() && (i == 0 || !data[i - 1].is_ascii_digit())).collect();
                if let Some(&s) = starts.get(rng.below(starts.len().max(1))) {
                    let s = if s > 0 && data[s - 1] == b'-' { s - 1 } else { s };
                    let mut e = s + 1;
                    while e < n && (data[e].is_ascii_digit() || data[e] == b'.' || data[e] == b'e') {
                        e += 1;
                    }
                    let num = NUMBERS[rng.below(NUMBERS.len())].as_bytes().to_vec();
                    data.splice(s..e, num);
                }
            }
        }
    }
    data.truncate(MAX_INPUT);
}

/// One loader under test.
pub struct Target {
    /// `cargo xtask fuzz NAME`.
    pub name: &'static str,
    /// The input file's extension (the loaders dispatch on it).
    pub ext: &'static str,
    /// Load the file; an `Err` is a correct answer to a bad file.
    pub run: fn(&Path) -> Result<(), String>,
    /// Valid seed files.
    pub seeds: fn() -> Vec<Vec<u8>>,
}

fn load_obj(p: &Path) -> Result<(), String> {
    engine::scene::load_obj(p).map(|_| ()).map_err(|e| e.to_string())
}
fn load_gltf(p: &Path) -> Result<(), String> {
    engine::scene::load_gltf(p, 0).map(|_| ()).map_err(|e| e.to_string())
}
fn load_env(p: &Path) -> Result<(), String> {
    engine::scene::load_environment(p).map(|_| ()).map_err(|e| e.to_string())
}
fn load_spheres(p: &Path) -> Result<(), String> {
    engine::blockers::file::SphereSetFile::load(p).map(|_| ()).map_err(|e| e.to_string())
}
/// The scene description parser (`--scene FILE.toml`): TOML syntax and the strict schema. Building the scene
/// (models, environment, sphere fits) reads other files through the loaders fuzzed above.
fn parse_scene(p: &Path) -> Result<(), String> {
    let text = engine::io::read_to_string(p, engine::io::Limit::SCENE).map_err(|e| e.to_string())?;
    scenes::user::parse_scene_file(&text).map(|_| ())
}

/// Every target: one per loader.
pub const TARGETS: &[Target] = &[
    Target { name: "obj", ext: "obj", run: load_obj, seeds: seeds::obj },
    Target { name: "gltf", ext: "gltf", run: load_gltf, seeds: seeds::gltf },
    Target { name: "glb", ext: "glb", run: load_gltf, seeds: seeds::glb },
    Target { name: "exr", ext: "exr", run: load_env, seeds: seeds::exr },
    Target { name: "hdr", ext: "hdr", run: load_env, seeds: seeds::hdr },
    Target { name: "spheres", ext: "json", run: load_spheres, seeds: seeds::spheres },
    Target { name: "scene", ext: "toml", run: parse_scene, seeds: seeds::scene },
];

/// The target called `name`.
pub fn target(name: &str) -> Option<&'static Target> {
    TARGETS.iter().find(|t| t.name == name)
}

/// What went wrong on one input.
#[derive(Clone, Debug)]
pub struct Finding {
    pub kind: &'static str,
    pub message: String,
    /// The input, saved for reproduction.
    pub saved: PathBuf,
}

/// What one execution did.
#[derive(Clone, Debug)]
pub struct Outcome {
    pub loaded: bool,
    /// The loader's error, when it refused the input.
    pub error: Option<String>,
    pub elapsed: Duration,
    /// Allocation peak above the live bytes at the start (0 without [`CountingAlloc`]).
    pub peak_bytes: usize,
    /// Panics raised and caught inside the loader (the glTF loader contains the gltf crate's).
    pub contained_panics: usize,
    /// A panic that escaped the loader.
    pub escaped: Option<String>,
}

thread_local! {
    static PANICS: std::cell::RefCell<Vec<String>> = const { std::cell::RefCell::new(Vec::new()) };
    /// Inside [`execute`]: panics are recorded, not printed.
    static IN_EXEC: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Install a panic hook that records the messages of panics inside [`execute`] instead of printing them (every
/// contained panic would print otherwise, and slow the run down); other panics go to the previous hook.
/// Idempotent.
pub fn quiet_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !IN_EXEC.with(|f| f.get()) {
                return previous(info);
            }
            let msg = match info.payload().downcast_ref::<&str>() {
                Some(s) => s.to_string(),
                None => info.payload().downcast_ref::<String>().cloned().unwrap_or_else(|| "panic".into()),
            };
            let at = info.location().map(|l| format!(" at {}:{}", l.file(), l.line())).unwrap_or_default();
            PANICS.with(|p| p.borrow_mut().push(format!("{msg}{at}")));
        }));
    });
}

/// Run `target` on the file at `path` (already written), measuring it.
pub fn execute(target: &Target, path: &Path) -> Outcome {
    quiet_panics();
    PANICS.with(|p| p.borrow_mut().clear());
    let base = LIVE.load(Ordering::Relaxed);
    PEAK.store(base, Ordering::Relaxed);
    IN_EXEC.with(|f| f.set(true));
    // The loaders contain their parsers' panics with engine::io::catch_quiet, which keeps them from every hook
    // (this one included) and counts them.
    let quietly_contained = engine::io::contained_panics();
    let t0 = Instant::now();
    let r = std::panic::catch_unwind(|| (target.run)(path));
    let elapsed = t0.elapsed();
    IN_EXEC.with(|f| f.set(false));
    let quiet = (engine::io::contained_panics() - quietly_contained) as usize;
    let peak_bytes = PEAK.load(Ordering::Relaxed).saturating_sub(base);
    let panics = PANICS.with(|p| std::mem::take(&mut *p.borrow_mut()));
    match r {
        Ok(res) => Outcome {
            loaded: res.is_ok(),
            error: res.err(),
            elapsed,
            peak_bytes,
            contained_panics: panics.len() + quiet,
            escaped: None,
        },
        Err(_) => Outcome {
            loaded: false,
            error: None,
            elapsed,
            peak_bytes,
            contained_panics: panics.len().saturating_sub(1) + quiet,
            escaped: Some(panics.last().cloned().unwrap_or_else(|| "panic".into())),
        },
    }
}

/// The findings of one outcome against the bounds.
pub fn check(outcome: &Outcome) -> Option<(&'static str, String)> {
    if let Some(m) = &outcome.escaped {
        return Some(("panic", m.clone()));
    }
    if outcome.peak_bytes > ALLOC_BOUND {
        return Some(("allocation", format!("{} MiB allocated at the peak", outcome.peak_bytes >> 20)));
    }
    if outcome.elapsed > HANG_BOUND {
        return Some(("hang", format!("took {:.2} s", outcome.elapsed.as_secs_f64())));
    }
    if let Some(e) = outcome.error.as_deref().filter(|e| has_control(e)) {
        return Some(("control", format!("the error carries a control character: {e:?}")));
    }
    None
}

/// Whether `text` holds a character that must not reach a terminal raw: a control character other than a line
/// break, or a bidirectional override (an error must not quote raw bytes of the input).
pub fn has_control(text: &str) -> bool {
    text.chars().any(|c| {
        (c.is_control() && c != '\n')
            || matches!(c, '\u{200e}' | '\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
    })
}

/// Totals of a run.
#[derive(Clone, Debug, Default)]
pub struct Stats {
    pub executions: u64,
    pub loaded: u64,
    pub rejected: u64,
    pub contained_panics: u64,
    pub seconds: f64,
    pub slowest: Duration,
    pub peak_bytes: usize,
    pub findings: Vec<Finding>,
}

impl Stats {
    pub fn per_second(&self) -> f64 {
        self.executions as f64 / self.seconds.max(1e-9)
    }

    pub fn summary(&self, target: &str) -> String {
        format!(
            "fuzz {target}: {} executions in {:.1} s ({:.0}/s): {} loaded, {} rejected with an error, {} panics \
             contained by the loader; slowest {:.1} ms, largest allocation peak {:.2} MiB; {} finding(s)",
            self.executions,
            self.seconds,
            self.per_second(),
            self.loaded,
            self.rejected,
            self.contained_panics,
            self.slowest.as_secs_f64() * 1e3,
            self.peak_bytes as f64 / 1048576.0,
            self.findings.len()
        )
    }
}

/// A fuzzing run of one target; findings are saved in `dir`.
pub struct Driver {
    pub target: &'static Target,
    pub dir: PathBuf,
    seeds: Vec<Vec<u8>>,
    rng: Rng,
}

impl Driver {
    /// Seeds from the target and from `corpus/<target>/` (the regression inputs), working in `dir`.
    pub fn new(target: &'static Target, dir: &Path, seed: u64) -> std::io::Result<Self> {
        std::fs::create_dir_all(dir)?;
        let mut seeds = (target.seeds)();
        seeds.extend(corpus(target)?.into_iter().map(|(_, bytes)| bytes));
        seeds.retain(|s| s.len() <= MAX_INPUT);
        Ok(Self { target, dir: dir.to_path_buf(), seeds, rng: Rng::new(seed) })
    }

    /// Where the input being run is written before the loader starts (it survives an abort): in /dev/shm when
    /// there is one (memory; on this project's machines a write to the disk's temp folder costs ~3 ms, 80 times
    /// the loader's own time), else the temp folder. The process id keeps parallel runs apart.
    pub fn pending_path(&self) -> PathBuf {
        let shm = Path::new("/dev/shm");
        let base = if shm.is_dir() { shm.to_path_buf() } else { std::env::temp_dir() };
        base.join(format!("engine-fuzz-{}-current-{}.{}", std::process::id(), self.target.name, self.target.ext))
    }

    /// Run until `runs` executions or `time` elapsed (whichever first), calling `progress` every ~5 s.
    pub fn run(
        &mut self,
        runs: u64,
        time: Option<Duration>,
        mut progress: impl FnMut(&Stats),
    ) -> std::io::Result<Stats> {
        quiet_panics();
        let pending = self.pending_path();
        let mut stats = Stats::default();
        let t0 = Instant::now();
        let mut last = Instant::now();
        let mut input = Vec::new();
        while stats.executions < runs && time.is_none_or(|t| t0.elapsed() < t) {
            input.clear();
            input.extend_from_slice(&self.seeds[self.rng.below(self.seeds.len())]);
            // Every 16th input runs a seed as it is (they must load: checked by the corpus test), the rest mutated.
            if stats.executions % 16 != 0 {
                mutate(&mut self.rng, &mut input, &self.seeds);
            }
            std::fs::write(&pending, &input)?;
            let o = execute(self.target, &pending);
            stats.executions += 1;
            if o.loaded {
                stats.loaded += 1;
            } else {
                stats.rejected += 1;
            }
            stats.contained_panics += o.contained_panics as u64;
            stats.slowest = stats.slowest.max(o.elapsed);
            stats.peak_bytes = stats.peak_bytes.max(o.peak_bytes);
            if let Some((kind, message)) = check(&o) {
                let saved =
                    self.dir.join(format!("{kind}-{}-{:016x}.{}", self.target.name, hash(&input), self.target.ext));
                std::fs::write(&saved, &input)?;
                stats.findings.push(Finding { kind, message, saved });
            }
            if last.elapsed() >= Duration::from_secs(5) {
                last = Instant::now();
                stats.seconds = t0.elapsed().as_secs_f64();
                progress(&stats);
            }
        }
        stats.seconds = t0.elapsed().as_secs_f64();
        let _ = std::fs::remove_file(&pending);
        Ok(stats)
    }
}

/// FNV-1a of the input, for file names.
pub fn hash(data: &[u8]) -> u64 {
    data.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ b as u64).wrapping_mul(0x0100_0000_01b3))
}

/// This crate's folder.
pub fn crate_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The regression inputs of `target`: `corpus/<name>/*`, sorted by name.
pub fn corpus(target: &Target) -> std::io::Result<Vec<(PathBuf, Vec<u8>)>> {
    let dir = crate_dir().join("corpus").join(target.name);
    let mut out = Vec::new();
    if dir.is_dir() {
        for e in std::fs::read_dir(&dir)? {
            let p = e?.path();
            if p.is_file() {
                let bytes = std::fs::read(&p)?;
                out.push((p, bytes));
            }
        }
    }
    out.sort();
    Ok(out)
}
