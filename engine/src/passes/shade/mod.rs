//! Shading passes behind the technique interface (DESIGN.md §2): every technique reads the same
//! inputs (G-buffer or world vertices, materials, environment, later the blocker buffers) and
//! writes one radiance target, per pixel or per vertex, from the same GLSL `shade_point`.

pub mod isg;
pub mod none;
pub mod reference;

use crate::gpu::{Binding, ComputePipeline, Gpu, Image, Recorder, Result};
use crate::passes::gbuffer::GBuffer;
use crate::renderer::GpuScene;

/// Where a technique writes radiance.
#[derive(Clone, Copy)]
pub enum ShadeTarget<'a> {
    /// One invocation per G-buffer pixel, into `radiance`.
    Pixel { gbuffer: &'a GBuffer, radiance: &'a Image },
    /// One invocation per world-space vertex, into `GpuScene::vertex_radiance`.
    Vertex,
}

/// The fixed inputs of every technique.
pub struct ShadeInputs<'a> {
    pub scene: &'a GpuScene,
}

pub trait Technique {
    fn name(&self) -> &'static str;
    /// Derive only the representations this technique reads (prefiltered maps, SG fit, SH, tables).
    fn prepare(&mut self, gpu: &Gpu, scene: &GpuScene) -> Result<()>;
    /// Record shading into `target`.
    fn record(&self, rec: &mut Recorder, inputs: &ShadeInputs, target: ShadeTarget) -> Result<()>;
    fn destroy(self: Box<Self>, gpu: &Gpu);
    /// Technique-specific controls (e.g. the reference's sample counts), reached by downcasting.
    fn as_any_mut(&mut self) -> Option<&mut dyn std::any::Any> {
        None
    }
}

/// Names accepted by [`create_technique`].
pub const TECHNIQUES: &[&str] = &["none", "isg", "reference"];

/// Split a technique spec `name[:key=value,key=value...]` into its name and options.
pub fn parse_technique_spec(spec: &str) -> Result<(&str, Vec<(String, String)>)> {
    let (name, rest) = spec.split_once(':').unwrap_or((spec, ""));
    let mut options = Vec::new();
    for part in rest.split(',').filter(|p| !p.trim().is_empty()) {
        let (k, v) = part.split_once('=').ok_or_else(|| {
            crate::gpu::GpuError::Other(format!("technique '{spec}': option '{part}' is not key=value"))
        })?;
        options.push((k.trim().to_string(), v.trim().to_string()));
    }
    Ok((name.trim(), options))
}

/// A technique from its spec, `name[:key=value,...]`: `none`, `isg` (options in
/// [`isg::IsgOptions`]) or `reference`; `lobes` and `shexp` plug in here.
pub fn create_technique(gpu: &Gpu, spec: &str) -> Result<Box<dyn Technique>> {
    let (name, options) = parse_technique_spec(spec)?;
    let no_options = || -> Result<()> {
        match options.first() {
            Some((k, _)) => Err(crate::gpu::GpuError::Other(format!("technique '{name}' has no option '{k}'"))),
            None => Ok(()),
        }
    };
    match name {
        "none" => {
            no_options()?;
            Ok(Box::new(none::NoShadows::new(gpu)?))
        }
        "isg" => Ok(Box::new(isg::Isg::new(gpu, isg::IsgOptions::parse(&options)?)?)),
        "reference" => {
            no_options()?;
            Ok(Box::new(reference::Reference::new(gpu)?))
        }
        other => Err(crate::gpu::GpuError::Other(format!(
            "unknown technique '{other}' (available: {})",
            TECHNIQUES.join(", ")
        ))),
    }
}

/// The two pipelines of a technique: `shade/<name>/pixel.comp` and `shade/<name>/vertex.comp`.
pub struct TargetPipelines {
    pub pixel: ComputePipeline,
    pub vertex: ComputePipeline,
}

impl TargetPipelines {
    pub fn new(gpu: &Gpu, technique: &str) -> Result<Self> {
        Self::with_defines(gpu, technique, &[])
    }

    /// The same compiled with preprocessor `defines` (a variant of the technique's shaders).
    pub fn with_defines(gpu: &Gpu, technique: &str, defines: &[(&str, &str)]) -> Result<Self> {
        let pixel = gpu.create_compute_pipeline(&format!("shade/{technique}/pixel.comp"), defines)?;
        match gpu.create_compute_pipeline(&format!("shade/{technique}/vertex.comp"), defines) {
            Ok(vertex) => Ok(Self { pixel, vertex }),
            Err(e) => {
                gpu.destroy_compute_pipeline(pixel);
                Err(e)
            }
        }
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
        let s = inputs.scene;
        let mut b = vec![
            Binding::buffer("FrameBuf", &s.frame),
            Binding::buffer("Materials", &s.materials),
            Binding::sampled("env_map", &s.environment),
        ];
        b.extend_from_slice(extra);
        match target {
            ShadeTarget::Pixel { gbuffer, radiance } => {
                rec.begin_pass(&format!("shade/{name}"));
                b.push(Binding::storage_image("gbuf_position", &gbuffer.position));
                b.push(Binding::storage_image("gbuf_normal", &gbuffer.normal));
                b.push(Binding::storage_image("radiance", radiance));
                rec.dispatch(&self.pixel, &b, &[], [radiance.desc.width, radiance.desc.height, 1])
            }
            ShadeTarget::Vertex => {
                rec.begin_pass(&format!("shade/{name} (per vertex)"));
                b.push(Binding::buffer("WorldVertices", &s.world_vertices));
                b.push(Binding::buffer("VertexRadiance", &s.vertex_radiance));
                rec.dispatch(&self.vertex, &b, &[], [s.vertex_count, 1, 1])
            }
        }
    }

    pub fn destroy(self, gpu: &Gpu) {
        gpu.destroy_compute_pipeline(self.pixel);
        gpu.destroy_compute_pipeline(self.vertex);
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
                Binding::sampled("env_map", &scene.environment),
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
