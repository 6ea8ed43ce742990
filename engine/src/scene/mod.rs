//! `engine::scene`: meshes, materials, environment, camera — plain data, no Vulkan.

pub mod blockers;
mod env;
mod mesh;
pub mod triangle_bvh;

pub use blockers::{SceneBlockers, Skin};
pub use env::load_environment;
pub use mesh::{compute_normals, load_gltf, load_obj, GltfScene, Mesh};

use glam::{Mat4, Vec3};
use std::path::PathBuf;

/// Errors loading scene input: always name the file and the problem.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: file not found")]
    NotFound { path: PathBuf },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
}

impl SceneError {
    pub(crate) fn invalid(path: &std::path::Path, message: impl Into<String>) -> Self {
        Self::Invalid { path: path.to_path_buf(), message: message.into() }
    }
}

pub type Result<T> = std::result::Result<T, SceneError>;

/// Our material model: Lambertian diffuse plus a normalized Blinn-Phong specular lobe
/// f = ρ_d/π + k_s (s+8)/(8π) (n·h)^s (the ISG paper's k_d + k_s s(ω_i, ω_o) form).
/// glTF metallic-roughness maps onto it in [`Material::from_metallic_roughness`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Diffuse reflectance ρ_d (albedo), linear RGB.
    pub diffuse: Vec3,
    /// Specular scale k_s, linear RGB.
    pub specular: Vec3,
    /// Blinn-Phong exponent s (glossiness).
    pub shininess: f32,
}

impl Material {
    pub fn diffuse(albedo: Vec3) -> Self {
        Self { diffuse: albedo, specular: Vec3::ZERO, shininess: 1.0 }
    }
    pub fn glossy(albedo: Vec3, ks: f32, shininess: f32) -> Self {
        Self { diffuse: albedo, specular: Vec3::splat(ks), shininess }
    }
    /// glTF base colour / metallic / roughness: ρ_d = base (1 − metallic), k_s = mix(0.04, base,
    /// metallic), and s = 2/α² − 2 with α = roughness² (the Beckmann–Blinn correspondence), clamped
    /// to [1, 1e5].
    pub fn from_metallic_roughness(base: Vec3, metallic: f32, roughness: f32) -> Self {
        let m = metallic.clamp(0.0, 1.0);
        let alpha = (roughness.clamp(0.0, 1.0) * roughness.clamp(0.0, 1.0)).max(1e-3);
        Self {
            diffuse: base * (1.0 - m),
            specular: Vec3::splat(0.04).lerp(base, m),
            shininess: (2.0 / (alpha * alpha) - 2.0).clamp(1.0, 1e5),
        }
    }
}

/// One drawable: a mesh, its object-to-world transform and its material index.
#[derive(Clone, Debug)]
pub struct Instance {
    pub mesh: usize,
    pub transform: Mat4,
    pub material: usize,
}

/// A pinhole camera (Y up).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    pub fov_y_degrees: f32,
}

impl Camera {
    /// Orthonormal basis (right, up, forward) of the view.
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let f = (self.target - self.eye).normalize_or(Vec3::NEG_Z);
        let r = f.cross(Vec3::Y).normalize_or(Vec3::X);
        let u = r.cross(f);
        (r, u, f)
    }
}

/// A spherical area light of uniform radiance (world space). Techniques and the reference treat
/// its radiance as added to the environment's along the directions it subtends (it does not hide
/// the environment behind it); it casts no shadow itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereLight {
    pub center: Vec3,
    pub radius: f32,
    /// Emitted radiance, linear RGB.
    pub radiance: Vec3,
}

/// Everything a frame renders.
#[derive(Clone, Debug)]
pub struct Scene {
    pub meshes: Vec<Mesh>,
    pub materials: Vec<Material>,
    pub instances: Vec<Instance>,
    pub environment: engine_math::envmap::LatLongMap,
    /// Radiance scale applied to the environment.
    pub environment_intensity: f32,
    /// Spherical lights (may be empty).
    pub lights: Vec<SphereLight>,
    /// Blocker sphere sets per mesh, skins and bone matrices (`Default`: none).
    pub blockers: SceneBlockers,
    pub camera: Camera,
}

impl Scene {
    /// Axis-aligned bounds of every instance in world space.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for inst in &self.instances {
            for p in &self.meshes[inst.mesh].positions {
                let w = inst.transform.transform_point3(*p);
                lo = lo.min(w);
                hi = hi.max(w);
            }
        }
        (lo, hi)
    }
}
