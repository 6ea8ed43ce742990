//! `arm`: a skinned cylinder with two bones, bent 60° at the elbow, raised above a ground plane under the
//! smooth sky of `sphere`; 12 blocker spheres follow the skin. `--animate` bends it between 0° and 60°.

use super::{Motion, Pose, Rest, SceneEntry, SceneInputs};
use engine::blockers::Sphere;
use engine::scene::{load_environment, Camera, Instance, Material, Mesh, Scene, SceneBlockers, Skin};
use glam::{Mat4, Vec3};

pub const SCENE: SceneEntry = SceneEntry {
    name: "arm",
    summary: "skinned cylinder bent 60° at the elbow over a ground plane, 12 skinned blocker spheres, smooth sky",
    build,
    motion: Some(Motion { summary: "the arm bends between 0° and 60° at the elbow", pose: bend }),
};

fn build(inputs: &SceneInputs) -> anyhow::Result<Scene> {
    let mut s = scene(60f32.to_radians());
    if let Some(p) = inputs.env {
        s.environment = load_environment(p)?;
    }
    Ok(s)
}

/// The bones (skin and skinned spheres follow): 0° at t = 0, 60° at t = π/1.3 s, and back.
fn bend(_rest: &Rest, t: f32) -> Pose {
    let angle = 60f32.to_radians() * (0.5 - 0.5 * (1.3 * t).cos());
    Pose { transforms: Vec::new(), bones: Some(bones(angle)) }
}

pub const ARM_LENGTH: f32 = 2.0;
pub const ARM_RADIUS: f32 = 0.15;

/// A skinned cylinder "arm" along +x from 0 to [`ARM_LENGTH`], radius [`ARM_RADIUS`], with two bones:
/// bone 0 (upper arm) is the identity, bone 1 (forearm) rotates about the elbow at x = 1 around +z.
/// Skin weights blend linearly over x in [0.8, 1.2]. Returns the mesh and its skin.
pub fn skinned_arm(rings: u32, segments: u32) -> (Mesh, Skin) {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut indices = Vec::new();
    for i in 0..=rings {
        let x = ARM_LENGTH * i as f32 / rings as f32;
        for j in 0..segments {
            let a = std::f32::consts::TAU * j as f32 / segments as f32;
            let (s, c) = a.sin_cos();
            positions.push(Vec3::new(x, ARM_RADIUS * c, ARM_RADIUS * s));
            normals.push(Vec3::new(0.0, c, s));
        }
    }
    for i in 0..rings {
        for j in 0..segments {
            let a = i * segments + j;
            let b = i * segments + (j + 1) % segments;
            let (c, d) = (a + segments, b + segments);
            indices.extend_from_slice(&[a, c, b, b, c, d]);
        }
    }
    let skin = Skin {
        joints: vec![[0, 1, 0, 0]; positions.len()],
        weights: positions
            .iter()
            .map(|p| {
                let t = ((p.x - 0.8) / 0.4).clamp(0.0, 1.0);
                [1.0 - t, t, 0.0, 0.0]
            })
            .collect(),
    };
    (Mesh { name: "arm".into(), positions, normals, indices, material_offsets: Vec::new() }, skin)
}

/// Spheres along the arm's axis that bound the cylinder at rest: centres every `spacing`, radius
/// sqrt(r² + (spacing/2)²) so the cylinder between two centres is covered.
pub fn spheres(count: u32) -> Vec<Sphere> {
    let spacing = ARM_LENGTH / (count - 1) as f32;
    let radius = (ARM_RADIUS * ARM_RADIUS + 0.25 * spacing * spacing).sqrt();
    (0..count).map(|i| Sphere::new(glam::DVec3::new((spacing * i as f32) as f64, 0.0, 0.0), radius as f64)).collect()
}

/// Bone matrices of the arm with the forearm bent by `angle` (radians) about the elbow (x = 1, +z axis).
pub fn bones(angle: f32) -> Vec<Mat4> {
    let elbow = Vec3::new(1.0, 0.0, 0.0);
    vec![Mat4::IDENTITY, Mat4::from_translation(elbow) * Mat4::from_rotation_z(angle) * Mat4::from_translation(-elbow)]
}

/// The arm scene with the forearm bent by `angle` (radians).
pub fn scene(angle: f32) -> Scene {
    let (arm, skin) = skinned_arm(24, 16);
    Scene {
        meshes: vec![arm, super::shapes::ground_plane(2.0, 16)],
        materials: vec![Material::diffuse(Vec3::new(0.8, 0.5, 0.4)), Material::diffuse(Vec3::splat(0.6))],
        instances: vec![
            Instance { mesh: 0, transform: Mat4::from_translation(Vec3::new(-1.0, 0.5, 0.0)), material: 0 },
            Instance { mesh: 1, transform: Mat4::IDENTITY, material: 1 },
        ],
        environment: super::sphere::sky(),
        environment_intensity: 1.0,
        env_lights: Default::default(),
        lights: Vec::new(),
        blockers: SceneBlockers {
            spheres: vec![Some(spheres(12))],
            skins: vec![Some(skin)],
            bones: bones(angle),
            plane_meshes: vec![false, true],
            ..Default::default()
        },
        camera: Camera { eye: Vec3::new(0.0, 1.5, 3.5), target: Vec3::new(0.0, 0.5, 0.0), fov_y_degrees: 45.0 },
    }
}
