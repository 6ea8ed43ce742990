//! Thin-shell records in device memory (std430 twins of shaders-glsl/common/thin.glsl), gathered once
//! per scene by [`gather`]: per thin triangle its scene vertex indices, and clusters of at most
//! [`CLUSTER_SIZE`] triangles. The `thin_shells` pass rewrites their world-space vertices and bounds
//! every frame.

use super::invalid_scene;
use crate::gpu::Result;
use crate::scene::Scene;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Triangles per cluster at most.
pub const CLUSTER_SIZE: u32 = 32;

/// `struct ThinTriangle` of shaders-glsl/common/thin.glsl: world-space vertices (w = 1).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuThinTriangle {
    pub v0: [f32; 4],
    pub v1: [f32; 4],
    pub v2: [f32; 4],
}

/// `struct ThinCluster` of shaders-glsl/common/thin.glsl: its triangles `first .. first + count`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuThinCluster {
    /// World-space bounding sphere (centre, radius), written every frame.
    pub bound: [f32; 4],
    pub first: u32,
    pub count: u32,
    pub pad0: u32,
    pub pad1: u32,
}

/// What [`GpuScene::upload`] puts in device memory for thin shells.
pub struct ThinData {
    /// Per thin triangle, its scene vertex indices (w unused), cluster by cluster.
    pub indices: Vec<[u32; 4]>,
    /// Clusters with their triangle ranges (bounds zero until the first frame).
    pub clusters: Vec<GpuThinCluster>,
}

/// Gathers the thin triangles of `scene` (instances in order; vertex indices as in the scene upload)
/// and their clusters. A thin mesh with a sphere set is an error (its triangles are its blockers).
pub fn gather(scene: &Scene) -> Result<ThinData> {
    let mut indices = Vec::new();
    let mut out = Vec::new();
    let mut base = 0u32;
    for (i, inst) in scene.instances.iter().enumerate() {
        let mesh = scene.meshes.get(inst.mesh).ok_or_else(|| invalid_scene(format!("instance {i}: no mesh")))?;
        let vertex_base = base;
        base += mesh.positions.len() as u32;
        if !scene.blockers.is_thin(inst.mesh) {
            continue;
        }
        if scene.blockers.spheres_of(inst.mesh).is_some() {
            return Err(invalid_scene(format!(
                "mesh '{}' is marked thin and has a sphere set: a thin mesh's triangles are its blockers",
                mesh.name
            )));
        }
        let tris: Vec<[u32; 3]> = mesh.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        for chunk in clusters(&mesh.positions, &tris) {
            out.push(GpuThinCluster {
                first: indices.len() as u32,
                count: chunk.len() as u32,
                ..GpuThinCluster::default()
            });
            indices.extend(chunk.iter().map(|&t| {
                let [a, b, c] = tris[t];
                [vertex_base + a, vertex_base + b, vertex_base + c, 0]
            }));
        }
    }
    Ok(ThinData { indices, clusters: out })
}

/// The clusters (triangle numbers, at most [`CLUSTER_SIZE`] each) of a mesh's triangles, by recursive
/// median splits of the centroids along the longest axis of their bounding box.
pub fn clusters(positions: &[Vec3], tris: &[[u32; 3]]) -> Vec<Vec<usize>> {
    let centroid = |t: usize| {
        (positions[tris[t][0] as usize] + positions[tris[t][1] as usize] + positions[tris[t][2] as usize]) / 3.0
    };
    let mut out = Vec::new();
    let mut todo = vec![(0..tris.len()).collect::<Vec<usize>>()];
    while let Some(mut part) = todo.pop() {
        if part.len() <= CLUSTER_SIZE as usize {
            if !part.is_empty() {
                out.push(part);
            }
            continue;
        }
        let (lo, hi) = part
            .iter()
            .map(|&t| centroid(t))
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(l, h), c| (l.min(c), h.max(c)));
        let e = hi - lo;
        let axis = if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        };
        let mid = part.len() / 2;
        part.select_nth_unstable_by(mid, |&a, &b| centroid(a)[axis].total_cmp(&centroid(b)[axis]).then(a.cmp(&b)));
        let right = part.split_off(mid);
        // Pushed right first so the left half is split (and listed) first.
        todo.push(right);
        todo.push(part);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clusters_partition_the_triangles_into_compact_blocks() {
        // A 24 × 24 grid of quads: each cluster spans a compact block, not a row strip.
        let n = 24u32;
        let positions: Vec<Vec3> =
            (0..=n).flat_map(|j| (0..=n).map(move |i| Vec3::new(i as f32, 0.0, j as f32))).collect();
        let mut tris = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let a = j * (n + 1) + i;
                tris.push([a, a + n + 1, a + 1]);
                tris.push([a + 1, a + n + 1, a + n + 2]);
            }
        }
        let parts = clusters(&positions, &tris);
        let mut seen = parts.concat();
        seen.sort();
        assert_eq!(seen, (0..tris.len()).collect::<Vec<_>>());
        assert_eq!(parts.len(), 64);
        for chunk in &parts {
            assert!(chunk.len() <= CLUSTER_SIZE as usize);
            let (lo, hi) = chunk
                .iter()
                .flat_map(|&t| tris[t].map(|v| positions[v as usize]))
                .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(l, h), p| (l.min(p), h.max(p)));
            let e = hi - lo;
            assert!(e.x <= 4.0 && e.z <= 4.0, "cluster extent {e}");
        }
    }
}
