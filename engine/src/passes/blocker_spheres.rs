//! `blocker_spheres` pass (shaders-glsl/blocker_spheres): every frame, the world-space blocker spheres
//! `GpuScene::spheres` (`vec4(center, radius)`) from the rest spheres of every instance whose mesh has a
//! sphere set, moved by the same instance transforms and bone matrices as the skin pass:
//!
//! - rigid: centre transformed by the instance's model matrix, radius scaled by its largest axis scale;
//! - skinned: centre = model · (Σ w_j B_j) · rest centre with the sphere's bone binding
//!   ([`crate::scene::blockers::bind_sphere_to_bones`]), radius kept (times the model's largest axis
//!   scale), as SHEXP §6.2 does for articulated motion.
//!
//! Also the host twins of the per-vertex skin and per-sphere binding records (std430, checked against
//! the shaders by tests/tests/struct_layouts.rs).

use crate::gpu::{Binding, ComputePipeline, Gpu, GpuError, Recorder, Result};
use crate::renderer::GpuScene;
use crate::scene::blockers::bind_sphere_to_bones;
use crate::scene::Scene;
use bytemuck::{Pod, Zeroable};

/// `struct VertexSkin` of shaders-glsl/common/skinning.glsl: four bone indices and weights per vertex
/// (weights summing to 0: the vertex follows its instance only).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuVertexSkin {
    pub joints: [u32; 4],
    pub weights: [f32; 4],
}

/// `struct BlockerSphere` of shaders-glsl/blocker_spheres/animate.comp: rest sphere (object space;
/// centre, radius), bone binding, and the object (instance) it belongs to.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuBlockerSphere {
    pub sphere: [f32; 4],
    pub joints: [u32; 4],
    pub weights: [f32; 4],
    pub object: u32,
    pub pad0: u32,
    pub pad1: u32,
    pub pad2: u32,
}

/// What [`GpuScene::upload`] puts in device memory for blockers and skinning.
pub struct BlockerData {
    /// One record per world-space sphere (instances in order, spheres of each in file order).
    pub rest: Vec<GpuBlockerSphere>,
    /// One record per scene vertex, in the vertex order of the upload (instances in order).
    pub vertex_skins: Vec<GpuVertexSkin>,
    /// Initial bone matrices (column-major).
    pub bones: Vec<[f32; 16]>,
}

/// Gathers the blocker and skin records of `scene` (validated: skin lengths, bone indices, spheres).
pub fn gather(scene: &Scene) -> Result<BlockerData> {
    let b = &scene.blockers;
    let bone_count = b.bones.len() as u32;
    let mut rest = Vec::new();
    let mut vertex_skins = Vec::new();
    for (i, inst) in scene.instances.iter().enumerate() {
        let Some(mesh) = scene.meshes.get(inst.mesh) else {
            return Err(GpuError::Other(format!("instance {i}: no mesh {}", inst.mesh)));
        };
        let skin = b.skin_of(inst.mesh);
        if let Some(skin) = skin {
            if skin.joints.len() != mesh.positions.len() || skin.weights.len() != mesh.positions.len() {
                return Err(GpuError::Other(format!(
                    "mesh '{}': skin has {} joints / {} weights for {} vertices",
                    mesh.name,
                    skin.joints.len(),
                    skin.weights.len(),
                    mesh.positions.len()
                )));
            }
            if let Some(j) = skin.joints.iter().flatten().find(|&&j| j >= bone_count) {
                return Err(GpuError::Other(format!("mesh '{}': bone {j} of {bone_count}", mesh.name)));
            }
            if skin.weights.iter().flatten().any(|w| !w.is_finite() || *w < 0.0) {
                return Err(GpuError::Other(format!("mesh '{}': negative or non-finite skin weight", mesh.name)));
            }
            vertex_skins.extend(
                skin.joints.iter().zip(&skin.weights).map(|(&joints, &weights)| GpuVertexSkin { joints, weights }),
            );
        } else {
            vertex_skins.extend(std::iter::repeat_n(GpuVertexSkin::default(), mesh.positions.len()));
        }
        for (k, s) in b.spheres_of(inst.mesh).unwrap_or(&[]).iter().enumerate() {
            s.validate(k).map_err(|e| GpuError::Other(format!("mesh '{}': {e}", mesh.name)))?;
            let (joints, weights) = match skin {
                Some(skin) => bind_sphere_to_bones(s, &mesh.positions, skin),
                None => ([0; 4], [0.0; 4]),
            };
            let c = s.center.as_vec3();
            rest.push(GpuBlockerSphere {
                sphere: [c.x, c.y, c.z, s.radius as f32],
                joints,
                weights,
                object: i as u32,
                ..GpuBlockerSphere::default()
            });
        }
    }
    if rest.len() > crate::passes::blocker_bvh::MAX_SPHERES as usize {
        return Err(GpuError::Other(format!(
            "{} blocker spheres, at most {}",
            rest.len(),
            crate::passes::blocker_bvh::MAX_SPHERES
        )));
    }
    Ok(BlockerData { rest, vertex_skins, bones: b.bones.iter().map(|m| m.to_cols_array()).collect() })
}

/// Push constants of shaders-glsl/blocker_spheres/animate.comp.
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
        if scene.sphere_count == 0 {
            return Ok(());
        }
        rec.begin_pass("blocker_spheres");
        let push = AnimatePush { sphere_count: scene.sphere_count, bone_count: scene.bone_count };
        rec.dispatch(
            &self.pipeline,
            &[
                Binding::buffer("BlockerSpheres", &scene.blocker_rest),
                Binding::buffer("Objects", &scene.objects),
                Binding::buffer("Bones", &scene.bones),
                Binding::buffer("Spheres", &scene.spheres),
            ],
            bytemuck::bytes_of(&push),
            [scene.sphere_count, 1, 1],
        )
    }

    pub fn destroy(self, gpu: &Gpu) {
        gpu.destroy_compute_pipeline(self.pipeline);
    }
}
