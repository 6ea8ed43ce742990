//! Host twins of the std430 structs in `shaders-glsl/common/scene.glsl`, declared once here.

use bytemuck::{Pod, Zeroable};

/// `struct Vertex` (scene.glsl). The indices are f32 (exact below 2^24) as the shaders read them.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuVertex {
    pub position: [f32; 3],
    /// Index of the instance (its `GpuObject`).
    pub instance: f32,
    pub normal: [f32; 3],
    /// Index of the material.
    pub material: f32,
}

/// `struct Object`: model matrix and its inverse transpose (column-major).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuObject {
    pub model: [f32; 16],
    pub normal_matrix: [f32; 16],
}

/// `struct Material` (see scene.glsl). `brdf` holds the parameters of the model `kind` names:
/// Cook-Torrance (α, λ_h, μ, 0), Ashikhmin–Shirley (n_u, n_v, λ_h, δ) or Lafortune (C_x, C_y, C_z, e),
/// zero for Blinn-Phong; `lobes`
/// = the per-lobe amplitudes: Ashikhmin–Shirley μ_{|k|}, k = 0..3 (indexed by k), Lafortune's weights
/// (1, w_1, w_2, 0) of its lobes, whose further (C, e) are `more` (zero elsewhere). The SG fits (λ_h, μ, δ) are
/// computed here once per material (`engine::math::brdf::HalfVectorFit`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuMaterial {
    /// ρ_d.
    pub diffuse: [f32; 3],
    /// [`BRDF_BLINN_PHONG`] … (exact small integers in f32).
    pub kind: f32,
    /// k_s (F0).
    pub specular: [f32; 3],
    /// Blinn-Phong exponent s.
    pub shininess: f32,
    pub brdf: [f32; 4],
    pub lobes: [f32; 4],
    /// Anisotropy direction.
    pub tangent: [f32; 3],
    /// 1 when the Ashikhmin–Shirley lobes lie along b, 0 along t.
    pub lobes_along_b: f32,
    /// Lafortune: (C_x, C_y, C_z, e) of lobes 1 and 2 (their weights in `lobes`).
    pub more: [[f32; 4]; crate::scene::LAFORTUNE_MORE],
}

/// BRDF kinds in [`GpuMaterial::kind`] (exact small integers in f32).
pub const BRDF_BLINN_PHONG: f32 = 0.0;
pub const BRDF_COOK_TORRANCE_BECKMANN: f32 = 1.0;
pub const BRDF_COOK_TORRANCE_GGX: f32 = 2.0;
pub const BRDF_ASHIKHMIN_SHIRLEY: f32 = 3.0;
pub const BRDF_LAFORTUNE: f32 = 4.0;

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
            Brdf::Lafortune { c, e, .. } => (BRDF_LAFORTUNE, [c[0], c[1], c[2], e]),
        };
        let (lobes, more) = match m.brdf {
            Brdf::BlinnPhong => ([0.0; 4], [[0.0; 4]; crate::scene::LAFORTUNE_MORE]),
            Brdf::Lafortune { more, .. } => (
                [1.0, more[0].w, more[1].w, 0.0],
                more.map(|l| if l.w > 0.0 { [l.c[0], l.c[1], l.c[2], l.e] } else { [0.0; 4] }),
            ),
            _ => (fit.mu.map(|x| x as f32), [[0.0; 4]; crate::scene::LAFORTUNE_MORE]),
        };
        let t = m.tangent;
        Self {
            diffuse: m.diffuse.to_array(),
            kind,
            specular: m.specular.to_array(),
            shininess: m.shininess,
            brdf,
            lobes,
            tangent: t.to_array(),
            lobes_along_b: if fit.wide_is_b { 1.0 } else { 0.0 },
            more,
        }
    }
}

/// `struct FrameData` (scene.glsl): the camera and the frame's constants.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct FrameData {
    pub eye: [f32; 3],
    pub pad0: f32,
    /// Unit camera axes.
    pub right: [f32; 3],
    /// tan(fov_y / 2) · aspect.
    pub tan_half_fov_x: f32,
    pub up: [f32; 3],
    /// tan(fov_y / 2).
    pub tan_half_fov_y: f32,
    pub forward: [f32; 3],
    /// Near plane distance.
    pub near: f32,
    /// Far plane distance.
    pub far: f32,
    /// Tone-mapping scale of the radiance.
    pub exposure: f32,
    pub pad1: f32,
    pub pad2: f32,
    /// Width, height (pixels).
    pub size: [u32; 2],
    pub vertex_count: u32,
    /// Levels of the prefiltered environment atlas.
    pub prefiltered_levels: u32,
}
