//! Technique `none` (shaders-glsl/shade/none): unshadowed environment lighting, diffuse from the
//! irradiance map and glossy from SG-prefiltered environment maps. The baseline every shadowing
//! technique is compared with, and the furnace reference (ρL for a Lambertian plane).

use super::{ShadeInputs, ShadeTarget, TargetPipelines, Technique};
use crate::gpu::{Binding, Gpu, Image, ImageDesc, ImageFormat, Recorder, Result};
use crate::renderer::GpuScene;
use engine_math::prefilter::{sg_prefiltered_map, IrradianceGrid, PREFILTER_LEVELS};

/// Size of the irradiance grid (columns, rows including both poles) and of each prefiltered level.
const IRRADIANCE_SIZE: (usize, usize) = (64, 33);
const PREFILTER_SIZE: (usize, usize) = (256, 128);

pub struct NoShadows {
    pipelines: TargetPipelines,
    maps: Option<(Image, Image)>,
}

impl NoShadows {
    pub fn new(gpu: &Gpu) -> Result<Self> {
        Ok(Self { pipelines: TargetPipelines::new(gpu, "none")?, maps: None })
    }
}

/// The irradiance grid E(n) (exact clamped-cosine sum over the environment, rows on both poles:
/// [`IrradianceGrid`]), RGBA32F.
pub(crate) fn irradiance_image(gpu: &Gpu, name: &str, env: &engine_math::envmap::LatLongMap) -> Result<Image> {
    let irr = IrradianceGrid::compute(env, IRRADIANCE_SIZE.0, IRRADIANCE_SIZE.1);
    gpu.upload_image(
        name,
        ImageDesc::texture(IRRADIANCE_SIZE.0 as u32, IRRADIANCE_SIZE.1 as u32, ImageFormat::Rgba32f),
        &rgba32f_bytes(&irr.texels),
    )
}

/// The SG-prefiltered environment maps Γ_L (ISG Eq. 10) at λ = 4^(k−1), k = 0..8, stacked
/// vertically in one RGBA32F texture (read by `prefiltered_lookup` in shaders-glsl/shade/prefiltered.glsl).
pub(crate) fn prefiltered_atlas(gpu: &Gpu, name: &str, env: &engine_math::envmap::LatLongMap) -> Result<Image> {
    let mut stacked = Vec::with_capacity(PREFILTER_SIZE.0 * PREFILTER_SIZE.1 * PREFILTER_LEVELS);
    for level in 0..PREFILTER_LEVELS {
        stacked.extend(sg_prefiltered_map(env, level, PREFILTER_SIZE.0, PREFILTER_SIZE.1).texels);
    }
    gpu.upload_image(
        name,
        ImageDesc::texture(PREFILTER_SIZE.0 as u32, (PREFILTER_SIZE.1 * PREFILTER_LEVELS) as u32, ImageFormat::Rgba32f),
        &rgba32f_bytes(&stacked),
    )
}

fn rgba32f_bytes(texels: &[[f32; 3]]) -> Vec<u8> {
    let v: Vec<f32> = texels.iter().flat_map(|t| [t[0], t[1], t[2], 1.0]).collect();
    bytemuck::cast_slice(&v).to_vec()
}

impl Technique for NoShadows {
    fn name(&self) -> &'static str {
        "none"
    }

    fn prepare(&mut self, gpu: &Gpu, scene: &GpuScene) -> Result<()> {
        if let Some((a, b)) = self.maps.take() {
            gpu.destroy_image(a);
            gpu.destroy_image(b);
        }
        let env = &scene.environment_cpu;
        let irr_img = irradiance_image(gpu, "none-irradiance", env)?;
        let pre = prefiltered_atlas(gpu, "none-prefiltered", env);
        match pre {
            Ok(pre) => {
                self.maps = Some((irr_img, pre));
                Ok(())
            }
            Err(e) => {
                gpu.destroy_image(irr_img);
                Err(e)
            }
        }
    }

    fn record(&self, rec: &mut Recorder, inputs: &ShadeInputs, target: ShadeTarget) -> Result<()> {
        let Some((irr, pre)) = &self.maps else {
            return Err(crate::gpu::GpuError::Other("technique 'none' recorded before prepare()".into()));
        };
        self.pipelines.record(
            rec,
            "none",
            inputs,
            target,
            &[Binding::sampled("irradiance_map", irr), Binding::sampled("prefiltered_env", pre)],
        )
    }

    fn destroy(self: Box<Self>, gpu: &Gpu) {
        if let Some((a, b)) = self.maps {
            gpu.destroy_image(a);
            gpu.destroy_image(b);
        }
        self.pipelines.destroy(gpu);
    }
}
