//! One frame: skin → thin shells → blocker spheres → blocker BVH → (per-vertex shade) → G-buffer →
//! shade or compose → tonemap, with per-pass
//! GPU times. Everything is allocated in [`Renderer::new`]; a steady frame allocates no device
//! memory (checked by a test through the allocator's counters).

use crate::gpu::{
    Buffer, BufferDesc, Frame, Gpu, GpuError, Image, ImageDesc, ImageFormat, PassTiming, Recorder, Result,
    SwapchainImage,
};
use crate::passes::blocker_bvh::{node_buffer_size, BlockerBvhPass};
use crate::passes::blocker_spheres::BlockerSpheresPass;
use crate::passes::gbuffer::{GBuffer, GBufferPass};
use crate::passes::layout::{FrameData, GpuMaterial, GpuObject, GpuVertex};
use crate::passes::shade::{create_technique, ComposePass, ShadeInputs, ShadeTarget, Technique};
use crate::passes::skin::SkinPass;
use crate::passes::thin_shells::{GpuThinCluster, GpuThinTriangle, ThinShellsPass};
use crate::passes::tonemap::TonemapPass;
use crate::scene::{Camera, Scene, SphereLight};
use engine_math::envmap::LatLongMap;
use engine_math::prefilter::PREFILTER_LEVELS;

/// The scene in device memory.
pub struct GpuScene {
    pub vertices: Buffer,
    pub indices: Buffer,
    pub objects: Buffer,
    pub materials: Buffer,
    pub world_vertices: Buffer,
    pub vertex_radiance: Buffer,
    /// Per-frame constants, host-visible, rewritten each frame (no allocation).
    pub frame: Buffer,
    pub environment: Image,
    /// The environment on the CPU (already scaled by the scene's intensity), for techniques'
    /// `prepare` (prefiltering, SG/SH fits).
    pub environment_cpu: LatLongMap,
    /// The scene's spherical lights (world space), for techniques' `prepare`.
    pub lights: Vec<SphereLight>,
    pub vertex_count: u32,
    pub index_count: u32,
    /// World-space blocker spheres `vec4(center, radius)`, rewritten every frame by the
    /// `blocker_spheres` pass (at least one element, so the binding is valid with no spheres).
    pub spheres: Buffer,
    /// The blocker BVH ([`crate::passes::blocker_bvh::GpuBvhNode`], root at index 0), rebuilt every
    /// frame by the `blocker_bvh` pass.
    pub bvh_nodes: Buffer,
    /// Number of blocker spheres (0: no blocker passes run; `spheres` and `bvh_nodes` stay valid).
    pub sphere_count: u32,
    /// Rest spheres with their instance and bone binding
    /// ([`crate::passes::blocker_spheres::GpuBlockerSphere`]).
    pub blocker_rest: Buffer,
    /// Per-vertex bone influences ([`crate::passes::blocker_spheres::GpuVertexSkin`]).
    pub vertex_skins: Buffer,
    /// Bone matrices (mat4, host-visible, rewritten by [`Renderer::set_bones`]).
    pub bones: Buffer,
    pub bone_count: u32,
    /// Thin shells ([`crate::passes::thin_shells`]): per thin triangle its scene vertex indices
    /// (`uvec4`, built once), its world-space vertices (rewritten every frame), and the clusters
    /// (triangle ranges built once, bounding spheres rewritten every frame). At least one element
    /// each: with no thin mesh, cluster 0 holds no triangles.
    pub thin_indices: Buffer,
    pub thin_triangles: Buffer,
    pub thin_clusters: Buffer,
    /// Number of thin triangles and clusters (0: the thin_shells pass does not run).
    pub thin_triangle_count: u32,
    pub thin_cluster_count: u32,
}

impl GpuScene {
    pub fn upload(gpu: &Gpu, scene: &Scene) -> Result<Self> {
        let mut vertices = Vec::new();
        let mut indices = Vec::new();
        let mut objects = Vec::new();
        for (i, inst) in scene.instances.iter().enumerate() {
            let mesh = scene
                .meshes
                .get(inst.mesh)
                .ok_or_else(|| GpuError::Other(format!("instance {i}: no mesh {}", inst.mesh)))?;
            if inst.material >= scene.materials.len() {
                return Err(GpuError::Other(format!("instance {i}: no material {}", inst.material)));
            }
            let base = vertices.len() as u32;
            for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
                vertices.push(GpuVertex {
                    position: [p.x, p.y, p.z],
                    instance: i as f32,
                    normal: [n.x, n.y, n.z],
                    material: inst.material as f32,
                });
            }
            indices.extend(mesh.indices.iter().map(|&k| base + k));
            objects.push(GpuObject {
                model: inst.transform.to_cols_array(),
                normal_matrix: inst.transform.inverse().transpose().to_cols_array(),
            });
        }
        if vertices.is_empty() || indices.is_empty() {
            return Err(GpuError::Other("the scene has no geometry".into()));
        }
        let materials: Vec<GpuMaterial> = scene.materials.iter().map(GpuMaterial::from_material).collect();
        let k = scene.environment_intensity;
        let env = LatLongMap {
            width: scene.environment.width,
            height: scene.environment.height,
            texels: scene.environment.texels.iter().map(|t| t.map(|c| c * k)).collect(),
        };
        let env_bytes: Vec<f32> = env.texels.iter().flat_map(|t| [t[0], t[1], t[2], 1.0]).collect();
        let blockers = crate::passes::blocker_spheres::gather(scene)?;
        let sphere_count = blockers.rest.len() as u32;
        let thin = crate::passes::thin_shells::gather(scene)?;
        let thin_triangle_count = thin.indices.len() as u32;
        let thin_cluster_count = thin.clusters.len() as u32;
        let thin_indices = if thin.indices.is_empty() { vec![[0u32; 4]] } else { thin.indices };
        let thin_clusters = if thin.clusters.is_empty() { vec![GpuThinCluster::default()] } else { thin.clusters };
        let bone_count = blockers.bones.len() as u32;
        let n = vertices.len() as u64;
        let mut made: Vec<Buffer> = Vec::new();
        let mut step = |r: Result<Buffer>| -> Result<()> {
            made.push(r?);
            Ok(())
        };
        let r = (|| {
            step(gpu.upload_buffer("scene-vertices", BufferDesc::gpu_only(0), &vertices))?;
            step(gpu.upload_buffer("scene-indices", BufferDesc::index(0), &indices))?;
            // Host-visible: instance transforms are rewritten by Renderer::set_instance_transform.
            step(gpu.create_buffer("scene-objects", BufferDesc::upload(std::mem::size_of_val(&objects[..]) as u64)))?;
            step(gpu.upload_buffer("scene-materials", BufferDesc::gpu_only(0), &materials))?;
            step(gpu.create_buffer("scene-world-vertices", BufferDesc::gpu_only(n * 32)))?;
            step(gpu.upload_buffer("scene-vertex-radiance", BufferDesc::gpu_only(0), &vec![[0f32; 4]; n as usize]))?;
            step(gpu.create_buffer("frame-constants", BufferDesc::upload(std::mem::size_of::<FrameData>() as u64)))?;
            step(gpu.create_buffer("blocker-spheres", BufferDesc::gpu_only(16 * sphere_count.max(1) as u64)))?;
            step(gpu.create_buffer("blocker-bvh-nodes", BufferDesc::gpu_only(node_buffer_size(sphere_count))))?;
            step(gpu.upload_buffer("blocker-rest", BufferDesc::gpu_only(64), &blockers.rest))?;
            step(gpu.upload_buffer("scene-vertex-skins", BufferDesc::gpu_only(0), &blockers.vertex_skins))?;
            step(gpu.create_buffer("scene-bones", BufferDesc::upload(64 * bone_count.max(1) as u64)))?;
            step(gpu.upload_buffer("thin-indices", BufferDesc::gpu_only(0), &thin_indices))?;
            let tri_bytes = std::mem::size_of::<GpuThinTriangle>() as u64 * thin_triangle_count.max(1) as u64;
            step(gpu.create_buffer("thin-triangles", BufferDesc::gpu_only(tri_bytes)))?;
            step(gpu.upload_buffer("thin-clusters", BufferDesc::gpu_only(0), &thin_clusters))?;
            Ok(())
        })();
        let environment = r.and_then(|_| {
            gpu.upload_image(
                "environment",
                ImageDesc::texture(env.width as u32, env.height as u32, ImageFormat::Rgba32f),
                bytemuck::cast_slice(&env_bytes),
            )
        });
        let environment = match environment {
            Ok(e) => e,
            Err(e) => {
                for b in made {
                    gpu.destroy_buffer(b);
                }
                return Err(e);
            }
        };
        let mut it = made.into_iter();
        let mut next = || it.next().ok_or_else(|| GpuError::Other("internal: buffer list".into()));
        let mut out = Self {
            vertices: next()?,
            indices: next()?,
            objects: next()?,
            materials: next()?,
            world_vertices: next()?,
            vertex_radiance: next()?,
            frame: next()?,
            environment,
            environment_cpu: env,
            lights: scene.lights.clone(),
            vertex_count: n as u32,
            index_count: indices.len() as u32,
            spheres: next()?,
            bvh_nodes: next()?,
            sphere_count,
            blocker_rest: next()?,
            vertex_skins: next()?,
            bones: next()?,
            bone_count,
            thin_indices: next()?,
            thin_triangles: next()?,
            thin_clusters: next()?,
            thin_triangle_count,
            thin_cluster_count,
        };
        let written = out.objects.write(&objects).and_then(|_| out.bones.write(&blockers.bones));
        if let Err(e) = written {
            out.destroy(gpu);
            return Err(e);
        }
        Ok(out)
    }

    pub fn destroy(self, gpu: &Gpu) {
        for b in [
            self.vertices,
            self.indices,
            self.objects,
            self.materials,
            self.world_vertices,
            self.vertex_radiance,
            self.frame,
            self.spheres,
            self.bvh_nodes,
            self.blocker_rest,
            self.vertex_skins,
            self.bones,
            self.thin_indices,
            self.thin_triangles,
            self.thin_clusters,
        ] {
            gpu.destroy_buffer(b);
        }
        gpu.destroy_image(self.environment);
    }
}

/// What a renderer draws and how.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub technique: String,
    /// Shade per vertex (interpolated by the raster pass) instead of per pixel.
    pub per_vertex: bool,
    /// Multiplier before tone mapping.
    pub exposure: f32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self { width: 640, height: 480, technique: "none".into(), per_vertex: false, exposure: 1.0 }
    }
}

/// A renderer under construction (each part destroyed if a later one fails).
#[derive(Default)]
struct Parts {
    scene: Option<GpuScene>,
    gbuffer: Option<GBuffer>,
    radiance: Option<Image>,
    ldr: Option<Image>,
    skin: Option<SkinPass>,
    blocker_spheres: Option<BlockerSpheresPass>,
    blocker_bvh: Option<BlockerBvhPass>,
    thin_shells: Option<ThinShellsPass>,
    gbuffer_pass: Option<GBufferPass>,
    compose: Option<ComposePass>,
    tonemap: Option<TonemapPass>,
    frame: Option<Frame>,
    technique: Option<Box<dyn Technique>>,
}

impl Parts {
    fn destroy(self, gpu: &Gpu) {
        if let Some(t) = self.technique {
            t.destroy(gpu);
        }
        if let Some(f) = self.frame {
            gpu.destroy_frame(f);
        }
        if let Some(x) = self.tonemap {
            x.destroy(gpu);
        }
        if let Some(x) = self.compose {
            x.destroy(gpu);
        }
        if let Some(x) = self.gbuffer_pass {
            x.destroy(gpu);
        }
        if let Some(x) = self.skin {
            x.destroy(gpu);
        }
        if let Some(x) = self.blocker_spheres {
            x.destroy(gpu);
        }
        if let Some(x) = self.blocker_bvh {
            x.destroy(gpu);
        }
        if let Some(x) = self.thin_shells {
            x.destroy(gpu);
        }
        for i in [self.radiance, self.ldr].into_iter().flatten() {
            gpu.destroy_image(i);
        }
        if let Some(g) = self.gbuffer {
            g.destroy(gpu);
        }
        if let Some(s) = self.scene {
            s.destroy(gpu);
        }
    }
}

pub struct Renderer {
    pub scene: GpuScene,
    pub gbuffer: GBuffer,
    /// Linear radiance (RGBA32F).
    pub radiance: Image,
    /// Tone-mapped sRGB (RGBA8).
    pub ldr: Image,
    skin: SkinPass,
    blocker_spheres: BlockerSpheresPass,
    blocker_bvh: BlockerBvhPass,
    thin_shells: ThinShellsPass,
    gbuffer_pass: GBufferPass,
    compose: ComposePass,
    tonemap: TonemapPass,
    technique: Box<dyn Technique>,
    frame: Frame,
    pub settings: RenderSettings,
    camera: Camera,
    near_far: (f32, f32),
}

impl Renderer {
    pub fn new(gpu: &Gpu, scene: &Scene, settings: RenderSettings) -> Result<Self> {
        if settings.width == 0 || settings.height == 0 || settings.width > 16384 || settings.height > 16384 {
            return Err(GpuError::Other(format!("bad resolution {}x{}", settings.width, settings.height)));
        }
        let (w, h) = (settings.width, settings.height);
        let mut p = Parts::default();
        // Every piece built so far is destroyed again if a later one fails: no leaks on error paths.
        let built = (|| -> Result<()> {
            p.scene = Some(GpuScene::upload(gpu, scene)?);
            p.gbuffer = Some(GBuffer::new(gpu, w, h)?);
            p.radiance = Some(gpu.create_image("radiance", ImageDesc::target(w, h, ImageFormat::Rgba32f))?);
            p.ldr = Some(gpu.create_image("ldr", ImageDesc::target(w, h, ImageFormat::Rgba8Unorm))?);
            p.skin = Some(SkinPass::new(gpu)?);
            p.blocker_spheres = Some(BlockerSpheresPass::new(gpu)?);
            let spheres = p.scene.as_ref().map_or(0, |s| s.sphere_count);
            p.blocker_bvh = Some(BlockerBvhPass::new(gpu, spheres)?);
            p.thin_shells = Some(ThinShellsPass::new(gpu)?);
            p.gbuffer_pass = Some(GBufferPass::new(gpu)?);
            p.compose = Some(ComposePass::new(gpu)?);
            p.tonemap = Some(TonemapPass::new(gpu)?);
            p.frame = Some(gpu.create_frame()?);
            let mut t = create_technique(gpu, &settings.technique)?;
            let prepared = match &p.scene {
                Some(s) => t.prepare(gpu, s),
                None => Ok(()),
            };
            p.technique = Some(t);
            prepared
        })();
        if let Err(e) = built {
            p.destroy(gpu);
            return Err(e);
        }
        let (lo, hi) = scene.bounds();
        let extent = (hi - lo).length().max(1e-3);
        let dist = (scene.camera.eye - 0.5 * (lo + hi)).length();
        let far = dist + extent * 2.0;
        let near = (far * 1e-4).max(1e-4);
        let missing = || GpuError::Other("internal: renderer part missing".into());
        Ok(Self {
            scene: p.scene.ok_or_else(missing)?,
            gbuffer: p.gbuffer.ok_or_else(missing)?,
            radiance: p.radiance.ok_or_else(missing)?,
            ldr: p.ldr.ok_or_else(missing)?,
            skin: p.skin.ok_or_else(missing)?,
            blocker_spheres: p.blocker_spheres.ok_or_else(missing)?,
            blocker_bvh: p.blocker_bvh.ok_or_else(missing)?,
            thin_shells: p.thin_shells.ok_or_else(missing)?,
            gbuffer_pass: p.gbuffer_pass.ok_or_else(missing)?,
            compose: p.compose.ok_or_else(missing)?,
            tonemap: p.tonemap.ok_or_else(missing)?,
            technique: p.technique.ok_or_else(missing)?,
            frame: p.frame.ok_or_else(missing)?,
            camera: scene.camera,
            near_far: (near, far),
            settings,
        })
    }

    /// Switch the shading technique (compiles and prepares it; the old one is destroyed).
    pub fn set_technique(&mut self, gpu: &Gpu, name: &str) -> Result<()> {
        if name == self.settings.technique {
            return Ok(());
        }
        let mut t = create_technique(gpu, name)?;
        if let Err(e) = t.prepare(gpu, &self.scene) {
            t.destroy(gpu);
            return Err(e);
        }
        let old = std::mem::replace(&mut self.technique, t);
        old.destroy(gpu);
        self.settings.technique = name.to_string();
        Ok(())
    }

    pub fn technique_name(&self) -> &'static str {
        self.technique.name()
    }

    /// The current technique, for technique-specific controls (see `Technique::as_any_mut`).
    pub fn technique_mut(&mut self) -> &mut dyn Technique {
        self.technique.as_mut()
    }

    pub fn set_camera(&mut self, camera: Camera) {
        self.camera = camera;
    }

    pub fn camera(&self) -> Camera {
        self.camera
    }

    fn frame_data(&self) -> FrameData {
        let (r, u, f) = self.camera.basis();
        let t = (self.camera.fov_y_degrees.to_radians() * 0.5).tan();
        let aspect = self.settings.width as f32 / self.settings.height as f32;
        FrameData {
            eye: self.camera.eye.to_array(),
            right: r.to_array(),
            tan_half_fov_x: t * aspect,
            up: u.to_array(),
            tan_half_fov_y: t,
            forward: f.to_array(),
            near: self.near_far.0,
            far: self.near_far.1,
            exposure: self.settings.exposure,
            size: [self.settings.width, self.settings.height],
            vertex_count: self.scene.vertex_count,
            prefiltered_levels: PREFILTER_LEVELS as u32,
            ..FrameData::default()
        }
    }

    /// Animate: the object-to-world transform of instance `i` from the next frame on (moves its vertices
    /// and blocker spheres; rewrites a host-visible buffer, allocates nothing).
    pub fn set_instance_transform(&mut self, i: usize, transform: glam::Mat4) -> Result<()> {
        let count = self.scene.objects.desc.size as usize / std::mem::size_of::<GpuObject>();
        if i >= count || !transform.is_finite() {
            return Err(GpuError::Other(format!("instance {i} of {count}, or a non-finite transform")));
        }
        let object = GpuObject {
            model: transform.to_cols_array(),
            normal_matrix: transform.inverse().transpose().to_cols_array(),
        };
        let mut all: Vec<GpuObject> = self.scene.objects.read()?;
        all[i] = object;
        self.scene.objects.write(&all[..count])
    }

    /// Animate: the bone matrices (rest → posed object space) from the next frame on, for the skin
    /// pass and the blocker spheres alike. `bones.len()` must equal the scene's bone count.
    pub fn set_bones(&mut self, bones: &[glam::Mat4]) -> Result<()> {
        if bones.len() != self.scene.bone_count as usize || bones.iter().any(|m| !m.is_finite()) {
            return Err(GpuError::Other(format!(
                "{} bone matrices (the scene has {}), or a non-finite one",
                bones.len(),
                self.scene.bone_count
            )));
        }
        let cols: Vec<[f32; 16]> = bones.iter().map(|m| m.to_cols_array()).collect();
        self.scene.bones.write(&cols)
    }

    /// Render one frame and wait for it; returns per-pass GPU times.
    pub fn render(&mut self, gpu: &Gpu) -> Result<Vec<PassTiming>> {
        self.render_to(gpu, None)
    }

    /// Render one frame into an acquired swapchain image (blitting the tone-mapped image, scaled
    /// if the sizes differ) and wait for it; present it with [`crate::gpu::Swapchain::present`].
    pub fn render_presenting(&mut self, gpu: &Gpu, target: &SwapchainImage) -> Result<Vec<PassTiming>> {
        self.render_to(gpu, Some(target))
    }

    fn render_to(&mut self, gpu: &Gpu, present: Option<&SwapchainImage>) -> Result<Vec<PassTiming>> {
        let data = self.frame_data();
        self.scene.frame.write(std::slice::from_ref(&data))?;
        let Self {
            scene,
            gbuffer,
            radiance,
            ldr,
            skin,
            blocker_spheres,
            blocker_bvh,
            thin_shells,
            gbuffer_pass,
            compose,
            tonemap,
            technique,
            frame,
            settings,
            ..
        } = self;
        let per_vertex = settings.per_vertex;
        let record = |rec: &mut Recorder| {
            skin.record(rec, scene)?;
            thin_shells.record(rec, scene)?;
            blocker_spheres.record(rec, scene)?;
            blocker_bvh.record(rec, &scene.spheres, &scene.bvh_nodes, scene.sphere_count)?;
            let inputs = ShadeInputs { scene };
            if per_vertex {
                technique.record(rec, &inputs, ShadeTarget::Vertex)?;
            }
            gbuffer_pass.record(rec, scene, gbuffer)?;
            if per_vertex {
                compose.record(rec, scene, gbuffer, radiance)?;
            } else {
                technique.record(rec, &inputs, ShadeTarget::Pixel { gbuffer, radiance })?;
            }
            tonemap.record(rec, scene, radiance, ldr)?;
            rec.end_pass();
            Ok(())
        };
        match present {
            None => gpu.run_frame(frame, None, None, record),
            Some(target) => gpu.run_frame_presenting(frame, target, ldr, record),
        }
    }

    /// Linear radiance, RGBA32F, row-major from the top-left.
    pub fn read_radiance(&self, gpu: &Gpu) -> Result<Vec<f32>> {
        gpu.read_image_rgba32f(&self.radiance)
    }

    /// Tone-mapped sRGB, RGBA8.
    pub fn read_ldr(&self, gpu: &Gpu) -> Result<Vec<u8>> {
        gpu.read_image_bytes(&self.ldr)
    }

    pub fn destroy(self, gpu: &Gpu) {
        let _ = gpu.wait_idle();
        self.technique.destroy(gpu);
        gpu.destroy_frame(self.frame);
        self.tonemap.destroy(gpu);
        self.compose.destroy(gpu);
        self.gbuffer_pass.destroy(gpu);
        self.skin.destroy(gpu);
        self.blocker_spheres.destroy(gpu);
        self.blocker_bvh.destroy(gpu);
        self.thin_shells.destroy(gpu);
        gpu.destroy_image(self.radiance);
        gpu.destroy_image(self.ldr);
        self.gbuffer.destroy(gpu);
        self.scene.destroy(gpu);
    }
}
