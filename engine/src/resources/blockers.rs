//! Blocker and skinning records in device memory (std430 twins of shaders-glsl/common/skinning.glsl and
//! blocker_spheres/animate.comp), gathered once per scene by [`gather`], and the blocker BVH's size
//! limits. Written by the `blocker_spheres` and `blocker_bvh` passes every frame. Plane blockers
//! ([`GpuBlockerPlane`], world space, static) are gathered here too.

use super::invalid_scene;
use crate::gpu::Result;
use crate::scene::blockers::{bind_sphere_to_bones, BlockerPlane};
use crate::scene::Scene;
use bytemuck::{Pod, Zeroable};
pub use engine_blockers::bvh::GpuBvhNode;

/// Largest sphere count the `blocker_bvh` pass accepts: its refit step runs one invocation per
/// workgroup (see refit.comp) and 65535 workgroups is the smallest `maxComputeWorkGroupCount[0]`
/// Vulkan allows.
pub const MAX_SPHERES: u32 = 65535;

/// Bytes of a node array for `sphere_count` spheres (2n − 1 nodes; at least one node so that an empty
/// scene still has a valid binding).
pub fn node_buffer_size(sphere_count: u32) -> u64 {
    (2 * sphere_count as u64).saturating_sub(1).max(1) * std::mem::size_of::<GpuBvhNode>() as u64
}

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

/// `struct BlockerPlane` of shaders-glsl/common/planes.glsl (twin of engine_blockers::plane):
/// `plane` = (unit normal m, offset d) of m·x = d; `center.w` = 1 for a rectangle (a two-sided plate
/// `center + s·half_u + t·half_v`, |s|, |t| ≤ 1), 0 for the half-space m·x < d; `half_u.w` = the
/// self-shadowing tolerance ε.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuBlockerPlane {
    pub plane: [f32; 4],
    pub center: [f32; 4],
    pub half_u: [f32; 4],
    pub half_v: [f32; 4],
}

impl GpuBlockerPlane {
    pub fn from_plane(p: &BlockerPlane) -> Self {
        let m = p.normal.as_vec3();
        let (c, u, v, bounded) = match p.rect {
            Some((c, u, v)) => (c.as_vec3(), u.as_vec3(), v.as_vec3(), 1.0),
            None => (p.normal.as_vec3() * p.offset as f32, glam::Vec3::ZERO, glam::Vec3::ZERO, 0.0),
        };
        Self {
            plane: [m.x, m.y, m.z, p.offset as f32],
            center: [c.x, c.y, c.z, bounded],
            half_u: [u.x, u.y, u.z, p.epsilon as f32],
            half_v: [v.x, v.y, v.z, 0.0],
        }
    }
}

/// The header of the `BlockerPlanes` buffer (std430: the array starts at byte 16).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuPlanesHeader {
    pub count: u32,
    pub pad: [u32; 3],
}

/// Most plane blockers a scene may have: every shading point tests each one (they are the few large
/// flat receivers of a scene, not a general primitive).
pub const MAX_PLANES: usize = 16;

/// The plane blockers of `scene` in world space: its explicit planes, then one rectangle per instance
/// of a mesh marked as a plane (its world-space vertices; it must be a flat rectangle). Validated.
pub fn gather_planes(scene: &Scene) -> Result<Vec<BlockerPlane>> {
    let b = &scene.blockers;
    let mut planes = Vec::new();
    for (k, pl) in b.planes.iter().enumerate() {
        pl.validate().map_err(|e| invalid_scene(format!("plane blocker {k}: {e}")))?;
        planes.push(*pl);
    }
    for (i, inst) in scene.instances.iter().enumerate() {
        if !b.is_plane(inst.mesh) {
            continue;
        }
        let Some(mesh) = scene.meshes.get(inst.mesh) else {
            return Err(invalid_scene(format!("instance {i}: no mesh {}", inst.mesh)));
        };
        if b.spheres_of(inst.mesh).is_some() || b.is_thin(inst.mesh) {
            return Err(invalid_scene(format!(
                "mesh '{}' is marked as a plane blocker and also has spheres or is thin: choose one",
                mesh.name
            )));
        }
        let m = inst.transform.as_dmat4();
        let world: Vec<glam::DVec3> = mesh.positions.iter().map(|p| m.transform_point3(p.as_dvec3())).collect();
        let pl = BlockerPlane::from_flat_mesh(&world, &mesh.indices)
            .map_err(|e| invalid_scene(format!("mesh '{}' (instance {i}): {e}", mesh.name)))?;
        planes.push(pl);
    }
    if planes.len() > MAX_PLANES {
        return Err(invalid_scene(format!("{} plane blockers, at most {MAX_PLANES}", planes.len())));
    }
    Ok(planes)
}

/// The bytes of the `BlockerPlanes` buffer: header, then at least one record (zero when there is
/// no plane, so the binding is valid).
pub fn planes_buffer_words(planes: &[BlockerPlane]) -> Vec<u32> {
    let header = GpuPlanesHeader { count: planes.len() as u32, pad: [0; 3] };
    let mut words: Vec<u32> = bytemuck::cast_slice(std::slice::from_ref(&header)).to_vec();
    let mut records: Vec<GpuBlockerPlane> = planes.iter().map(GpuBlockerPlane::from_plane).collect();
    if records.is_empty() {
        records.push(GpuBlockerPlane::default());
    }
    words.extend_from_slice(bytemuck::cast_slice(&records));
    words
}

/// The records of the cloth's generated blocker spheres (after every other sphere): the patch spheres of its
/// rest grid in object space, on its instance. The `cloth` pass overwrites their world spheres every frame
/// (`engine::passes::cloth`); the records only keep the `blocker_spheres` pass's writes meaningful.
fn cloth_sphere_records(scene: &Scene, cloth: &crate::scene::cloth::Cloth) -> Result<Vec<GpuBlockerSphere>> {
    let (instance, _) = crate::scene::cloth::cloth_instance(scene, cloth).map_err(invalid_scene)?;
    let mesh = &scene.meshes[cloth.mesh];
    let x: Vec<glam::DVec3> = mesh.positions.iter().map(|p| p.as_dvec3()).collect();
    let (across, down) = cloth.sphere_grid();
    let mut out = Vec::with_capacity((across * down) as usize);
    for b in 0..down {
        for a in 0..across {
            let (c, r) = crate::scene::cloth::patch_sphere(cloth, &x, a, b);
            let c = c.as_vec3();
            out.push(GpuBlockerSphere {
                sphere: [c.x, c.y, c.z, r as f32],
                object: instance as u32,
                ..GpuBlockerSphere::default()
            });
        }
    }
    Ok(out)
}

/// What [`GpuScene::upload`] puts in device memory for blockers and skinning.
pub struct BlockerData {
    /// One record per world-space sphere (instances in order, spheres of each in file order).
    pub rest: Vec<GpuBlockerSphere>,
    /// One record per scene vertex, in the vertex order of the upload (instances in order).
    pub vertex_skins: Vec<GpuVertexSkin>,
    /// Initial bone matrices (column-major).
    pub bones: Vec<[f32; 16]>,
    /// Plane blockers in world space ([`gather_planes`]).
    pub planes: Vec<BlockerPlane>,
}

/// Gathers the blocker and skin records of `scene` (validated: skin lengths, bone indices, spheres).
pub fn gather(scene: &Scene) -> Result<BlockerData> {
    let b = &scene.blockers;
    let bone_count = b.bones.len() as u32;
    let mut rest = Vec::new();
    let mut vertex_skins = Vec::new();
    for (i, inst) in scene.instances.iter().enumerate() {
        let Some(mesh) = scene.meshes.get(inst.mesh) else {
            return Err(invalid_scene(format!("instance {i}: no mesh {}", inst.mesh)));
        };
        let skin = b.skin_of(inst.mesh);
        if let Some(skin) = skin {
            if skin.joints.len() != mesh.positions.len() || skin.weights.len() != mesh.positions.len() {
                return Err(invalid_scene(format!(
                    "mesh '{}': skin has {} joints / {} weights for {} vertices",
                    mesh.name,
                    skin.joints.len(),
                    skin.weights.len(),
                    mesh.positions.len()
                )));
            }
            if let Some(j) = skin.joints.iter().flatten().find(|&&j| j >= bone_count) {
                return Err(invalid_scene(format!("mesh '{}': bone {j} of {bone_count}", mesh.name)));
            }
            if skin.weights.iter().flatten().any(|w| !w.is_finite() || *w < 0.0) {
                return Err(invalid_scene(format!("mesh '{}': negative or non-finite skin weight", mesh.name)));
            }
            vertex_skins.extend(
                skin.joints.iter().zip(&skin.weights).map(|(&joints, &weights)| GpuVertexSkin { joints, weights }),
            );
        } else {
            vertex_skins.extend(std::iter::repeat_n(GpuVertexSkin::default(), mesh.positions.len()));
        }
        for (k, s) in b.spheres_of(inst.mesh).unwrap_or(&[]).iter().enumerate() {
            s.validate(k).map_err(|e| invalid_scene(format!("mesh '{}': {e}", mesh.name)))?;
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
    if let Some(cloth) = &b.cloth {
        rest.extend(cloth_sphere_records(scene, cloth)?);
    }
    if rest.len() > MAX_SPHERES as usize {
        return Err(invalid_scene(format!("{} blocker spheres, at most {}", rest.len(), MAX_SPHERES)));
    }
    let planes = gather_planes(scene)?;
    Ok(BlockerData { rest, vertex_skins, bones: b.bones.iter().map(|m| m.to_cols_array()).collect(), planes })
}
