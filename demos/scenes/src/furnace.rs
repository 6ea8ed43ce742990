//! `furnace`: a Lambertian plane of albedo ρ under a constant environment L, looked at from above; every
//! covered pixel must shade to ρL (the furnace tests, tests/tests/furnace.rs, build it with other ρ and L).

use super::{SceneEntry, SceneInputs};
use engine::math::envmap::LatLongMap;
use engine::scene::{Camera, Instance, Material, Scene};
use glam::{Mat4, Vec3};

pub const SCENE: SceneEntry = SceneEntry {
    name: "furnace",
    summary: "Lambertian plane (albedo 0.5) under a constant environment (1): every pixel shades to 0.5",
    build,
    motion: None,
};

fn build(inputs: &SceneInputs) -> anyhow::Result<Scene> {
    // A furnace is defined by its constant environment: another one would make it a different scene.
    anyhow::ensure!(inputs.env.is_none(), "scene 'furnace' has a constant environment; --env does not apply to it");
    Ok(scene(0.5, 1.0))
}

/// The furnace with albedo `albedo` under constant radiance `radiance`.
pub fn scene(albedo: f32, radiance: f32) -> Scene {
    Scene {
        meshes: vec![super::shapes::ground_plane(1.0, 4)],
        materials: vec![Material::diffuse(Vec3::splat(albedo))],
        instances: vec![Instance { mesh: 0, transform: Mat4::IDENTITY, material: 0 }],
        environment: LatLongMap::constant(64, 32, [radiance; 3]),
        environment_intensity: 1.0,
        env_lights: Default::default(),
        lights: Vec::new(),
        blockers: Default::default(),
        camera: Camera { eye: Vec3::new(0.0, 1.5, 0.01), target: Vec3::ZERO, fov_y_degrees: 40.0 },
    }
}
