//! The scene's spherical lights in device memory, shared by every technique: one buffer
//! `Lights { uint count; SphereLight lights[]; }` (shaders-glsl/shade/lights.glsl), validated once.

use super::invalid_scene;
use crate::gpu::{Buffer, BufferDesc, Gpu, Result};
use crate::scene::SphereLight;
use bytemuck::{Pod, Zeroable};

/// `struct SphereLight` of shaders-glsl/shade/lights.glsl: world-space centre and radius, emitted
/// radiance (linear RGB).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuSphereLight {
    pub center: [f32; 3],
    pub radius: f32,
    pub radiance: [f32; 3],
    pub pad0: f32,
}

/// The header of the `Lights` buffer (std430: the array starts at byte 16).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuLightsHeader {
    pub count: u32,
    pub pad: [u32; 3],
}

pub struct LightResources {
    /// The lights as given (world space), for techniques' `prepare`.
    pub cpu: Vec<SphereLight>,
    /// Header + at least one light record (zero when there is none, so the binding is valid).
    pub buffer: Buffer,
    pub count: u32,
}

/// The device records of `lights`, each checked: a positive finite radius at a finite centre, a
/// finite non-negative radiance. Errors name the light.
pub fn gpu_lights(lights: &[SphereLight]) -> Result<Vec<GpuSphereLight>> {
    lights
        .iter()
        .enumerate()
        .map(|(i, l)| {
            if l.radius.is_nan() || l.radius <= 0.0 || !l.center.is_finite() || !l.radius.is_finite() {
                return Err(invalid_scene(format!(
                    "light {i}: radius {} at {} is not a positive finite sphere",
                    l.radius, l.center
                )));
            }
            if !l.radiance.is_finite() || l.radiance.min_element() < 0.0 {
                return Err(invalid_scene(format!("light {i}: radiance {} is negative or not finite", l.radiance)));
            }
            Ok(GpuSphereLight {
                center: l.center.to_array(),
                radius: l.radius,
                radiance: l.radiance.to_array(),
                pad0: 0.0,
            })
        })
        .collect()
}

impl LightResources {
    pub fn new(gpu: &Gpu, lights: &[SphereLight]) -> Result<Self> {
        let records = gpu_lights(lights)?;
        let header = GpuLightsHeader { count: records.len() as u32, pad: [0; 3] };
        let mut words: Vec<u32> = bytemuck::cast_slice(std::slice::from_ref(&header)).to_vec();
        if records.is_empty() {
            words.extend_from_slice(bytemuck::cast_slice(&[GpuSphereLight::default()]));
        } else {
            words.extend_from_slice(bytemuck::cast_slice(&records));
        }
        let buffer = gpu.upload_buffer("scene-lights", BufferDesc::gpu_only(0), &words)?;
        Ok(Self { cpu: lights.to_vec(), buffer, count: records.len() as u32 })
    }

    pub fn destroy(self, gpu: &Gpu) {
        gpu.destroy_buffer(self.buffer);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn bad_lights_are_errors_naming_the_light() {
        let ok = SphereLight { center: Vec3::new(0.0, 2.0, 0.0), radius: 0.5, radiance: Vec3::splat(3.0) };
        let g = gpu_lights(&[ok]).expect("a good light");
        assert_eq!(g[0], GpuSphereLight { center: [0.0, 2.0, 0.0], radius: 0.5, radiance: [3.0; 3], pad0: 0.0 });
        for (bad, needle) in [
            (SphereLight { radius: 0.0, ..ok }, "radius"),
            (SphereLight { radius: -1.0, ..ok }, "radius"),
            (SphereLight { radius: f32::NAN, ..ok }, "radius"),
            (SphereLight { radius: f32::INFINITY, ..ok }, "radius"),
            (SphereLight { center: Vec3::new(f32::INFINITY, 0.0, 0.0), ..ok }, "radius"),
            (SphereLight { radiance: Vec3::new(-1.0, 0.0, 0.0), ..ok }, "radiance"),
            (SphereLight { radiance: Vec3::splat(f32::NAN), ..ok }, "radiance"),
        ] {
            let e = gpu_lights(&[ok, bad]).unwrap_err().to_string();
            assert!(e.contains("light 1") && e.contains(needle), "{bad:?}: {e}");
        }
        assert!(gpu_lights(&[]).expect("no lights").is_empty());
    }
}
