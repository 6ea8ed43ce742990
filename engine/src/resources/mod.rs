//! `engine::resources`: the scene in device memory, prepared once per scene and shared by every pass
//! and technique (below `passes`, above `scene`, `blockers` and `gpu`).
//!
//! [`GpuScene`] is a named set: [`Geometry`] (vertices, indices, instance transforms, skinning),
//! the per-frame constants, the materials, [`EnvironmentResources`] (the environment texture, its
//! prefiltered maps and irradiance grid, the SH projection slot), [`LightResources`] (the spherical
//! lights), [`BlockerResources`] (sphere records, world spheres and their BVH) and [`ThinResources`]
//! (thin-shell triangles and clusters). A technique names the parts it reads
//! ([`crate::passes::shade::Reads`]) and receives only those.

pub mod blockers;
pub mod environment;
pub mod layout;
pub mod lights;
pub mod thin;

use crate::gpu::{Buffer, BufferDesc, Gpu, GpuError, Result};
use crate::scene::Scene;
pub use environment::{EnvSplit, EnvironmentResources};
use layout::{FrameData, GpuMaterial, GpuObject, GpuVertex};
pub use lights::LightResources;
use thin::{GpuThinCluster, GpuThinTriangle};

/// A scene refused at upload (an input error, not a GPU failure): [`crate::input::SceneInputError`].
pub(crate) fn invalid_scene(message: impl Into<String>) -> GpuError {
    crate::input::SceneInputError(message.into()).into()
}

/// Make `N` buffers in order; if one fails, the ones made before it are destroyed again.
pub(crate) fn make_buffers<const N: usize>(gpu: &Gpu, steps: [&dyn Fn() -> Result<Buffer>; N]) -> Result<[Buffer; N]> {
    let mut made = Vec::with_capacity(N);
    for step in steps {
        match step() {
            Ok(b) => made.push(b),
            Err(e) => {
                for b in made {
                    gpu.destroy_buffer(b);
                }
                return Err(e);
            }
        }
    }
    made.try_into().map_err(|_| GpuError::Other("internal: buffer count".into()))
}

/// Vertices, indices, instance transforms and skinning: what the `skin` and `gbuffer` passes read.
pub struct Geometry {
    /// Object-space vertices ([`GpuVertex`]), all instances concatenated.
    pub vertices: Buffer,
    pub indices: Buffer,
    /// Per-instance transforms ([`GpuObject`]), host-visible: rewritten by
    /// `Renderer::set_instance_transform`.
    pub objects: Buffer,
    /// World-space vertices, written every frame by the `skin` pass.
    pub world_vertices: Buffer,
    /// Per-vertex radiance (per-vertex shading target, interpolated by the raster pass).
    pub vertex_radiance: Buffer,
    /// Per-vertex bone influences ([`blockers::GpuVertexSkin`]).
    pub vertex_skins: Buffer,
    /// Bone matrices (mat4, host-visible, rewritten by `Renderer::set_bones`).
    pub bones: Buffer,
    pub vertex_count: u32,
    pub index_count: u32,
    pub bone_count: u32,
}

/// The blocker spheres and planes: rest records with their instance and bone binding
/// ([`blockers::GpuBlockerSphere`]), the world-space spheres `vec4(center, radius)` rewritten every
/// frame by the `blocker_spheres` pass, and their BVH ([`blockers::GpuBvhNode`], root at 0) rebuilt
/// every frame by the `blocker_bvh` pass. At least one element each, so the bindings are valid
/// with no spheres.
pub struct BlockerResources {
    pub rest: Buffer,
    pub spheres: Buffer,
    pub bvh_nodes: Buffer,
    /// Number of blocker spheres (0: no blocker pass runs).
    pub sphere_count: u32,
    /// Plane blockers: `BlockerPlanes { uint count; BlockerPlane planes[]; }`
    /// ([`blockers::GpuBlockerPlane`], world space, static; at least one record).
    pub planes: Buffer,
}

/// Thin shells (`passes::thin_shells`): per thin triangle its scene vertex indices (`uvec4`, built
/// once), its world-space vertices (rewritten every frame), and the clusters (triangle ranges built
/// once, bounding spheres rewritten every frame). At least one element each: with no thin mesh,
/// cluster 0 holds no triangles.
pub struct ThinResources {
    pub indices: Buffer,
    pub triangles: Buffer,
    pub clusters: Buffer,
    /// Number of thin triangles and clusters (0: the thin_shells pass does not run).
    pub triangle_count: u32,
    pub cluster_count: u32,
}

/// The scene in device memory (see the module docs).
pub struct GpuScene {
    pub geometry: Geometry,
    /// Per-frame constants ([`FrameData`]), host-visible, rewritten each frame (no allocation).
    pub frame: Buffer,
    pub materials: Buffer,
    pub environment: EnvironmentResources,
    pub lights: LightResources,
    pub blockers: BlockerResources,
    pub thin: ThinResources,
    /// How the environment splits into lights and a residual ([`Scene::env_lights`]).
    pub env_params: engine_math::env_lights::EnvLightParams,
    /// The scene's bounding sphere (centre, radius) at upload: where the environment's lights are placed.
    pub bounds: (glam::Vec3, f32),
    /// The split environment, made by [`GpuScene::env_split`] on first request (a technique with
    /// `env_lights=on`) and dropped when the environment changes.
    env_split: Option<EnvSplit>,
}

impl GpuScene {
    /// The environment split into lights and a residual, made on the first call and kept.
    pub fn env_split(&mut self, gpu: &Gpu) -> Result<&EnvSplit> {
        if self.env_split.is_none() {
            let (center, radius) = self.bounds;
            let split = EnvSplit::new(gpu, &self.environment, &self.env_params, &self.lights.cpu, center, radius)?;
            if let Some(note) = &split.decomposition.note {
                log::warn!("{note}");
            }
            self.env_split = Some(split);
        }
        self.env_split.as_ref().ok_or_else(|| GpuError::Other("internal: environment split missing".into()))
    }

    /// The split environment if it has been made.
    pub fn env_split_if_made(&self) -> Option<&EnvSplit> {
        self.env_split.as_ref()
    }

    /// Take the split out (the environment is changing); the caller destroys or restores it.
    pub fn take_env_split(&mut self) -> Option<EnvSplit> {
        self.env_split.take()
    }

    /// Put back a split taken out by [`Self::take_env_split`], destroying any made since.
    pub fn restore_env_split(&mut self, gpu: &Gpu, split: Option<EnvSplit>) {
        if let Some(old) = std::mem::replace(&mut self.env_split, split) {
            old.destroy(gpu);
        }
    }

    pub fn upload(gpu: &Gpu, scene: &Scene) -> Result<Self> {
        crate::scene::check_radiance(scene).map_err(invalid_scene)?;
        let mut vertices = Vec::new();
        let mut indices = Vec::new();
        let mut objects = Vec::new();
        for (i, inst) in scene.instances.iter().enumerate() {
            let mesh = scene
                .meshes
                .get(inst.mesh)
                .ok_or_else(|| invalid_scene(format!("instance {i}: no mesh {}", inst.mesh)))?;
            if inst.material >= scene.materials.len() {
                return Err(invalid_scene(format!("instance {i}: no material {}", inst.material)));
            }
            let offsets = &mesh.material_offsets;
            if !offsets.is_empty() && offsets.len() != mesh.positions.len() {
                return Err(invalid_scene(format!(
                    "mesh '{}': {} material offsets for {} vertices",
                    mesh.name,
                    offsets.len(),
                    mesh.positions.len()
                )));
            }
            let top = inst.material as u64 + offsets.iter().copied().max().unwrap_or(0) as u64;
            if top >= scene.materials.len() as u64 {
                return Err(invalid_scene(format!(
                    "instance {i}: its mesh's material offsets reach material {top} of {}",
                    scene.materials.len()
                )));
            }
            let base = vertices.len() as u32;
            for (v, (p, n)) in mesh.positions.iter().zip(&mesh.normals).enumerate() {
                vertices.push(GpuVertex {
                    position: p.to_array(),
                    instance: i as f32,
                    normal: n.to_array(),
                    material: (inst.material as u32 + mesh.material_offset(v)) as f32,
                });
            }
            indices.extend(mesh.indices.iter().map(|&k| base + k));
            objects.push(GpuObject {
                model: inst.transform.to_cols_array(),
                normal_matrix: inst.transform.inverse().transpose().to_cols_array(),
            });
        }
        if vertices.is_empty() || indices.is_empty() {
            return Err(invalid_scene("the scene has no geometry"));
        }
        let materials: Vec<GpuMaterial> = scene.materials.iter().map(GpuMaterial::from_material).collect();
        let blocker_data = blockers::gather(scene)?;
        let sphere_count = blocker_data.rest.len() as u32;
        let thin_data = thin::gather(scene)?;
        let thin_triangle_count = thin_data.indices.len() as u32;
        let thin_cluster_count = thin_data.clusters.len() as u32;
        let thin_indices = if thin_data.indices.is_empty() { vec![[0u32; 4]] } else { thin_data.indices };
        let thin_clusters =
            if thin_data.clusters.is_empty() { vec![GpuThinCluster::default()] } else { thin_data.clusters };
        let bone_count = blocker_data.bones.len() as u32;
        let n = vertices.len() as u64;
        let tri_bytes = std::mem::size_of::<GpuThinTriangle>() as u64 * thin_triangle_count.max(1) as u64;
        let objects_bytes = std::mem::size_of_val(&objects[..]) as u64;
        let plane_words = blockers::planes_buffer_words(&blocker_data.planes);
        let [v, ix, obj, world, radiance, skins, bones, frame, mats, rest, spheres, nodes, planes, ti, tt, tc] =
            make_buffers(
                gpu,
                [
                    &|| gpu.upload_buffer("scene-vertices", BufferDesc::gpu_only(0), &vertices),
                    &|| gpu.upload_buffer("scene-indices", BufferDesc::index(0), &indices),
                    // Host-visible: instance transforms are rewritten by Renderer::set_instance_transform.
                    &|| gpu.create_buffer("scene-objects", BufferDesc::upload(objects_bytes)),
                    &|| gpu.create_buffer("scene-world-vertices", BufferDesc::gpu_only(n * 32)),
                    &|| {
                        gpu.upload_buffer(
                            "scene-vertex-radiance",
                            BufferDesc::gpu_only(0),
                            &vec![[0f32; 4]; n as usize],
                        )
                    },
                    &|| gpu.upload_buffer("scene-vertex-skins", BufferDesc::gpu_only(0), &blocker_data.vertex_skins),
                    &|| gpu.create_buffer("scene-bones", BufferDesc::upload(64 * bone_count.max(1) as u64)),
                    &|| {
                        gpu.create_buffer(
                            "frame-constants",
                            BufferDesc::upload(std::mem::size_of::<FrameData>() as u64),
                        )
                    },
                    &|| gpu.upload_buffer("scene-materials", BufferDesc::gpu_only(0), &materials),
                    &|| gpu.upload_buffer("blocker-rest", BufferDesc::gpu_only(64), &blocker_data.rest),
                    &|| gpu.create_buffer("blocker-spheres", BufferDesc::gpu_only(16 * sphere_count.max(1) as u64)),
                    &|| {
                        gpu.create_buffer(
                            "blocker-bvh-nodes",
                            BufferDesc::gpu_only(blockers::node_buffer_size(sphere_count)),
                        )
                    },
                    &|| gpu.upload_buffer("blocker-planes", BufferDesc::gpu_only(0), &plane_words),
                    &|| gpu.upload_buffer("thin-indices", BufferDesc::gpu_only(0), &thin_indices),
                    &|| gpu.create_buffer("thin-triangles", BufferDesc::gpu_only(tri_bytes)),
                    &|| gpu.upload_buffer("thin-clusters", BufferDesc::gpu_only(0), &thin_clusters),
                ],
            )?;
        let geometry = Geometry {
            vertices: v,
            indices: ix,
            objects: obj,
            world_vertices: world,
            vertex_radiance: radiance,
            vertex_skins: skins,
            bones,
            vertex_count: n as u32,
            index_count: indices.len() as u32,
            bone_count,
        };
        let blockers = BlockerResources { rest, spheres, bvh_nodes: nodes, sphere_count, planes };
        let thin = ThinResources {
            indices: ti,
            triangles: tt,
            clusters: tc,
            triangle_count: thin_triangle_count,
            cluster_count: thin_cluster_count,
        };
        let partial = |geometry: Geometry, frame: Buffer, mats: Buffer, blockers: BlockerResources, thin| {
            geometry.destroy(gpu);
            gpu.destroy_buffer(frame);
            gpu.destroy_buffer(mats);
            blockers.destroy(gpu);
            ThinResources::destroy(thin, gpu);
        };
        let environment = match EnvironmentResources::new(gpu, &scene.environment, scene.environment_intensity) {
            Ok(e) => e,
            Err(e) => {
                partial(geometry, frame, mats, blockers, thin);
                return Err(e);
            }
        };
        let lights = match LightResources::new(gpu, &scene.lights) {
            Ok(l) => l,
            Err(e) => {
                environment.destroy(gpu);
                partial(geometry, frame, mats, blockers, thin);
                return Err(e);
            }
        };
        let (lo, hi) = scene.bounds();
        let bounds = if lo.is_finite() && hi.is_finite() {
            (0.5 * (lo + hi), (0.5 * (hi - lo).length()).max(1e-3))
        } else {
            (glam::Vec3::ZERO, 1.0)
        };
        let mut out = Self {
            geometry,
            frame,
            materials: mats,
            environment,
            lights,
            blockers,
            thin,
            env_params: scene.env_lights,
            bounds,
            env_split: None,
        };
        let written = out.geometry.objects.write(&objects).and_then(|_| out.geometry.bones.write(&blocker_data.bones));
        if let Err(e) = written {
            out.destroy(gpu);
            return Err(e);
        }
        Ok(out)
    }

    pub fn destroy(self, gpu: &Gpu) {
        self.geometry.destroy(gpu);
        gpu.destroy_buffer(self.frame);
        gpu.destroy_buffer(self.materials);
        self.environment.destroy(gpu);
        self.lights.destroy(gpu);
        self.blockers.destroy(gpu);
        self.thin.destroy(gpu);
        if let Some(s) = self.env_split {
            s.destroy(gpu);
        }
    }
}

impl Geometry {
    fn destroy(self, gpu: &Gpu) {
        for b in [
            self.vertices,
            self.indices,
            self.objects,
            self.world_vertices,
            self.vertex_radiance,
            self.vertex_skins,
            self.bones,
        ] {
            gpu.destroy_buffer(b);
        }
    }
}

impl BlockerResources {
    fn destroy(self, gpu: &Gpu) {
        for b in [self.rest, self.spheres, self.bvh_nodes, self.planes] {
            gpu.destroy_buffer(b);
        }
    }
}

impl ThinResources {
    fn destroy(self, gpu: &Gpu) {
        for b in [self.indices, self.triangles, self.clusters] {
            gpu.destroy_buffer(b);
        }
    }
}
