//! Shading passes behind the technique interface (docs/design.md §2): every technique reads a named set of
//! shared scene resources ([`ShadeInputs`]: frame, materials, environment, and the lights, blockers,
//! thin shells or geometry it names in [`Reads`]) and writes one radiance target, per pixel or per
//! vertex, from the same GLSL `shade_point`.
//!
//! **Adding a technique** = one entry in [`TECHNIQUES`] (its `mod` line and its [`TechniqueEntry`]),
//! one Rust file here and one shader folder `shaders-glsl/shade/<name>/` with `pixel.comp` and
//! `vertex.comp`. `--help`, the viewer's technique cycle, the report sweep's validation, the docs'
//! option tables and the parameterized tests (tests/tests/techniques.rs) all read the registry.

pub mod isg;
pub mod lobes;
pub mod none;
pub mod reference;
pub mod shexp;
pub mod tiles;

use crate::gpu::{Binding, Buffer, ComputePipeline, Gpu, GpuError, Image, Recorder, Result};
use crate::options::{self, OptionError, OptionSpec, Options};
use crate::passes::gbuffer::GBuffer;
use crate::resources::{BlockerResources, EnvironmentResources, Geometry, GpuScene, LightResources, ThinResources};

/// The registry: every technique the engine knows, in the order `--help` and the viewer list them.
pub static TECHNIQUES: &[TechniqueEntry] = &[isg::ENTRY, lobes::ENTRY, none::ENTRY, reference::ENTRY, shexp::ENTRY];

/// One registered technique.
pub struct TechniqueEntry {
    pub name: &'static str,
    /// One line for `--help` and the docs.
    pub summary: &'static str,
    /// Its options (`--technique name:key=value,...`).
    pub options: &'static [OptionSpec],
    /// The shared resources it reads beyond frame, materials and environment.
    pub reads: Reads,
    /// What the parameterized tests hold it to (tests/tests/techniques.rs).
    pub tolerances: Tolerances,
    pub create: fn(&Gpu, &Options) -> Result<Box<dyn Technique>>,
}

/// The bounds a technique states for itself, checked by the registry's parameterized tests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerances {
    /// Furnace (Lambertian plane, constant environment, no blockers): relative RMSE against ρL.
    pub furnace: f64,
    /// No blockers: relative RMSE against `none` (its representation error; 0 for `none`).
    pub unoccluded_vs_none: f64,
    /// One sphere over a Lambertian plane under a constant environment: relative RMSE against the
    /// closed form (the cap's cosine-weighted solid angle). `None`: the technique casts no shadows.
    pub one_sphere: Option<f64>,
    /// A Lambertian ball above a plane blocker under a constant environment: relative RMSE against the
    /// closed form ρL (1 + n_y)/2 (the upper hemisphere only). `None`: the technique casts no shadows.
    pub one_plane: Option<f64>,
    /// Monte Carlo: the test accumulates this many samples per pixel before comparing (0: not MC).
    pub samples: u32,
}

/// The shared resources a technique reads beyond the frame constants, the materials and the
/// environment (which every technique reads: the background shows the environment).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Reads {
    pub lights: bool,
    pub blockers: bool,
    pub thin: bool,
    /// Vertices, indices and instance transforms (e.g. the reference's triangle BVH).
    pub geometry: bool,
    /// The environment split into lights and a residual ([`crate::resources::EnvSplit`]): the technique's
    /// environment is the residual and its lights include the environment's. Not set in a registry entry:
    /// the renderer sets it for an instance whose spec says `env_lights=on` ([`env_lights_option`]).
    pub env_lights: bool,
}

impl TechniqueEntry {
    /// Its `--help` block: the name, the summary and one line per option.
    pub fn help(&self) -> String {
        let mut s = format!(
            "  {:<10} {}
",
            self.name, self.summary
        );
        s.push_str(&options::help_lines(self.options, "               "));
        s
    }
}

/// The `env_lights` option of the techniques that shade an environment (issue 34): `on` takes the
/// environment's bright regions as spherical lights plus a residual map ([`crate::resources::EnvSplit`]),
/// `off` shades the map whole. `default` is what the technique's measurements favour.
pub const fn env_lights_option(default: &'static str) -> OptionSpec {
    OptionSpec {
        key: "env_lights",
        aliases: &[],
        kind: options::Kind::Choice(&["off", "on"]),
        default: Some(default),
        help: "on: the environment's bright regions as spherical lights (the scene's environment.lights, --env-lights) plus a residual map; off: the environment whole",
    }
}

/// Whether parsed options ask for the split environment (`env_lights=on`).
pub fn wants_env_lights(options: &Options) -> bool {
    options.get("env_lights") == Some(options::Value::Choice("on"))
}

/// The registry entry of `name` (an unknown name is an option error listing the registered ones).
pub fn technique_entry(name: &str) -> std::result::Result<&'static TechniqueEntry, OptionError> {
    TECHNIQUES.iter().find(|t| t.name == name).ok_or_else(|| {
        let names: Vec<&str> = TECHNIQUES.iter().map(|t| t.name).collect();
        OptionError(format!("unknown technique '{}' (available: {})", engine_io::excerpt(name), names.join(", ")))
    })
}

/// Checks that tie several keys of one technique together (each key alone is checked by its schema), by technique
/// name: a table beside the registry, so that no entry has to change for a technique to have none.
const OPTION_CHECKS: &[(&str, OptionCheck)] = &[("shexp", shexp::check_options)];

/// A check of several keys of one technique's parsed options: `Err` says what contradicts what.
type OptionCheck = fn(&Options) -> std::result::Result<(), String>;

/// Parse a technique spec `name[:key=value,...]` against the registry (no GPU needed): unknown names,
/// unknown keys, out-of-range values and contradictory keys are errors naming them.
pub fn parse_technique(spec: &str) -> std::result::Result<(&'static TechniqueEntry, Options), OptionError> {
    let (name, pairs) = options::split_spec(spec).map_err(|e| OptionError(format!("technique {e}")))?;
    let entry = technique_entry(name)?;
    let opts = options::parse(entry.name, entry.options, &pairs)?;
    for (_, check) in OPTION_CHECKS.iter().filter(|(n, _)| *n == entry.name) {
        check(&opts).map_err(|e| OptionError(format!("{}: {e}", entry.name)))?;
    }
    Ok((entry, opts))
}

/// A spec with every option's effective value: `isg: diffuse=map, patches=32, ...` (the viewer's
/// option display).
pub fn describe_technique(spec: &str) -> std::result::Result<String, OptionError> {
    let (entry, opts) = parse_technique(spec)?;
    let values = opts.describe(entry.options, ", ");
    Ok(if values.is_empty() { entry.name.to_string() } else { format!("{}: {values}", entry.name) })
}

/// `--help` text of every registered technique.
pub fn techniques_help() -> String {
    TECHNIQUES.iter().map(TechniqueEntry::help).collect()
}

/// A technique from its spec, `name[:key=value,...]`.
pub fn create_technique(gpu: &Gpu, spec: &str) -> Result<Box<dyn Technique>> {
    let (entry, opts) = parse_technique(spec)?;
    (entry.create)(gpu, &opts)
}

/// Where a technique writes radiance.
#[derive(Clone, Copy)]
pub enum ShadeTarget<'a> {
    /// One invocation per G-buffer pixel, into `radiance`.
    Pixel { gbuffer: &'a GBuffer, radiance: &'a Image },
    /// One invocation per world-space vertex (written by the skin pass), into `radiance`.
    Vertex { world_vertices: &'a Buffer, radiance: &'a Buffer, count: u32 },
}

impl<'a> ShadeTarget<'a> {
    pub fn vertices(geometry: &'a Geometry) -> Self {
        ShadeTarget::Vertex {
            world_vertices: &geometry.world_vertices,
            radiance: &geometry.vertex_radiance,
            count: geometry.vertex_count,
        }
    }

    /// Items shaded: pixels or vertices.
    pub fn items(&self) -> u32 {
        match self {
            ShadeTarget::Pixel { radiance, .. } => radiance.desc.width * radiance.desc.height,
            ShadeTarget::Vertex { count, .. } => *count,
        }
    }
}

/// The named inputs of a technique: frame, materials and environment always, the rest only when the
/// technique's [`Reads`] names it (asking for one it did not name is an error, not a silent read).
pub struct ShadeInputs<'a> {
    pub technique: &'static str,
    pub frame: &'a Buffer,
    pub materials: &'a Buffer,
    /// The environment the technique shades with: the scene's, or with `env_lights` its residual.
    pub environment: &'a EnvironmentResources,
    /// The scene's environment texture, always whole: what the background shows.
    pub background: &'a Image,
    lights: Option<&'a LightResources>,
    blockers: Option<&'a BlockerResources>,
    thin: Option<&'a ThinResources>,
    geometry: Option<&'a Geometry>,
    /// The scene has thin shells (a cloth, thin meshes), whether or not the technique reads them.
    thin_shells: bool,
}

impl<'a> ShadeInputs<'a> {
    /// The parts of `scene` that `technique` names in `reads`. With `reads.env_lights` the environment is the
    /// split's residual and the lights the split's ([`GpuScene::env_split`] must have been made: an error
    /// otherwise).
    pub fn new(scene: &'a GpuScene, technique: &'static str, reads: Reads) -> Result<Self> {
        let (environment, lights) = match (reads.env_lights, scene.env_split_if_made()) {
            (false, _) => (&scene.environment, &scene.lights),
            (true, Some(split)) => (&split.residual, &split.lights),
            (true, None) => {
                return Err(GpuError::Other(format!(
                    "internal: technique '{technique}' reads the environment's lights before they were made"
                )))
            }
        };
        Ok(Self {
            technique,
            frame: &scene.frame,
            materials: &scene.materials,
            environment,
            background: &scene.environment.image,
            lights: reads.lights.then_some(lights),
            blockers: reads.blockers.then_some(&scene.blockers),
            thin: reads.thin.then_some(&scene.thin),
            geometry: reads.geometry.then_some(&scene.geometry),
            thin_shells: scene.thin.triangle_count > 0,
        })
    }

    /// Whether the scene has thin shells (a cloth, thin meshes): a technique that sees only their stand-in
    /// spheres may treat those differently (`lobes:light_rule=auto`).
    pub fn has_thin_shells(&self) -> bool {
        self.thin_shells
    }

    fn unnamed(&self, what: &str) -> GpuError {
        GpuError::Other(format!("technique '{}' reads the {what} but does not name them in its Reads", self.technique))
    }

    pub fn lights(&self) -> Result<&'a LightResources> {
        self.lights.ok_or_else(|| self.unnamed("lights"))
    }
    pub fn blockers(&self) -> Result<&'a BlockerResources> {
        self.blockers.ok_or_else(|| self.unnamed("blockers"))
    }
    pub fn thin(&self) -> Result<&'a ThinResources> {
        self.thin.ok_or_else(|| self.unnamed("thin shells"))
    }
    pub fn geometry(&self) -> Result<&'a Geometry> {
        self.geometry.ok_or_else(|| self.unnamed("geometry"))
    }
}

/// `Send`: a renderer moves between threads (the Python module keeps one behind a mutex and renders with the GIL
/// released); a technique holds Vulkan handles and host data only.
pub trait Technique: Send {
    fn name(&self) -> &'static str;
    /// Derive only the representations this technique reads (SG fit, SH, tables), once per scene.
    fn prepare(&mut self, gpu: &Gpu, inputs: &ShadeInputs) -> Result<()>;
    /// Record shading into `target`.
    fn record(&self, rec: &mut Recorder, inputs: &ShadeInputs, target: ShadeTarget) -> Result<()>;
    fn destroy(self: Box<Self>, gpu: &Gpu);
    /// The scene's materials were rewritten ([`crate::renderer::Renderer::set_materials`]): drop whatever was
    /// derived from them (the reference discards its accumulated samples). Techniques that read the materials
    /// only per shading point need nothing.
    fn materials_changed(&mut self) {}
    /// What the technique dropped or clamped beyond its stated model since the last call (e.g. `lobes`' blockers
    /// past its per-receiver bound), as lines for the user; reading may wait for the GPU. Default: nothing.
    fn warnings(&mut self, _gpu: &Gpu) -> Result<Vec<String>> {
        Ok(Vec::new())
    }
    /// [`Technique::warnings`] and the technique's work counts since the last call (e.g. `lobes`' products per
    /// receiver), as lines for the user. Default: the warnings, no counts.
    fn report(&mut self, gpu: &Gpu) -> Result<TechniqueReport> {
        Ok(TechniqueReport { warnings: self.warnings(gpu)?, counts: Vec::new() })
    }
    /// The blocker tiles' counts ([`tiles::TileCounts`]: list lengths since the last call, BVH nodes tested per
    /// pixel in the last frame) of a technique that traverses the blocker BVH per pixel. Default: none.
    fn tile_counts(&mut self, _gpu: &Gpu) -> Result<Option<tiles::TileCounts>> {
        Ok(None)
    }
    /// Technique-specific controls (e.g. the reference's sample counts), reached by downcasting.
    fn as_any_mut(&mut self) -> Option<&mut dyn std::any::Any> {
        None
    }
}

/// What a technique says about the frames since it was last asked ([`Technique::report`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TechniqueReport {
    /// What it dropped or clamped beyond its model.
    pub warnings: Vec<String>,
    /// Its work counts.
    pub counts: Vec<String>,
}

/// The two pipelines of a technique: `shade/<name>/pixel.comp` and `shade/<name>/vertex.comp`.
///
/// Both shaders are compiled to SPIR-V at creation (a GLSL error surfaces there), but each pipeline is created
/// on its first dispatch: a renderer shades per pixel or per vertex, rarely both, and on lavapipe creating the
/// `isg` pipeline costs ~5 s (measured: `shade/isg/pixel.comp` 4.9 s, `vertex.comp` 5.8 s of a 15 s bunny
/// set-up in the dev profile), so the unused one is never paid for.
pub struct TargetPipelines {
    technique: String,
    defines: Vec<(String, String)>,
    pixel: std::cell::OnceCell<ComputePipeline>,
    vertex: std::cell::OnceCell<ComputePipeline>,
}

impl TargetPipelines {
    pub fn new(gpu: &Gpu, technique: &str) -> Result<Self> {
        Self::with_defines(gpu, technique, &[])
    }

    /// The same compiled with preprocessor `defines` (a variant of the technique's shaders).
    pub fn with_defines(gpu: &Gpu, technique: &str, defines: &[(&str, &str)]) -> Result<Self> {
        for target in ["pixel", "vertex"] {
            gpu.compile_compute_shader(&format!("shade/{technique}/{target}.comp"), defines)?;
        }
        Ok(Self {
            technique: technique.to_string(),
            defines: defines.iter().map(|&(k, v)| (k.to_string(), v.to_string())).collect(),
            pixel: std::cell::OnceCell::new(),
            vertex: std::cell::OnceCell::new(),
        })
    }

    fn get(&self, gpu: &Gpu, per_vertex: bool) -> Result<&ComputePipeline> {
        let (cell, target) = if per_vertex { (&self.vertex, "vertex") } else { (&self.pixel, "pixel") };
        if cell.get().is_none() {
            let defines: Vec<(&str, &str)> = self.defines.iter().map(|(k, v)| (k.as_str(), v.as_str())).collect();
            let p = gpu.create_compute_pipeline(&format!("shade/{}/{target}.comp", self.technique), &defines)?;
            if let Err(p) = cell.set(p) {
                gpu.destroy_compute_pipeline(p);
            }
        }
        cell.get().ok_or_else(|| crate::gpu::GpuError::Other("internal: shade pipeline missing".into()))
    }

    /// The per-pixel pipeline, created on first use.
    pub fn pixel(&self, gpu: &Gpu) -> Result<&ComputePipeline> {
        self.get(gpu, false)
    }

    /// The per-vertex pipeline, created on first use.
    pub fn vertex(&self, gpu: &Gpu) -> Result<&ComputePipeline> {
        self.get(gpu, true)
    }

    /// Dispatch the pipeline for `target` with the common bindings plus `extra`.
    pub fn record(
        &self,
        rec: &mut Recorder,
        name: &str,
        inputs: &ShadeInputs,
        target: ShadeTarget,
        extra: &[Binding],
    ) -> Result<()> {
        self.record_with_push(rec, name, inputs, target, extra, &[])
    }

    /// [`Self::record`] with push constants.
    pub fn record_with_push(
        &self,
        rec: &mut Recorder,
        name: &str,
        inputs: &ShadeInputs,
        target: ShadeTarget,
        extra: &[Binding],
        push: &[u8],
    ) -> Result<()> {
        let mut b = vec![
            Binding::buffer("FrameBuf", inputs.frame),
            Binding::buffer("Materials", inputs.materials),
            Binding::sampled("env_map", inputs.background),
        ];
        b.extend_from_slice(extra);
        match target {
            ShadeTarget::Pixel { gbuffer, radiance } => {
                rec.begin_pass(&format!("shade/{name}"));
                b.push(Binding::storage_image("gbuf_position", &gbuffer.position));
                b.push(Binding::storage_image("gbuf_normal", &gbuffer.normal));
                b.push(Binding::storage_image("gbuf_geometric", &gbuffer.geometric));
                b.push(Binding::storage_image("radiance", radiance));
                let pipeline = self.pixel(rec.gpu())?;
                rec.dispatch(pipeline, &b, push, [radiance.desc.width, radiance.desc.height, 1])
            }
            ShadeTarget::Vertex { world_vertices, radiance, count } => {
                rec.begin_pass(&format!("shade/{name} (per vertex)"));
                b.push(Binding::buffer("WorldVertices", world_vertices));
                b.push(Binding::buffer("VertexRadiance", radiance));
                let pipeline = self.vertex(rec.gpu())?;
                rec.dispatch(pipeline, &b, push, [count, 1, 1])
            }
        }
    }

    pub fn destroy(self, gpu: &Gpu) {
        for p in [self.pixel.into_inner(), self.vertex.into_inner()].into_iter().flatten() {
            gpu.destroy_compute_pipeline(p);
        }
    }
}

/// Per-vertex mode: covered pixels take the interpolated vertex radiance, background the environment.
pub struct ComposePass {
    pipeline: ComputePipeline,
}

impl ComposePass {
    pub fn new(gpu: &Gpu) -> Result<Self> {
        Ok(Self { pipeline: gpu.create_compute_pipeline("shade/compose.comp", &[])? })
    }
    pub fn record(&self, rec: &mut Recorder, scene: &GpuScene, gbuffer: &GBuffer, radiance: &Image) -> Result<()> {
        rec.begin_pass("compose");
        rec.dispatch(
            &self.pipeline,
            &[
                Binding::buffer("FrameBuf", &scene.frame),
                Binding::sampled("env_map", &scene.environment.image),
                Binding::storage_image("gbuf_position", &gbuffer.position),
                Binding::storage_image("gbuf_vertex_radiance", &gbuffer.vertex_radiance),
                Binding::storage_image("radiance", radiance),
            ],
            &[],
            [radiance.desc.width, radiance.desc.height, 1],
        )
    }
    pub fn destroy(self, gpu: &Gpu) {
        gpu.destroy_compute_pipeline(self.pipeline);
    }
}

/// docs/technique-template/template.rs, compiled with the engine's tests against this registry's types, so that
/// the template cannot rot (its shaders are compiled by the test below).
#[cfg(test)]
#[path = "../../../../docs/technique-template/template.rs"]
mod template;

#[cfg(test)]
mod template_tests {
    use super::template;
    use crate::gpu::{ShaderCompiler, ShaderStage};
    use std::path::{Path, PathBuf};

    fn copy_dir(from: &Path, to: &Path) {
        std::fs::create_dir_all(to).unwrap();
        for e in std::fs::read_dir(from).unwrap().flatten() {
            let target = to.join(e.file_name());
            if e.path().is_dir() {
                copy_dir(&e.path(), &target);
            } else {
                std::fs::copy(e.path(), &target).unwrap();
            }
        }
    }

    /// The template's entry is a valid registry entry: its options parse at their defaults, under its name.
    #[test]
    fn template_entry_parses_its_defaults() {
        assert_eq!(template::ENTRY.name, "template");
        let o = crate::options::parse(template::ENTRY.name, template::ENTRY.options, &[]).expect("defaults");
        assert_eq!(o.float("gain"), 1.0);
        assert!(crate::options::parse("template", template::ENTRY.options, &[("gain".into(), "11".into())]).is_err());
    }

    /// The template's shaders compile (with shaderc, warnings as errors) when copied where its README says,
    /// `shaders-glsl/shade/template/`, next to the real shared GLSL they include.
    #[test]
    fn template_shaders_compile_in_place() {
        let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
        let tmp = std::env::temp_dir().join(format!("technique-template-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&tmp);
        let root = tmp.join("shaders-glsl");
        copy_dir(&repo.join("shaders-glsl"), &root);
        copy_dir(&repo.join("docs/technique-template/shader"), &root.join("shade/template"));
        let compiler = ShaderCompiler::new(root).expect("shaderc");
        for target in ["pixel.comp", "vertex.comp"] {
            let rel = format!("shade/template/{target}");
            compiler.compile(&rel, ShaderStage::Compute, &[]).unwrap_or_else(|e| panic!("{rel}: {e}"));
        }
        let _ = std::fs::remove_dir_all(&tmp);
    }
}
