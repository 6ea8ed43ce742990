//! `skin` pass (shaders-glsl/skin): object-space vertices → world space, every frame: linear blend
//! skinning by `GpuScene::bones` (per-vertex `GpuScene::vertex_skins`; identity for rigid vertices), then
//! the instance transform.

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
                Binding::buffer("Bones", &scene.bones),
                Binding::buffer("VertexSkins", &scene.vertex_skins),
            ],
            bytemuck::cast_slice(&[scene.vertex_count, scene.bone_count]),
            [scene.vertex_count, 1, 1],
        )
    }
    pub fn destroy(self, gpu: &Gpu) {
        gpu.destroy_compute_pipeline(self.pipeline);
    }
}
