//! `skin` pass (shaders-glsl/skin): object-space vertices → world space, every frame.

use crate::gpu::{Binding, ComputePipeline, Gpu, Recorder, Result};
use crate::renderer::GpuScene;

pub struct SkinPass {
    pipeline: ComputePipeline,
}

impl SkinPass {
    pub fn new(gpu: &Gpu) -> Result<Self> {
        Ok(Self { pipeline: gpu.create_compute_pipeline("skin/skin.comp", &[])? })
    }
    pub fn record(&self, rec: &mut Recorder, scene: &GpuScene) -> Result<()> {
        rec.begin_pass("skin");
        rec.dispatch(
            &self.pipeline,
            &[
                Binding::buffer("Vertices", &scene.vertices),
                Binding::buffer("Objects", &scene.objects),
                Binding::buffer("WorldVertices", &scene.world_vertices),
            ],
            bytemuck::bytes_of(&scene.vertex_count),
            [scene.vertex_count, 1, 1],
        )
    }
    pub fn destroy(self, gpu: &Gpu) {
        gpu.destroy_compute_pipeline(self.pipeline);
    }
}
