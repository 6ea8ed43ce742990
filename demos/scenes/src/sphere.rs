//! `sphere`: a finely tessellated diffuse sphere under a smooth environment (a sky gradient); per-vertex
//! and per-pixel shading must agree on it (tests/tests/per_vertex.rs).

use super::{SceneEntry, SceneInputs};
use engine::math::envmap::LatLongMap;
use engine::scene::{load_environment, Camera, Instance, Material, Scene};
use glam::{Mat4, Vec3};

pub const SCENE: SceneEntry = SceneEntry {
    name: "sphere",
    summary: "tessellated diffuse sphere under a smooth sky gradient, no blockers",
    build,
    motion: None,
};

fn build(inputs: &SceneInputs) -> anyhow::Result<Scene> {
    let mut s = scene(64);
    if let Some(p) = inputs.env {
        s.environment = load_environment(p)?;
    }
    Ok(s)
}

/// The smooth sky of `sphere` and `arm` (64 × 32): brighter and bluer towards the zenith, at least 0.05.
pub fn sky() -> LatLongMap {
    let (w, h) = (64, 32);
    let texels = (0..w * h)
        .map(|i| {
            let v = ((i / w) as f32 + 0.5) / h as f32;
            let up = (std::f32::consts::PI * v).cos();
            [0.6 + 0.5 * up, 0.7 + 0.4 * up, 1.0 + 0.2 * up].map(|c| c.max(0.05))
        })
        .collect();
    LatLongMap { width: w, height: h, texels }
}

/// The sphere scene with a sphere of `stacks` × `2·stacks` quads.
pub fn scene(stacks: u32) -> Scene {
    Scene {
        meshes: vec![super::shapes::uv_sphere(stacks)],
        materials: vec![Material::diffuse(Vec3::new(0.8, 0.6, 0.4))],
        instances: vec![Instance { mesh: 0, transform: Mat4::IDENTITY, material: 0 }],
        environment: sky(),
        environment_intensity: 1.0,
        env_lights: Default::default(),
        lights: Vec::new(),
        blockers: Default::default(),
        camera: Camera { eye: Vec3::new(0.0, 0.8, 3.0), target: Vec3::ZERO, fov_y_degrees: 45.0 },
    }
}
