//! `blocker_spheres` pass (shaders-glsl/blocker_spheres): every frame, the world-space blocker spheres
//! `BlockerResources::spheres` (`vec4(center, radius)`) from the rest spheres of every instance whose mesh has a
//! sphere set, moved by the same instance transforms and bone matrices as the skin pass:
//!
//! - rigid: centre transformed by the instance's model matrix, radius scaled by its largest axis scale;
//! - skinned: centre = model · (Σ w_j B_j) · rest centre with the sphere's bone binding
//!   ([`crate::scene::blockers::bind_sphere_to_bones`]), radius kept (times the model's largest axis
//!   scale), as SHEXP §6.2 does for articulated motion.
//!
//! The records it reads are in [`crate::resources::blockers`].

use crate::gpu::{Binding, ComputePipeline, Gpu, Recorder, Result};
use crate::resources::GpuScene;
use bytemuck::{Pod, Zeroable};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct AnimatePush {
    pub sphere_count: u32,
    pub bone_count: u32,
}

pub struct BlockerSpheresPass {
    pipeline: ComputePipeline,
}

impl BlockerSpheresPass {
    pub fn new(gpu: &Gpu) -> Result<Self> {
        Ok(Self { pipeline: gpu.create_compute_pipeline("blocker_spheres/animate.comp", &[])? })
    }

    /// Writes `scene.spheres`; nothing is dispatched when the scene has no spheres.
    pub fn record(&self, rec: &mut Recorder, scene: &GpuScene) -> Result<()> {
        if scene.blockers.sphere_count == 0 {
            return Ok(());
        }
        rec.begin_pass("blocker_spheres");
        let push = AnimatePush { sphere_count: scene.blockers.sphere_count, bone_count: scene.geometry.bone_count };
        rec.dispatch(
            &self.pipeline,
            &[
                Binding::buffer("BlockerSpheres", &scene.blockers.rest),
                Binding::buffer("Objects", &scene.geometry.objects),
                Binding::buffer("Bones", &scene.geometry.bones),
                Binding::buffer("Spheres", &scene.blockers.spheres),
            ],
            bytemuck::bytes_of(&push),
            [scene.blockers.sphere_count, 1, 1],
        )
    }

    pub fn destroy(self, gpu: &Gpu) {
        gpu.destroy_compute_pipeline(self.pipeline);
    }
}
