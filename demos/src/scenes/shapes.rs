//! Mesh primitives the scenes (and the test fixtures in tests/src/fixtures.rs) are made of.

use engine::scene::Mesh;
use glam::Vec3;

/// A square ground plane of half-size `half` at y = 0, tessellated `n` × `n` (per-vertex shading
/// needs vertices), normal +Y.
pub fn ground_plane(half: f32, n: u32) -> Mesh {
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let x = -half + 2.0 * half * i as f32 / n as f32;
            let z = -half + 2.0 * half * j as f32 / n as f32;
            positions.push(Vec3::new(x, 0.0, z));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
            indices.extend_from_slice(&[a, c, b, b, c, d]);
        }
    }
    let normals = vec![Vec3::Y; positions.len()];
    Mesh { name: "ground".into(), positions, normals, indices }
}

/// A UV sphere of radius 1 with `stacks` × `2·stacks` quads.
pub fn uv_sphere(stacks: u32) -> Mesh {
    let slices = 2 * stacks;
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for j in 0..=stacks {
        let theta = std::f32::consts::PI * j as f32 / stacks as f32;
        for i in 0..=slices {
            let phi = 2.0 * std::f32::consts::PI * i as f32 / slices as f32;
            positions.push(Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()));
        }
    }
    for j in 0..stacks {
        for i in 0..slices {
            let a = j * (slices + 1) + i;
            let (b, c, d) = (a + 1, a + slices + 1, a + slices + 2);
            if j != 0 {
                indices.extend_from_slice(&[a, b, c]);
            }
            if j != stacks - 1 {
                indices.extend_from_slice(&[b, d, c]);
            }
        }
    }
    let normals = positions.clone();
    Mesh { name: "sphere".into(), positions, normals, indices }
}
