//! `thin_shells` pass (shaders-glsl/thin_shells): every frame, the world-space triangles of the meshes
//! marked thin ([`crate::scene::SceneBlockers::thin`], ISG §5) and the bounding sphere of each cluster
//! of them, from `Geometry::world_vertices` (written by the skin pass just before, so they follow
//! skinning and instance transforms). Nothing is read back.
//!
//! - `ThinResources::indices`: per thin triangle its three scene vertex indices (built once here);
//! - `ThinResources::triangles`: per thin triangle its three world-space vertices (`GpuThinTriangle`),
//!   rewritten every frame;
//! - `ThinResources::clusters`: clusters of at most `CLUSTER_SIZE` consecutive thin triangles
//!   (`GpuThinCluster`: the triangle range, built once; the bounding sphere, rewritten every frame).
//!
//! Clusters are built once per instance from the rest pose, spatially: the triangle centroids are split
//! recursively at the median of the longest axis until at most 32 remain ([`clusters`]), so a cluster
//! is a compact patch of the surface (a 24 × 24-quad grid gives 64 clusters of 18 triangles, about
//! 3 × 3 quads) and stays compact while the surface moves smoothly. Its sphere (centre of the triangles' bounding box, radius
//! the farthest vertex, padded by 1e-5 relative for f32 rounding) is what the shading passes cull with.

use crate::gpu::{Binding, ComputePipeline, Gpu, Recorder, Result};
use crate::resources::GpuScene;
use bytemuck::{Pod, Zeroable};

/// Push constants of shaders-glsl/thin_shells/triangles.comp.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct ThinShellsPush {
    pub cluster_count: u32,
}

pub struct ThinShellsPass {
    pipeline: ComputePipeline,
}

impl ThinShellsPass {
    pub fn new(gpu: &Gpu) -> Result<Self> {
        Ok(Self { pipeline: gpu.create_compute_pipeline("thin_shells/triangles.comp", &[])? })
    }

    /// Writes `scene.thin.triangles` and the bounds of `scene.thin.clusters`; nothing is dispatched
    /// when the scene has no thin mesh.
    pub fn record(&self, rec: &mut Recorder, scene: &GpuScene) -> Result<()> {
        if scene.thin.cluster_count == 0 {
            return Ok(());
        }
        rec.begin_pass("thin_shells");
        rec.dispatch(
            &self.pipeline,
            &[
                Binding::buffer("WorldVertices", &scene.geometry.world_vertices),
                Binding::buffer("ThinIndices", &scene.thin.indices),
                Binding::buffer("ThinTriangles", &scene.thin.triangles),
                Binding::buffer("ThinClusters", &scene.thin.clusters),
            ],
            bytemuck::bytes_of(&ThinShellsPush { cluster_count: scene.thin.cluster_count }),
            [scene.thin.cluster_count, 1, 1],
        )
    }

    pub fn destroy(self, gpu: &Gpu) {
        gpu.destroy_compute_pipeline(self.pipeline);
    }
}
