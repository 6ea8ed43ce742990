//! `skin` pass (shaders-glsl/skin): object-space vertices → world space, every frame: linear blend
//! skinning by `Geometry::bones` (per-vertex `Geometry::vertex_skins`; identity for rigid vertices), then
//! the instance transform.

use crate::gpu::{Binding, ComputePipeline, Gpu, Recorder, Result};
use crate::resources::GpuScene;

/// Push constants of shaders-glsl/skin/skin.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SkinPush {
    pub vertex_count: u32,
    pub bone_count: u32,
}

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
                Binding::buffer("Vertices", &scene.geometry.vertices),
                Binding::buffer("Objects", &scene.geometry.objects),
                Binding::buffer("WorldVertices", &scene.geometry.world_vertices),
                Binding::buffer("Bones", &scene.geometry.bones),
                Binding::buffer("VertexSkins", &scene.geometry.vertex_skins),
            ],
            bytemuck::bytes_of(&SkinPush {
                vertex_count: scene.geometry.vertex_count,
                bone_count: scene.geometry.bone_count,
            }),
            [scene.geometry.vertex_count, 1, 1],
        )
    }
    pub fn destroy(self, gpu: &Gpu) {
        gpu.destroy_compute_pipeline(self.pipeline);
    }
}
