//! Host twins of the std430 structs in `shaders-glsl/common/scene.glsl`, declared once here.

use bytemuck::{Pod, Zeroable};

/// `struct Vertex`: position.w = instance index, normal.w = material index.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuVertex {
    pub position: [f32; 4],
    pub normal: [f32; 4],
}

/// `struct Object`: model matrix and its inverse transpose (column-major).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuObject {
    pub model: [f32; 16],
    pub normal_matrix: [f32; 16],
}

/// `struct Material` (see scene.glsl): diffuse.rgb = ρ_d, diffuse.w = BRDF kind
/// ([`BRDF_BLINN_PHONG`] …); specular.rgb = k_s, specular.w = Blinn-Phong exponent s;
/// brdf = Cook-Torrance (α, λ_h, μ, 0) or Ashikhmin–Shirley (n_u, n_v, λ_h, δ); lobes = the
/// Ashikhmin–Shirley amplitudes μ_{|k|}, k = 0..3; tangent.xyz = anisotropy direction, tangent.w = 1
/// when the Ashikhmin–Shirley lobes lie along b, 0 along t. The SG fits (λ_h, μ, δ) are computed here
/// once per material (`engine::math::brdf::HalfVectorFit`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuMaterial {
    pub diffuse: [f32; 4],
    pub specular: [f32; 4],
    pub brdf: [f32; 4],
    pub lobes: [f32; 4],
    pub tangent: [f32; 4],
}

/// BRDF kinds in `GpuMaterial::diffuse[3]` (exact small integers in f32).
pub const BRDF_BLINN_PHONG: f32 = 0.0;
pub const BRDF_COOK_TORRANCE_BECKMANN: f32 = 1.0;
pub const BRDF_COOK_TORRANCE_GGX: f32 = 2.0;
pub const BRDF_ASHIKHMIN_SHIRLEY: f32 = 3.0;

impl GpuMaterial {
    pub fn from_material(m: &crate::scene::Material) -> Self {
        use crate::scene::{Brdf, Ndf};
        let fit = engine_math::brdf::HalfVectorFit::new(&m.specular_model());
        let (kind, brdf) = match m.brdf {
            Brdf::BlinnPhong => (BRDF_BLINN_PHONG, [0.0; 4]),
            Brdf::CookTorrance { ndf, roughness } => (
                if ndf == Ndf::Ggx { BRDF_COOK_TORRANCE_GGX } else { BRDF_COOK_TORRANCE_BECKMANN },
                [roughness, fit.lambda_h as f32, fit.mu[0] as f32, 0.0],
            ),
            Brdf::AshikhminShirley { nu, nv } => {
                (BRDF_ASHIKHMIN_SHIRLEY, [nu, nv, fit.lambda_h as f32, fit.delta as f32])
            }
        };
        let t = m.tangent;
        Self {
            diffuse: [m.diffuse.x, m.diffuse.y, m.diffuse.z, kind],
            specular: [m.specular.x, m.specular.y, m.specular.z, m.shininess],
            brdf,
            lobes: if m.brdf == Brdf::BlinnPhong { [0.0; 4] } else { fit.mu.map(|x| x as f32) },
            tangent: [t.x, t.y, t.z, if fit.wide_is_b { 1.0 } else { 0.0 }],
        }
    }
}

/// `struct FrameData` (see the GLSL for the meaning of each lane).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct FrameData {
    pub eye: [f32; 4],
    pub right: [f32; 4],
    pub up: [f32; 4],
    pub forward: [f32; 4],
    pub params: [f32; 4],
    pub size: [u32; 4],
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{offset_of, size_of};

    // std430 offsets as declared in shaders-glsl/common/scene.glsl.
    #[test]
    fn std430_layouts() {
        assert_eq!(size_of::<GpuVertex>(), 32);
        assert_eq!(offset_of!(GpuVertex, normal), 16);
        assert_eq!(size_of::<GpuObject>(), 128);
        assert_eq!(offset_of!(GpuObject, normal_matrix), 64);
        assert_eq!(size_of::<GpuMaterial>(), 80);
        assert_eq!(offset_of!(GpuMaterial, specular), 16);
        assert_eq!(offset_of!(GpuMaterial, brdf), 32);
        assert_eq!(offset_of!(GpuMaterial, lobes), 48);
        assert_eq!(offset_of!(GpuMaterial, tangent), 64);
        assert_eq!(size_of::<FrameData>(), 96);
        assert_eq!(offset_of!(FrameData, params), 64);
        assert_eq!(offset_of!(FrameData, size), 80);
    }
}
