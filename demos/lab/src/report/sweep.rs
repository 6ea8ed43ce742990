//! The sweep's definition: the config file of named sweeps (tools/report/sweep.json), its scenes and techniques,
//! checked against the registries before anything runs.

use anyhow::{bail, Context, Result};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The config file: named sweeps (`full` and `tiny` in the default file).
pub type SweepFile = BTreeMap<String, Sweep>;

/// One sweep.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sweep {
    pub width: u32,
    pub height: u32,
    /// Frames per technique; at least 5 are rendered (times are medians).
    pub frames: u32,
    /// The reference stops when its relative standard error is this fraction of the smallest measured error…
    pub fraction: f64,
    /// …or at this many samples per pixel.
    pub max_spp: u32,
    pub samples_per_frame: u32,
    /// The scene whose decomposition heads the README (every scene with spheres gets one in the CSV).
    #[serde(default)]
    pub decomposition_scene: Option<String>,
    /// Also render every image under the environment's upper and lower hemisphere only (above and below the
    /// ground's horizon, world +Y up; without the sphere lights, which are then a third part), for the error by
    /// lighting (default: true; costs two (three) more references per visibility and frames per technique).
    #[serde(default = "yes")]
    pub split_lighting: bool,
    /// Also measure every technique on the scene without blockers against the unoccluded reference (the
    /// representation error; default: true; costs one more reference and frame per technique).
    #[serde(default = "yes")]
    pub representation: bool,
    /// Keep the converged references in this folder (relative to the workspace root), keyed by everything that
    /// determines them, and reuse them on the next run (`measure::cached_reference`). With a cache, set a small
    /// `fraction` so that `max_spp` decides: the fraction rule converges against the techniques of the first run.
    #[serde(default)]
    pub reference_cache: Option<String>,
    /// Write the results page (index.html, README.md, the summary) for this sweep ([`Site`]).
    #[serde(default)]
    pub site: Option<Site>,
    pub scenes: Vec<SceneSpec>,
    /// Technique specs as `demo --technique` takes them (`none`, `isg:patches=8,K=4`, …).
    pub techniques: Vec<String>,
    /// More specs measured per pixel only, after `techniques` (variants whose per-vertex figures would add
    /// little for the time they take on lavapipe: the environment split on and off, a higher SH order).
    #[serde(default)]
    pub pixel_techniques: Vec<String>,
    /// `pixel` and/or `vertex`.
    pub shading: Vec<String>,
}

impl Sweep {
    /// The technique specs measured at shading rate `shading`: every one of `techniques`, and per pixel also
    /// `pixel_techniques`.
    pub fn techniques_at(&self, shading: &str) -> impl Iterator<Item = &String> {
        let extra = if shading == "pixel" { &self.pixel_techniques[..] } else { &[] };
        self.techniques.iter().chain(extra)
    }
}

fn yes() -> bool {
    true
}

/// The results page of a sweep (docs/results: see [`super::page`]).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Site {
    /// Output folder, relative to the workspace root (the default `--out` of this sweep).
    pub out: String,
    /// The scene of the first-screen picture…
    pub hero_scene: String,
    /// …and its techniques, left to right, per pixel; the triangle reference follows them.
    pub hero_techniques: Vec<String>,
    /// The techniques of the summary table and plot (per pixel), usually each technique at its defaults.
    pub summary_techniques: Vec<String>,
    /// A Markdown file (relative to the workspace root) whose block between [`super::page::BEGIN`] and
    /// [`super::page::END`] is replaced by the summary (the project's README.md).
    #[serde(default)]
    pub readme: Option<String>,
}

/// A scene of the sweep, optionally with material 0 overridden.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// A `demo --scene` name (a scene of the registry, demos/scenes).
    pub scene: String,
    /// Name in the results (default: the scene name).
    #[serde(default)]
    pub label: Option<String>,
    /// Blinn-Phong exponent of material 0.
    #[serde(default)]
    pub gloss: Option<f32>,
    /// k_s of material 0.
    #[serde(default)]
    pub ks: Option<f32>,
    /// Specular BRDF of the glossy materials as `demo --brdf` takes it (applied after gloss/ks).
    #[serde(default)]
    pub brdf: Option<String>,
    /// Shading rates for this scene instead of the sweep's.
    #[serde(default)]
    pub shading: Option<Vec<String>>,
    /// Measure the scene as its motion poses it at this time (s), frozen (`measure::freeze_at`, as `compare
    /// --time`): a piece mid-slide, the cloth landed, the club raised.
    #[serde(default)]
    pub time: Option<f32>,
}

impl SceneSpec {
    pub fn label(&self) -> &str {
        self.label.as_deref().unwrap_or(&self.scene)
    }
}

/// Read the config and pick sweep `name`.
pub fn load_sweep(path: &Path, name: &str) -> Result<Sweep> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut file: SweepFile = serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
    let names = file.keys().cloned().collect::<Vec<_>>().join(", ");
    let sweep = file.remove(name).with_context(|| format!("{}: no sweep '{name}' (has: {names})", path.display()))?;
    validate_techniques(&sweep).with_context(|| format!("{}: sweep '{name}'", path.display()))?;
    check_scenes(&sweep).with_context(|| format!("{}: sweep '{name}'", path.display()))?;
    Ok(sweep)
}

/// Every technique spec of a sweep parses against the technique registry (before any GPU work), and
/// the report rows are measured against a reference, so `reference` itself is not a sweep entry.
pub fn validate_techniques(sweep: &Sweep) -> Result<()> {
    for spec in sweep.techniques.iter().chain(&sweep.pixel_techniques) {
        let (entry, _) = engine::passes::shade::parse_technique(spec)?;
        if entry.name == "reference" {
            bail!("technique '{spec}': the reference is measured against itself; leave it out of the sweep");
        }
    }
    Ok(())
}

/// Every scene of the sweep is registered (demos/scenes), so that a typo fails before hours of measuring.
pub fn check_scenes(sweep: &Sweep) -> Result<()> {
    for s in &sweep.scenes {
        scenes::find(&s.scene).with_context(|| format!("scene '{}'", s.label()))?;
    }
    Ok(())
}

/// The workspace root (where the sweep's relative folders start).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The default config: tools/report/sweep.json.
pub fn default_config() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tools/report/sweep.json")
}
