//! `tonemap` pass (shaders-glsl/tonemap): exposure, ACES fit, sRGB, into an RGBA8 image.

use crate::gpu::{Binding, ComputePipeline, Gpu, Image, Recorder, Result};
use crate::resources::GpuScene;

pub struct TonemapPass {
    pipeline: ComputePipeline,
}

impl TonemapPass {
    pub fn new(gpu: &Gpu) -> Result<Self> {
        Ok(Self { pipeline: gpu.create_compute_pipeline("tonemap/tonemap.comp", &[])? })
    }
    pub fn record(&self, rec: &mut Recorder, scene: &GpuScene, radiance: &Image, ldr: &Image) -> Result<()> {
        rec.begin_pass("tonemap");
        rec.dispatch(
            &self.pipeline,
            &[
                Binding::buffer("FrameBuf", &scene.frame),
                Binding::storage_image("radiance", radiance),
                Binding::storage_image("ldr", ldr),
            ],
            &[],
            [ldr.desc.width, ldr.desc.height, 1],
        )
    }
    pub fn destroy(self, gpu: &Gpu) {
        gpu.destroy_compute_pipeline(self.pipeline);
    }
}
