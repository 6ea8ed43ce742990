//! `sheet`: the bunny scene with a cloth-like sheet (24 × 24 quads, 1.2 × 1.2, sagging 0.15 and tilted
//! towards the camera) hanging above the bunny's left half, marked thin (ISG §5: its triangles are its
//! blockers, no spheres); its soft shadow falls on the bunny and the ground. Meshes are two-sided, so the
//! sheet's underside, which the camera sees, is shaded with the flipped normal. (Not the simulated `cloth`
//! scene.)

use super::{SceneEntry, SceneInputs};
use engine::scene::{Camera, Instance, Material, Mesh, Scene};
use glam::{Mat4, Vec3};

pub const SCENE: SceneEntry = SceneEntry {
    name: "sheet",
    summary: "the bunny scene under a thin-shell sheet (its triangles are its blockers) hanging over the bunny",
    build,
    motion: Some(super::bunny::TURNTABLE),
};

fn build(inputs: &SceneInputs) -> anyhow::Result<Scene> {
    let mut scene = super::bunny::scene(inputs)?;
    scene.meshes.push(sheet_mesh(24, 0.6, 0.15, 0.1));
    scene.materials.push(Material::diffuse(Vec3::new(0.65, 0.18, 0.14)));
    scene.instances.push(Instance {
        mesh: 2,
        transform: Mat4::from_translation(Vec3::new(-0.45, 1.35, 0.1)),
        material: 2,
    });
    scene.blockers.thin = vec![false, false, true];
    // Higher and further back than the bunny scene's view: the sheet, the bunny under it and the ground around.
    scene.camera = Camera { eye: Vec3::new(0.9, 1.9, 2.6), target: Vec3::new(-0.2, 0.45, 0.0), fov_y_degrees: 45.0 };
    Ok(scene)
}

/// A cloth-like sheet: `n` × `n` quads over [−half, half]² in x and z, at height
/// `y(u, v) = −sag (1 − u²)(1 − v²) − slope v` with u, v ∈ [−1, 1] the normalized x and z (a gentle drape,
/// lowest in the middle, tilted down towards +z by `slope`); normals area-weighted from the triangles.
pub fn sheet_mesh(n: u32, half: f32, sag: f32, slope: f32) -> Mesh {
    let mut m = super::shapes::ground_plane(half, n);
    for p in &mut m.positions {
        let (u, v) = (p.x / half, p.z / half);
        p.y = -sag * (1.0 - u * u) * (1.0 - v * v) - slope * v;
    }
    m.normals = engine::scene::compute_normals(&m.positions, &m.indices);
    m.name = "sheet".into();
    m
}
