//! One frame: skin → blocker spheres → cloth (if the scene has one) → thin shells → blocker BVH →
//! (per-vertex shade) → G-buffer → shade or compose → tonemap, with per-pass
//! GPU times. Everything is allocated in [`Renderer::new`]; a steady frame allocates no device
//! memory (checked by a test through the allocator's counters).

use crate::gpu::{Frame, Gpu, GpuError, Image, ImageDesc, ImageFormat, PassTiming, Recorder, Result, SwapchainImage};
use crate::passes::blocker_bvh::BlockerBvhPass;
use crate::passes::blocker_spheres::BlockerSpheresPass;
use crate::passes::cloth::ClothPass;
use crate::passes::gbuffer::{GBuffer, GBufferPass};
use crate::passes::shade::{
    parse_technique, wants_env_lights, ComposePass, Reads, ShadeInputs, ShadeTarget, Technique,
};
use crate::passes::skin::SkinPass;
use crate::passes::thin_shells::ThinShellsPass;
use crate::passes::tonemap::TonemapPass;
use crate::resources::layout::{FrameData, GpuObject};
use crate::resources::GpuScene;
use crate::scene::{Camera, Scene};
use engine_math::prefilter::PREFILTER_LEVELS;

/// The technique a renderer uses unless told otherwise: the best soft shadows at their defaults.
pub const DEFAULT_TECHNIQUE: &str = "isg";

/// A technique made from its spec and prepared for a scene (destroyed again if `prepare` fails). A technique
/// that shades the environment as lights and a residual (`env_lights=on`) gets the scene's split,
/// made here on first use.
fn make_technique(gpu: &Gpu, scene: &mut GpuScene, spec: &str) -> Result<(Box<dyn Technique>, Reads)> {
    let (entry, options) = parse_technique(spec)?;
    let mut t = (entry.create)(gpu, &options)?;
    let reads = Reads { env_lights: wants_env_lights(&options), ..entry.reads };
    let prepared = (|| {
        if reads.env_lights {
            scene.env_split(gpu)?;
        }
        t.prepare(gpu, &ShadeInputs::new(scene, entry.name, reads)?)
    })();
    match prepared {
        Ok(()) => Ok((t, reads)),
        Err(e) => {
            t.destroy(gpu);
            Err(e)
        }
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
        Self { width: 640, height: 480, technique: DEFAULT_TECHNIQUE.into(), per_vertex: false, exposure: 1.0 }
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
    cloth: Option<ClothPass>,
    gbuffer_pass: Option<GBufferPass>,
    compose: Option<ComposePass>,
    tonemap: Option<TonemapPass>,
    frame: Option<Frame>,
    technique: Option<(Box<dyn Technique>, Reads)>,
}

impl Parts {
    fn destroy(self, gpu: &Gpu) {
        if let Some((t, _)) = self.technique {
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
        if let Some(x) = self.cloth {
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
    /// The scene's cloth simulation, if it has one.
    cloth: Option<ClothPass>,
    gbuffer_pass: GBufferPass,
    compose: ComposePass,
    tonemap: TonemapPass,
    technique: Box<dyn Technique>,
    reads: Reads,
    frame: Frame,
    pub settings: RenderSettings,
    camera: Camera,
    near_far: (f32, f32),
    /// The scene's time (s), for the cloth simulation ([`Renderer::set_time`]).
    time: f64,
}

/// The widest or tallest image the renderer makes, in pixels (Vulkan's guaranteed 2D image size is 4096; lavapipe
/// and current GPUs take 16384).
pub const MAX_RESOLUTION: u32 = 16384;

impl Renderer {
    pub fn new(gpu: &Gpu, scene: &Scene, settings: RenderSettings) -> Result<Self> {
        let side = 1..=MAX_RESOLUTION;
        if !side.contains(&settings.width) || !side.contains(&settings.height) {
            return Err(crate::options::OptionError(format!(
                "resolution {}x{}: width and height must be in 1..={MAX_RESOLUTION}",
                settings.width, settings.height
            ))
            .into());
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
            let spheres = p.scene.as_ref().map_or(0, |s| s.blockers.sphere_count);
            p.blocker_bvh = Some(BlockerBvhPass::new(gpu, spheres)?);
            p.thin_shells = Some(ThinShellsPass::new(gpu)?);
            if let Some(s) = p.scene.as_ref() {
                p.cloth = ClothPass::new(gpu, scene, s)?;
            }
            p.gbuffer_pass = Some(GBufferPass::new(gpu)?);
            p.compose = Some(ComposePass::new(gpu)?);
            p.tonemap = Some(TonemapPass::new(gpu)?);
            p.frame = Some(gpu.create_frame()?);
            let scene = p.scene.as_mut().ok_or_else(|| GpuError::Other("internal: scene missing".into()))?;
            p.technique = Some(make_technique(gpu, scene, &settings.technique)?);
            Ok(())
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
        let technique = p.technique.take().ok_or_else(missing)?;
        Ok(Self {
            scene: p.scene.ok_or_else(missing)?,
            gbuffer: p.gbuffer.ok_or_else(missing)?,
            radiance: p.radiance.ok_or_else(missing)?,
            ldr: p.ldr.ok_or_else(missing)?,
            skin: p.skin.ok_or_else(missing)?,
            blocker_spheres: p.blocker_spheres.ok_or_else(missing)?,
            blocker_bvh: p.blocker_bvh.ok_or_else(missing)?,
            thin_shells: p.thin_shells.ok_or_else(missing)?,
            cloth: p.cloth,
            gbuffer_pass: p.gbuffer_pass.ok_or_else(missing)?,
            compose: p.compose.ok_or_else(missing)?,
            tonemap: p.tonemap.ok_or_else(missing)?,
            technique: technique.0,
            reads: technique.1,
            frame: p.frame.ok_or_else(missing)?,
            camera: scene.camera,
            near_far: (near, far),
            time: 0.0,
            settings,
        })
    }

    /// Switch the shading technique (compiles and prepares it; the old one is destroyed).
    pub fn set_technique(&mut self, gpu: &Gpu, name: &str) -> Result<()> {
        if name == self.settings.technique {
            return Ok(());
        }
        let (t, reads) = make_technique(gpu, &mut self.scene, name)?;
        let old = std::mem::replace(&mut self.technique, t);
        old.destroy(gpu);
        self.reads = reads;
        self.settings.technique = name.to_string();
        Ok(())
    }

    /// Rotate the environment about +y to `degrees` (absolute, from the scene's unrotated map) from the
    /// next frame on. Everything derived from it is recomputed (textures, prefiltered maps, irradiance
    /// grid, SH projections) and the technique is prepared again (its SG or SH fits depend on it; the
    /// reference restarts): an event that costs about as much as switching technique, not a per-frame
    /// animation. On error the renderer keeps its previous environment and technique.
    pub fn set_environment_rotation(&mut self, gpu: &Gpu, degrees: f32) -> Result<()> {
        if degrees == self.scene.environment.rotation_degrees {
            return Ok(());
        }
        let environment = self.scene.environment.rotated(gpu, degrees)?;
        gpu.wait_idle()?;
        let old_environment = std::mem::replace(&mut self.scene.environment, environment);
        // The split (lights and residual) follows the environment: made again for the new one on demand.
        let old_split = self.scene.take_env_split();
        match make_technique(gpu, &mut self.scene, &self.settings.technique) {
            Ok((t, reads)) => {
                std::mem::replace(&mut self.technique, t).destroy(gpu);
                self.reads = reads;
                old_environment.destroy(gpu);
                if let Some(s) = old_split {
                    s.destroy(gpu);
                }
                Ok(())
            }
            Err(e) => {
                std::mem::replace(&mut self.scene.environment, old_environment).destroy(gpu);
                self.scene.restore_env_split(gpu, old_split);
                Err(e)
            }
        }
    }

    /// The environment's current rotation about +y (degrees).
    pub fn environment_rotation(&self) -> f32 {
        self.scene.environment.rotation_degrees
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
            vertex_count: self.scene.geometry.vertex_count,
            prefiltered_levels: PREFILTER_LEVELS as u32,
            ..FrameData::default()
        }
    }

    /// Animate: the object-to-world transform of instance `i` from the next frame on (moves its vertices
    /// and blocker spheres; rewrites a host-visible buffer, allocates nothing).
    pub fn set_instance_transform(&mut self, i: usize, transform: glam::Mat4) -> Result<()> {
        let count = self.scene.geometry.objects.desc.size as usize / std::mem::size_of::<GpuObject>();
        if i >= count || !transform.is_finite() {
            return Err(crate::resources::invalid_scene(format!("instance {i} of {count}, or a non-finite transform")));
        }
        let object = GpuObject {
            model: transform.to_cols_array(),
            normal_matrix: transform.inverse().transpose().to_cols_array(),
        };
        let mut all: Vec<GpuObject> = self.scene.geometry.objects.read()?;
        all[i] = object;
        self.scene.geometry.objects.write(&all[..count])
    }

    /// Animate: the bone matrices (rest → posed object space) from the next frame on, for the skin
    /// pass and the blocker spheres alike. `bones.len()` must equal the scene's bone count.
    pub fn set_bones(&mut self, bones: &[glam::Mat4]) -> Result<()> {
        if bones.len() != self.scene.geometry.bone_count as usize || bones.iter().any(|m| !m.is_finite()) {
            return Err(crate::resources::invalid_scene(format!(
                "{} bone matrices (the scene has {}), or a non-finite one",
                bones.len(),
                self.scene.geometry.bone_count
            )));
        }
        let cols: Vec<[f32; 16]> = bones.iter().map(|m| m.to_cols_array()).collect();
        self.scene.geometry.bones.write(&cols)
    }

    /// Replace the scene's materials from the next frame on (the viewer's BRDF switch): as many as the scene
    /// was built with, each checked as at upload. Rewrites the device-local material buffer through a staging
    /// copy (one transient allocation: an event, not a steady frame) and tells the technique
    /// ([`Technique::materials_changed`]).
    pub fn set_materials(&mut self, gpu: &Gpu, materials: &[crate::scene::Material]) -> Result<()> {
        use crate::resources::layout::GpuMaterial;
        let count = self.scene.materials.desc.size as usize / std::mem::size_of::<GpuMaterial>();
        if materials.len() != count {
            return Err(crate::resources::invalid_scene(format!(
                "{} materials given, the scene has {count} (set_materials replaces them one for one)",
                materials.len()
            )));
        }
        let gpu_materials: Vec<GpuMaterial> = materials.iter().map(GpuMaterial::from_material).collect();
        if let Some(i) =
            gpu_materials.iter().position(|m| !bytemuck::cast_slice::<_, f32>(&[*m]).iter().all(|x| x.is_finite()))
        {
            return Err(crate::resources::invalid_scene(format!("material {i} has a non-finite parameter")));
        }
        gpu.copy_to_buffer(&self.scene.materials, bytemuck::cast_slice(&gpu_materials))?;
        self.technique.materials_changed();
        Ok(())
    }

    /// Animate: the scene's time (s) from the next frame on. Only a simulated cloth reads it: the next frame
    /// advances it from its state to `t` in fixed substeps, or resets it to the rest state first when `t` is
    /// earlier than the state (`engine::passes::cloth`).
    pub fn set_time(&mut self, t: f32) -> Result<()> {
        if !t.is_finite() || t < 0.0 {
            return Err(crate::resources::invalid_scene(format!("scene time {t} s (finite, ≥ 0)")));
        }
        self.time = t as f64;
        Ok(())
    }

    /// The cloth simulation, if the scene has one (its state for tests and captures).
    pub fn cloth(&self) -> Option<&ClothPass> {
        self.cloth.as_ref()
    }

    /// The technique's warnings since the last call ([`Technique::warnings`]: e.g. `lobes`' dropped blockers).
    pub fn technique_warnings(&mut self, gpu: &Gpu) -> Result<Vec<String>> {
        self.technique.warnings(gpu)
    }

    /// The technique's warnings and work counts since the last call ([`Technique::report`]).
    pub fn technique_report(&mut self, gpu: &Gpu) -> Result<crate::passes::shade::TechniqueReport> {
        self.technique.report(gpu)
    }

    /// The technique's blocker-tile counts ([`Technique::tile_counts`]), if it traverses the blocker BVH.
    pub fn tile_counts(&mut self, gpu: &Gpu) -> Result<Option<crate::passes::shade::tiles::TileCounts>> {
        self.technique.tile_counts(gpu)
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
            cloth,
            gbuffer_pass,
            compose,
            tonemap,
            technique,
            reads,
            frame,
            settings,
            time,
            ..
        } = self;
        let per_vertex = settings.per_vertex;
        let record = |rec: &mut Recorder| {
            skin.record(rec, scene)?;
            blocker_spheres.record(rec, scene)?;
            if let Some(c) = cloth.as_mut() {
                // Spheres along the cloth only for the techniques that do not see its thin shells.
                c.record(rec, scene, *time, !reads.thin)?;
            }
            thin_shells.record(rec, scene)?;
            let b = &scene.blockers;
            blocker_bvh.record(rec, &b.spheres, &b.bvh_nodes, b.sphere_count)?;
            let inputs = ShadeInputs::new(scene, technique.name(), *reads)?;
            if per_vertex {
                technique.record(rec, &inputs, ShadeTarget::vertices(&scene.geometry))?;
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
        if let Some(c) = self.cloth {
            c.destroy(gpu);
        }
        gpu.destroy_image(self.radiance);
        gpu.destroy_image(self.ldr);
        self.gbuffer.destroy(gpu);
        self.scene.destroy(gpu);
    }
}
