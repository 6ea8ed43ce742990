//! The environment and what is derived from it once per scene, shared by every technique: the
//! texture itself, the SG-prefiltered maps Γ_L (ISG Eq. 10), the irradiance grid E(n), and a slot
//! for its SH projection (filled on first use, e.g. by SHEXP, and kept for the scene's lifetime).

use crate::gpu::{Buffer, BufferDesc, Gpu, Image, ImageDesc, ImageFormat, Result};
use crate::resources::LightResources;
use crate::scene::SphereLight;
use engine_math::env_lights::{decompose, EnvDecomposition, EnvLightParams};
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
            return Err(crate::options::OptionError(format!(
                "SH order {order}: supported 1..={}",
                engine_math::sh::MAX_ORDER
            ))
            .into());
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

/// The lights are placed this many scene radii from the scene's centre: far enough that their directions
/// barely change across the scene (parallax 1/256 rad at its rim), near enough for f32 (DESIGN §7).
pub const ENV_LIGHT_DISTANCE: f32 = 256.0;

/// The environment split into spherical lights and a residual ([`engine_math::env_lights`]), for the
/// techniques whose `env_lights` option is on: they read [`EnvSplit::residual`] as their environment and
/// [`EnvSplit::lights`] (the scene's own lights, then the environment's) as their lights. Made on first
/// request and kept until the environment changes.
pub struct EnvSplit {
    /// The decomposition on the CPU (the lights as directions and cap sizes, the residual's texels, what was
    /// found).
    pub decomposition: EnvDecomposition,
    /// The residual as an environment: its maps, irradiance grid and SH projections.
    pub residual: EnvironmentResources,
    /// The scene's lights followed by the environment's, as spheres [`ENV_LIGHT_DISTANCE`] scene radii away.
    pub lights: LightResources,
    /// Seconds the decomposition itself took on the CPU (not the residual's maps).
    pub decompose_seconds: f64,
    /// Seconds the residual's maps and the lights' buffer took.
    pub build_seconds: f64,
}

impl EnvSplit {
    /// Split `environment` by `params` and upload the residual and the lights (`scene_lights` first), placed
    /// about the scene's bounding sphere (`center`, `radius`).
    pub fn new(
        gpu: &Gpu,
        environment: &EnvironmentResources,
        params: &EnvLightParams,
        scene_lights: &[SphereLight],
        center: glam::Vec3,
        radius: f32,
    ) -> Result<Self> {
        params.check().map_err(crate::options::OptionError)?;
        let t0 = std::time::Instant::now();
        let decomposition = decompose(&environment.cpu, params);
        let decompose_seconds = t0.elapsed().as_secs_f64();
        let t1 = std::time::Instant::now();
        let lights = env_sphere_lights(&decomposition, center, radius);
        let all: Vec<SphereLight> = scene_lights.iter().copied().chain(lights).collect();
        let residual = EnvironmentResources::new(gpu, &decomposition.residual(&environment.cpu), 1.0)?;
        let lights = match LightResources::new(gpu, &all) {
            Ok(l) => l,
            Err(e) => {
                residual.destroy(gpu);
                return Err(e);
            }
        };
        Ok(Self { decomposition, residual, lights, decompose_seconds, build_seconds: t1.elapsed().as_secs_f64() })
    }

    pub fn destroy(self, gpu: &Gpu) {
        self.residual.destroy(gpu);
        self.lights.destroy(gpu);
    }
}

/// The decomposition's lights as spheres [`ENV_LIGHT_DISTANCE`] × `radius` from `center`, each subtending its
/// cap from there.
pub fn env_sphere_lights(d: &EnvDecomposition, center: glam::Vec3, radius: f32) -> Vec<SphereLight> {
    let distance = ENV_LIGHT_DISTANCE as f64 * (radius as f64).max(1e-3);
    d.lights
        .iter()
        .map(|l| {
            let (c, r) = l.sphere(center.as_dvec3().to_array(), distance);
            SphereLight {
                center: glam::DVec3::from(c).as_vec3(),
                radius: r as f32,
                radiance: glam::DVec3::from(l.radiance).as_vec3(),
            }
        })
        .collect()
}
