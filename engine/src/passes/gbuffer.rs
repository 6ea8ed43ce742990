//! `gbuffer` pass (shaders-glsl/gbuffer): raster into depth, world position (w = material + 1,
//! 0 = background), shading normal, interpolated per-vertex radiance and geometric normal (w = the
//! index of the triangle's first vertex, as an f32: exact up to 2²⁴ vertices). Both
//! normals face the viewer: the side is the geometric normal's and the shading normal is adapted
//! where it would face away (shaders-glsl/common/shading.glsl, twin `engine::math::shading`).

use crate::gpu::{
    Binding, Gpu, GraphicsPipeline, GraphicsPipelineDesc, Image, ImageDesc, ImageFormat, Recorder, Result,
};
use crate::resources::GpuScene;

/// The G-buffer every technique reads.
pub struct GBuffer {
    pub position: Image,
    /// The shading normal every technique uses (xyz, unit, facing the viewer).
    pub normal: Image,
    pub vertex_radiance: Image,
    /// The triangle's geometric normal (xyz, unit, facing the viewer): the side the reference's rays
    /// leave from; w: the index of the triangle's first (provoking) vertex, as an f32 (`shexp`'s
    /// `pixel_clusters=world` finds a pixel's vertex cluster by it).
    pub geometric: Image,
    pub depth: Image,
}

impl GBuffer {
    pub fn new(gpu: &Gpu, width: u32, height: u32) -> Result<Self> {
        let t = |f| ImageDesc::target(width, height, f);
        let position = gpu.create_image("gbuffer-position", t(ImageFormat::Rgba32f))?;
        let normal = gpu.create_image("gbuffer-normal", t(ImageFormat::Rgba32f));
        let vertex_radiance = gpu.create_image("gbuffer-vertex-radiance", t(ImageFormat::Rgba32f));
        let geometric = gpu.create_image("gbuffer-geometric-normal", t(ImageFormat::Rgba32f));
        let depth = gpu.create_image("gbuffer-depth", t(ImageFormat::Depth32f));
        match (normal, vertex_radiance, geometric, depth) {
            (Ok(normal), Ok(vertex_radiance), Ok(geometric), Ok(depth)) => {
                Ok(Self { position, normal, vertex_radiance, geometric, depth })
            }
            (n, v, g, d) => {
                gpu.destroy_image(position);
                let mut err = None;
                for r in [n, v, g, d] {
                    match r {
                        Ok(i) => gpu.destroy_image(i),
                        Err(e) => err = err.or(Some(e)),
                    }
                }
                Err(err.unwrap_or_else(|| crate::gpu::GpuError::Other("G-buffer creation failed".into())))
            }
        }
    }
    pub fn destroy(self, gpu: &Gpu) {
        gpu.destroy_image(self.position);
        gpu.destroy_image(self.normal);
        gpu.destroy_image(self.vertex_radiance);
        gpu.destroy_image(self.geometric);
        gpu.destroy_image(self.depth);
    }
}

pub struct GBufferPass {
    pipeline: GraphicsPipeline,
}

impl GBufferPass {
    pub fn new(gpu: &Gpu) -> Result<Self> {
        Ok(Self {
            pipeline: gpu.create_graphics_pipeline(&GraphicsPipelineDesc {
                vertex: "gbuffer/gbuffer.vert",
                fragment: "gbuffer/gbuffer.frag",
                defines: &[],
                color_formats: &[
                    ImageFormat::Rgba32f,
                    ImageFormat::Rgba32f,
                    ImageFormat::Rgba32f,
                    ImageFormat::Rgba32f,
                ],
                depth_format: Some(ImageFormat::Depth32f),
            })?,
        })
    }
    pub fn record(&self, rec: &mut Recorder, scene: &GpuScene, gbuffer: &GBuffer) -> Result<()> {
        rec.begin_pass("gbuffer");
        rec.draw_indexed(
            &self.pipeline,
            &[
                Binding::buffer("WorldVertices", &scene.geometry.world_vertices),
                Binding::buffer("FrameBuf", &scene.frame),
                Binding::buffer("VertexRadiance", &scene.geometry.vertex_radiance),
            ],
            &[],
            &[&gbuffer.position, &gbuffer.normal, &gbuffer.vertex_radiance, &gbuffer.geometric],
            Some(&gbuffer.depth),
            &scene.geometry.indices,
            scene.geometry.index_count,
        )
    }
    pub fn destroy(self, gpu: &Gpu) {
        gpu.destroy_graphics_pipeline(self.pipeline);
    }
}
