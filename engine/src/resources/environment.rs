//! The environment and what is derived from it once per scene, shared by every technique: the
//! texture itself, the SG-prefiltered maps Γ_L (ISG Eq. 10), the irradiance grid E(n), and a slot
//! for its SH projection (filled on first use, e.g. by SHEXP, and kept for the scene's lifetime).

use crate::gpu::{Buffer, BufferDesc, Gpu, Image, ImageDesc, ImageFormat, Result};
use engine_math::envmap::LatLongMap;
use engine_math::prefilter::{sg_prefiltered_map, IrradianceGrid, PREFILTER_LEVELS};
use engine_math::sh::{project_latlong, Window};
use std::cell::{Ref, RefCell};

/// Size of the irradiance grid (columns, rows including both poles).
pub const IRRADIANCE_SIZE: (usize, usize) = (64, 33);
/// Size of each prefiltered level.
pub const PREFILTER_SIZE: (usize, usize) = (256, 128);

/// The environment's SH projection of one order (unwindowed: a technique applies its own window).
pub struct ShProjection {
    pub order: usize,
    /// n² RGB coefficients (f32, `vec4` per coefficient on the GPU, w = 0).
    pub coefficients: Vec<[f32; 3]>,
    pub buffer: Buffer,
}

pub struct EnvironmentResources {
    /// The environment (already scaled by the scene's intensity), RGBA32F, sampled by direction.
    pub image: Image,
    /// The same on the CPU, for techniques' `prepare` (SG fits, sampling tables).
    pub cpu: LatLongMap,
    /// The unrotated map (scaled like `cpu`), from which [`Self::rotated`] resamples: rotations do not
    /// accumulate resampling blur.
    base: LatLongMap,
    /// The rotation about +y (degrees) of `cpu` against `base`.
    pub rotation_degrees: f32,
    /// Γ_L at λ = 4^(k−1), k = 0..8, stacked vertically (read by `prefiltered_lookup` in
    /// shaders-glsl/shade/prefiltered.glsl).
    pub prefiltered: Image,
    /// E(n): the exact clamped-cosine sum over the environment on a grid with rows on both poles
    /// ([`IrradianceGrid`], read by `irradiance_lookup`).
    pub irradiance: Image,
    sh: RefCell<Vec<ShProjection>>,
}

fn rgba32f_bytes(texels: &[[f32; 3]]) -> Vec<u8> {
    let v: Vec<f32> = texels.iter().flat_map(|t| [t[0], t[1], t[2], 1.0]).collect();
    bytemuck::cast_slice(&v).to_vec()
}

impl EnvironmentResources {
    pub fn new(gpu: &Gpu, environment: &LatLongMap, intensity: f32) -> Result<Self> {
        let base = LatLongMap {
            width: environment.width,
            height: environment.height,
            texels: environment.texels.iter().map(|t| t.map(|c| c * intensity)).collect(),
        };
        Self::build(gpu, base, 0.0)
    }

    /// The same environment rotated about +y by `degrees` (from the unrotated map, not from this
    /// rotation): every derived map is recomputed, so this is a scene-change event, not a per-frame
    /// operation (the textures and grids are uploaded anew).
    pub fn rotated(&self, gpu: &Gpu, degrees: f32) -> Result<Self> {
        if !degrees.is_finite() {
            return Err(super::invalid_scene(format!("environment rotation {degrees}° is not finite")));
        }
        Self::build(gpu, self.base.clone(), degrees)
    }

    fn build(gpu: &Gpu, base: LatLongMap, degrees: f32) -> Result<Self> {
        let cpu = if degrees.rem_euclid(360.0) == 0.0 { base.clone() } else { base.rotated_y(degrees) };
        let irr = IrradianceGrid::compute(&cpu, IRRADIANCE_SIZE.0, IRRADIANCE_SIZE.1);
        let mut stacked = Vec::with_capacity(PREFILTER_SIZE.0 * PREFILTER_SIZE.1 * PREFILTER_LEVELS);
        for level in 0..PREFILTER_LEVELS {
            stacked.extend(sg_prefiltered_map(&cpu, level, PREFILTER_SIZE.0, PREFILTER_SIZE.1).texels);
        }
        let image = gpu.upload_image(
            "environment",
            ImageDesc::texture(cpu.width as u32, cpu.height as u32, ImageFormat::Rgba32f),
            &rgba32f_bytes(&cpu.texels),
        )?;
        let irradiance = gpu.upload_image(
            "environment-irradiance",
            ImageDesc::texture(IRRADIANCE_SIZE.0 as u32, IRRADIANCE_SIZE.1 as u32, ImageFormat::Rgba32f),
            &rgba32f_bytes(&irr.texels),
        );
        let irradiance = match irradiance {
            Ok(i) => i,
            Err(e) => {
                gpu.destroy_image(image);
                return Err(e);
            }
        };
        let prefiltered = gpu.upload_image(
            "environment-prefiltered",
            ImageDesc::texture(
                PREFILTER_SIZE.0 as u32,
                (PREFILTER_SIZE.1 * PREFILTER_LEVELS) as u32,
                ImageFormat::Rgba32f,
            ),
            &rgba32f_bytes(&stacked),
        );
        match prefiltered {
            Ok(prefiltered) => Ok(Self {
                image,
                cpu,
                base,
                rotation_degrees: degrees,
                prefiltered,
                irradiance,
                sh: RefCell::new(Vec::new()),
            }),
            Err(e) => {
                gpu.destroy_image(image);
                gpu.destroy_image(irradiance);
                Err(e)
            }
        }
    }

    /// The environment's order-`order` SH projection (paper SHEXP Eq. 1, unwindowed), computed and
    /// uploaded on the first request of that order and shared from then on.
    pub fn sh_projection(&self, gpu: &Gpu, order: usize) -> Result<Ref<'_, ShProjection>> {
        if !(1..=engine_math::sh::MAX_ORDER).contains(&order) {
            return Err(crate::gpu::GpuError::Other(format!(
                "SH order {order}: supported 1..={}",
                engine_math::sh::MAX_ORDER
            )));
        }
        let index = self.sh.borrow().iter().position(|p| p.order == order);
        let index = match index {
            Some(i) => i,
            None => {
                let [r, g, b] = project_latlong(&self.cpu, order, Window::None);
                let coefficients: Vec<[f32; 3]> =
                    (0..order * order).map(|i| [r[i] as f32, g[i] as f32, b[i] as f32]).collect();
                let gpu_data: Vec<[f32; 4]> = coefficients.iter().map(|c| [c[0], c[1], c[2], 0.0]).collect();
                let buffer =
                    gpu.upload_buffer(&format!("environment-sh{order}"), BufferDesc::gpu_only(0), &gpu_data)?;
                let mut slot = self.sh.borrow_mut();
                slot.push(ShProjection { order, coefficients, buffer });
                slot.len() - 1
            }
        };
        Ok(Ref::map(self.sh.borrow(), |v| &v[index]))
    }

    pub fn destroy(self, gpu: &Gpu) {
        gpu.destroy_image(self.image);
        gpu.destroy_image(self.prefiltered);
        gpu.destroy_image(self.irradiance);
        for p in self.sh.into_inner() {
            gpu.destroy_buffer(p.buffer);
        }
    }
}
