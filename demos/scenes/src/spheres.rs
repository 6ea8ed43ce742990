//! `spheres`: five diffuse balls on and over a ground plane under one spherical light, the environment off:
//! the cosine-lobes paper's Fig. 13 ("a scene composed of 5 [spheres] and a plane", path tracing against the
//! technique). Each ball is a finely tessellated mesh whose blocker set is the one exact sphere, so the sphere
//! proxy is the geometry (up to tessellation) and a technique's error against either reference is its own.
//! Overlapping shadows (two balls close together), a ball resting on the ground (contact), one floating
//! (a wide penumbra) and a small near one (a sharp shadow).

use super::{SceneEntry, SceneInputs};
use engine::blockers::Sphere;
use engine::scene::{load_environment, Camera, Instance, Material, Scene, SceneBlockers, SphereLight};
use glam::{DVec3, Mat4, Vec3};

pub const SCENE: SceneEntry = SceneEntry {
    name: "spheres",
    summary: "five diffuse balls on a plane under one spherical light, no environment (lobes paper Fig. 13)",
    build,
    motion: None,
};

/// (centre, radius) of the five balls.
pub const BALLS: [([f32; 3], f32); 5] = [
    ([-0.55, 0.35, -0.2], 0.35),
    ([0.05, 0.25, -0.45], 0.25),
    ([0.5, 0.65, 0.0], 0.22),
    ([-0.1, 0.12, 0.35], 0.12),
    ([0.75, 0.2, -0.6], 0.2),
];

/// The light: up and behind the balls on the left, half-angle about 0.14 rad from the middle of the ground.
pub const LIGHT: SphereLight =
    SphereLight { center: Vec3::new(-0.8, 2.0, -1.4), radius: 0.35, radiance: Vec3::new(30.0, 28.0, 25.0) };

/// `--env` lights the scene with that map at 0.3 besides the light; without it the environment is off.
fn build(inputs: &SceneInputs) -> anyhow::Result<Scene> {
    let (environment, intensity) = match inputs.env {
        Some(p) => (load_environment(p)?, 0.3),
        None => (load_environment(&inputs.assets.join("envmaps/courtyard.exr"))?, 0.0),
    };
    let meshes = vec![super::shapes::ground_plane(2.0, 32), super::shapes::uv_sphere(32)];
    let mut instances = vec![Instance { mesh: 0, transform: Mat4::IDENTITY, material: 0 }];
    for (c, r) in BALLS {
        let transform = Mat4::from_translation(Vec3::from(c)) * Mat4::from_scale(Vec3::splat(r));
        instances.push(Instance { mesh: 1, transform, material: 1 });
    }
    Ok(Scene {
        meshes,
        materials: vec![Material::diffuse(Vec3::splat(0.6)), Material::diffuse(Vec3::new(0.75, 0.7, 0.65))],
        instances,
        environment,
        environment_intensity: intensity,
        env_lights: Default::default(),
        lights: vec![LIGHT],
        // The unit sphere in the mesh's object space: each instance's transform places it on its ball. The
        // ground is a plane blocker, as in `bunny`.
        blockers: SceneBlockers {
            spheres: vec![None, Some(vec![Sphere::new(DVec3::ZERO, 1.0)])],
            plane_meshes: vec![true, false],
            ..Default::default()
        },
        camera: Camera { eye: Vec3::new(0.0, 1.5, 2.6), target: Vec3::new(0.0, 0.2, -0.2), fov_y_degrees: 40.0 },
    })
}
