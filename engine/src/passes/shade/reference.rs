//! Technique `reference` (shaders-glsl/shade/reference): the Monte Carlo ground truth of
//! docs/design.md §4. Per G-buffer pixel (or per vertex) it integrates environment × BRDF × visibility
//! plus the scene's spherical lights, with environment importance sampling (luminance × texel
//! solid angle, marginal and conditional CDFs built here), light sampling (uniform in the cone a
//! sphere subtends) and BRDF sampling (cosine / Blinn-Phong lobe), combined by the power heuristic.
//! Visibility is traced against the real triangles through a binned-SAH BVH
//! ([`crate::scene::triangle_bvh`]) plus the live triangles of thin meshes, against the sphere proxies, or
//! switched off ([`Visibility::Unoccluded`]).
//!
//! Samples are deterministic (PCG hash of item, sample index and seed) and accumulate over frames
//! (Welford mean and M2 per item in device buffers) until the view changes, so the engine knows the
//! reference's own standard error ([`ReferenceStats`]) and can stop when it is a stated fraction of
//! the error being measured ([`converge`], [`converge_against`]).

use super::{Reads, ShadeInputs, ShadeTarget, TargetPipelines, Technique, TechniqueEntry, Tolerances};
use crate::gpu::{Binding, Buffer, BufferDesc, Gpu, GpuError, Recorder, Result};
use crate::input::SceneInputError;
use crate::options::OptionError;
use crate::resources::blockers::GpuVertexSkin;
use crate::resources::layout::{FrameData, GpuObject, GpuVertex};
use crate::resources::Geometry;
use crate::resources::ThinResources;
use crate::scene::triangle_bvh::TriangleBvh;
use bytemuck::{Pod, Zeroable};
use engine_math::envmap::{texel_solid_angle, LatLongMap};
use glam::{Mat4, Vec3, Vec4};
use std::cell::{Cell, Ref, RefCell};

pub const ENTRY: TechniqueEntry = TechniqueEntry {
    name: "reference",
    summary: "Monte Carlo ground truth (environment, light and BRDF sampling; triangles, spheres or unoccluded)",
    options: &[],
    reads: Reads { lights: true, blockers: true, thin: true, geometry: true, env_lights: false },
    tolerances: Tolerances {
        // Monte Carlo at `samples` per pixel: a few standard errors of the estimate.
        furnace: 0.02,
        unoccluded_vs_none: 0.05,
        one_sphere: Some(0.05),
        // The ball's dim underside is noise-dominated at 256 spp (measured 4.65 %; 2.3 % at 1024 spp).
        one_plane: Some(0.08),
        samples: 256,
    },
    create: |gpu, _| Ok(Box::new(Reference::new(gpu)?)),
};

/// The version of the reference's host code (sampling tables, what the triangle BVH holds, how samples are
/// merged): bumped whenever a change alters its images, so that references cached on disk
/// (`compare --reference-cache`) are not reused across it. Its shaders need no bump: caches key their sources
/// ([`FRAME_SHADERS`]). 2: thin meshes (a simulated cloth) traced live, not from the posed rest mesh; 3: the ray
/// offset relative to the shading point's coordinates, not the scene's diagonal (both issue 35).
pub const REFERENCE_CODE_VERSION: u32 = 3;

/// Every shader a renderer with the reference technique compiles (its own and the frame's passes), paths relative
/// to `shaders-glsl`: with their includes, the shader sources a reference image depends on
/// (tests/tests/reference.rs checks that the list is complete).
pub const FRAME_SHADERS: &[&str] = &[
    "blocker_bvh/bounds.comp",
    "blocker_bvh/hierarchy.comp",
    "blocker_bvh/morton.comp",
    "blocker_bvh/radix_count.comp",
    "blocker_bvh/radix_scan.comp",
    "blocker_bvh/radix_scatter.comp",
    "blocker_bvh/refit.comp",
    "blocker_spheres/animate.comp",
    "cloth/finish.comp",
    "cloth/predict.comp",
    "cloth/reset.comp",
    "cloth/solve.comp",
    "cloth/spheres.comp",
    "cloth/write.comp",
    "gbuffer/gbuffer.frag",
    "gbuffer/gbuffer.vert",
    "shade/compose.comp",
    "shade/reference/pixel.comp",
    "shade/reference/vertex.comp",
    "skin/skin.comp",
    "thin_shells/triangles.comp",
    "tonemap/tonemap.comp",
];

/// Push constants (`Params` in integrate.glsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct ReferenceParams {
    pub sample_base: u32,
    pub samples: u32,
    pub seed: u32,
    /// Unused (the light count is in the shared `Lights` buffer).
    pub pad_lights: u32,
    pub env_width: u32,
    pub env_height: u32,
    pub visibility: u32,
    pub item_count: u32,
    pub ray_offset: f32,
    pub env_total: f32,
    pub sphere_count: u32,
    pub pad0: f32,
}

/// What blocks the rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Visibility {
    /// The scene's triangles (the ground truth): those of solid meshes through the host-built BVH at the
    /// frame's pose, those of thin meshes (a simulated cloth) as the `thin_shells` pass writes them every frame,
    /// each hit exactly (no self-shadowing rule; the ray offset is the only guard).
    Triangles,
    /// Nothing (unshadowed lighting, for the decomposition of error and closed-form checks).
    Unoccluded,
    /// The blocker spheres (`GpuScene::spheres` through `GpuScene::bvh_nodes`): the sphere-proxy
    /// ground truth. Each sphere is seen from the shading point after the SHEXP §6.2 self-shadowing
    /// rules (`engine::blockers::geom::blocker_for_receiver`: eliminated behind the tangent plane,
    /// shrunk to tangency when the point is inside, the tangent sphere in front when it straddles),
    /// exactly the proxy the techniques see; every such sphere the ray enters in front of the point
    /// blocks. The triangles of thin meshes (`GpuScene::thin_triangles`, their own proxy) block too,
    /// through the same rule as in ISG (a triangle whose plane passes within 1e-3 of its longest edge
    /// of the point, or of zero area, does not).
    Spheres,
}

/// Controls of the reference. Changing them restarts accumulation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceOptions {
    /// Samples per item added by each frame (each sample traces up to three rays).
    pub samples_per_frame: u32,
    pub seed: u32,
    pub visibility: Visibility,
    /// Ray origins move along the geometric normal by this fraction of the magnitude of the coordinates the
    /// shading point was interpolated from (the larger of |p|∞ and its triangle's first vertex's |v|∞), the
    /// scale of its rounding error (self-intersection guard; contact shadows closer than this are lost).
    /// 5e-5 is about 400 f32 ulps: 0.1 mm at 2 m from the origin. It used to be a fraction (1e-4) of the
    /// scene's bounding-box diagonal, which a 2 km ground plane made 0.28 m: origins under a ball resting
    /// above it moved into the ball, and the triangle reference went black there (issue 35, the gate's
    /// `ball-above-*` fixtures).
    pub ray_offset: f32,
}

impl Default for ReferenceOptions {
    fn default() -> Self {
        Self { samples_per_frame: 4, seed: 1, visibility: Visibility::Triangles, ray_offset: 5e-5 }
    }
}

/// The largest sample count per item (the shader's sample counts are exact in f32 below 2^24).
pub const MAX_SAMPLES: u32 = 1 << 24;

/// Environment importance sampling: texel (row, col) is chosen with probability proportional to
/// luminance × solid angle, as marginal (rows) and conditional (columns in a row) CDFs; the
/// direction is uniform in (u, v) inside the texel, so its solid-angle density is
/// `P · W · H / (2π² sin θ)`. The shader uses the f32 CDF differences as probabilities, which is
/// exactly the distribution its binary search samples.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvSampling {
    pub width: usize,
    pub height: usize,
    /// H + 1 entries, 0 … 1.
    pub marginal: Vec<f32>,
    /// H × (W + 1) entries, each row 0 … 1.
    pub conditional: Vec<f32>,
    /// Σ luminance × solid angle (0 for a black map, whose CDFs are then uniform).
    pub total: f64,
}

fn luminance(t: [f32; 3]) -> f64 {
    0.2126 * t[0] as f64 + 0.7152 * t[1] as f64 + 0.0722 * t[2] as f64
}

impl EnvSampling {
    pub fn build(env: &LatLongMap) -> Result<Self> {
        let (w, h) = (env.width, env.height);
        if w == 0 || h == 0 || env.texels.len() != w * h {
            return Err(SceneInputError(format!("environment {w}x{h} with {} texels", env.texels.len())).into());
        }
        if let Some(i) = env.texels.iter().position(|t| t.iter().any(|c| !c.is_finite() || *c < 0.0)) {
            return Err(SceneInputError(format!(
                "environment texel {i} is negative or not finite: {:?}",
                env.texels[i]
            ))
            .into());
        }
        let weight = |row: usize, col: usize| luminance(env.texel(col, row)) * texel_solid_angle(row, w, h);
        let total: f64 = (0..h).flat_map(|r| (0..w).map(move |c| (r, c))).map(|(r, c)| weight(r, c)).sum();
        // A black map keeps uniform CDFs (its radiance is zero wherever they sample).
        let black = total.is_nan() || total <= 0.0;
        let weight = |row: usize, col: usize| if black { texel_solid_angle(row, w, h) } else { weight(row, col) };
        let mut conditional = Vec::with_capacity(h * (w + 1));
        let mut row_sums = Vec::with_capacity(h);
        for row in 0..h {
            let sum: f64 = (0..w).map(|c| weight(row, c)).sum();
            row_sums.push(sum);
            let mut acc = 0.0;
            conditional.push(0.0f32);
            for col in 0..w {
                acc += if sum > 0.0 { weight(row, col) / sum } else { 1.0 / w as f64 };
                conditional.push(if col + 1 == w { 1.0 } else { acc.min(1.0) as f32 });
            }
        }
        let all: f64 = row_sums.iter().sum();
        let mut marginal = Vec::with_capacity(h + 1);
        marginal.push(0.0f32);
        let mut acc = 0.0;
        for (row, s) in row_sums.iter().enumerate() {
            acc += s / all;
            marginal.push(if row + 1 == h { 1.0 } else { acc.min(1.0) as f32 });
        }
        Ok(Self { width: w, height: h, marginal, conditional, total: if black { 0.0 } else { total } })
    }

    /// Probability of texel (col, row), as the shader computes it.
    pub fn texel_probability(&self, col: usize, row: usize) -> f64 {
        let w1 = self.width + 1;
        (self.marginal[row + 1] - self.marginal[row]) as f64
            * (self.conditional[row * w1 + col + 1] - self.conditional[row * w1 + col]) as f64
    }
}

/// Per-item accumulation (Welford mean and M2, `vec4` each).
struct Accum {
    mean: Buffer,
    m2: Buffer,
    items: u32,
}

impl Accum {
    fn new(gpu: &Gpu, name: &str, items: u32) -> Result<Self> {
        let bytes = items.max(1) as u64 * 16;
        let mean = gpu.create_buffer(&format!("{name}-mean"), BufferDesc::gpu_only(bytes))?;
        match gpu.create_buffer(&format!("{name}-m2"), BufferDesc::gpu_only(bytes)) {
            Ok(m2) => Ok(Self { mean, m2, items }),
            Err(e) => {
                gpu.destroy_buffer(mean);
                Err(e)
            }
        }
    }
    fn destroy(self, gpu: &Gpu) {
        gpu.destroy_buffer(self.mean);
        gpu.destroy_buffer(self.m2);
    }
}

/// Everything `prepare` derives from the scene.
struct Tables {
    marginal: Buffer,
    conditional: Buffer,
    /// The triangle BVH of the pose it was built for; rebuilt by `record` when the pose changes.
    triangles: RefCell<PosedTriangles>,
    /// The skin pass's inputs, read back once, to pose the triangles on the host.
    rest: RestGeometry,
    /// Count of non-finite samples since `prepare` (host-visible).
    diagnostics: Buffer,
    vertex_accum: Accum,
    env_size: (u32, u32),
    env_total: f32,
}

impl Tables {
    fn destroy(self, gpu: &Gpu) {
        for b in [self.marginal, self.conditional, self.diagnostics] {
            gpu.destroy_buffer(b);
        }
        self.triangles.into_inner().destroy(gpu);
        self.vertex_accum.destroy(gpu);
    }
}

/// What the `skin` pass reads (object-space vertices, their bone influences, the indices), kept on the host so
/// that the triangles can be posed again without reading device memory.
struct RestGeometry {
    vertices: Vec<GpuVertex>,
    skins: Vec<GpuVertexSkin>,
    indices: Vec<u32>,
    bone_count: usize,
    /// Per scene triangle: whether it is a thin shell's (traced live from `ThinResources::triangles`).
    thin: Vec<bool>,
}

impl RestGeometry {
    fn read(gpu: &Gpu, scene: &Geometry, thin: &ThinResources) -> Result<Self> {
        let mut vertices: Vec<GpuVertex> = gpu.read_buffer(&scene.vertices)?;
        let mut indices: Vec<u32> = gpu.read_buffer(&scene.indices)?;
        let skins: Vec<GpuVertexSkin> = gpu.read_buffer(&scene.vertex_skins)?;
        vertices.truncate(scene.vertex_count as usize);
        indices.truncate(scene.index_count as usize);
        // The thin triangles hold the scene's vertex indices (resources::thin::gather), so a scene triangle is
        // thin when its index triple is one of theirs.
        let thin_indices: Vec<[u32; 4]> =
            if thin.triangle_count == 0 { Vec::new() } else { gpu.read_buffer(&thin.indices)? };
        let thin_set: std::collections::HashSet<[u32; 3]> =
            thin_indices.iter().take(thin.triangle_count as usize).map(|t| [t[0], t[1], t[2]]).collect();
        let thin = indices.chunks_exact(3).map(|t| thin_set.contains(&[t[0], t[1], t[2]])).collect();
        Ok(Self { vertices, skins, indices, bone_count: scene.bone_count as usize, thin })
    }

    /// World-space triangles at `pose`, by the skin pass's formula ([`skinned_position`]).
    fn world_triangles(&self, pose: &Pose) -> Result<Vec<[Vec3; 3]>> {
        let bones: Vec<Mat4> =
            pose.bones.chunks_exact(16).take(self.bone_count).map(|c| Mat4::from_cols_slice(c)).collect();
        let models: Vec<Mat4> = pose.objects.iter().map(|o| Mat4::from_cols_array(&o.model)).collect();
        let world: Vec<Vec3> = self
            .vertices
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let model = models.get(v.instance as usize).copied().unwrap_or(Mat4::IDENTITY);
                let skin = self.skins.get(i).copied().unwrap_or_default();
                skinned_position(model, skin_matrix(skin.joints, skin.weights, &bones), Vec3::from(v.position))
            })
            .collect();
        self.indices
            .chunks_exact(3)
            .map(|t| {
                let get = |i: u32| {
                    world
                        .get(i as usize)
                        .copied()
                        .ok_or_else(|| GpuError::Other(format!("reference: index {i} out of range")))
                };
                Ok([get(t[0])?, get(t[1])?, get(t[2])?])
            })
            .collect()
    }
}

/// The pose of the scene as the next frame's `skin` pass sees it: the bone matrices and instance transforms in
/// their host-visible buffers (`Renderer::set_bones`, `Renderer::set_instance_transform`), compared bit for bit.
#[derive(Clone, Debug, PartialEq)]
struct Pose {
    bones: Vec<f32>,
    objects: Vec<GpuObject>,
}

impl Pose {
    fn read(scene: &Geometry) -> Result<Self> {
        Ok(Self { bones: scene.bones.read()?, objects: scene.objects.read()? })
    }

    fn same_bits(&self, other: &Pose) -> bool {
        let bits = |p: &Pose| -> (Vec<u32>, Vec<u32>) {
            (p.bones.iter().map(|x| x.to_bits()).collect(), bytemuck::cast_slice(&p.objects).to_vec())
        };
        bits(self) == bits(other)
    }
}

/// The triangle BVH in device memory and the world-space triangles of the pose it was built for (scene index
/// order, thin triangles included). The BVH holds only the triangles of meshes that are not thin: those of thin
/// meshes (a simulated cloth above all) are traced from their world-space triangles that the `thin_shells` pass
/// rewrites every frame, the triangles the G-buffer rasterises, which a host-posed copy of the rest mesh is not.
struct PosedTriangles {
    nodes: Buffer,
    triangles: Buffer,
    pose: Pose,
    world: Vec<[Vec3; 3]>,
}

impl PosedTriangles {
    fn build(gpu: &Gpu, rest: &RestGeometry, pose: Pose) -> Result<Self> {
        let world = rest.world_triangles(&pose)?;
        let solid: Vec<[Vec3; 3]> = world.iter().zip(&rest.thin).filter(|(_, thin)| !**thin).map(|(t, _)| *t).collect();
        let bvh = TriangleBvh::build(&solid);
        let depth = bvh.depth();
        if depth >= TRACE_STACK {
            return Err(GpuError::Other(format!(
                "reference: triangle BVH depth {depth} exceeds the traversal stack ({TRACE_STACK})"
            )));
        }
        let nodes = gpu.upload_buffer("reference-bvh-nodes", BufferDesc::gpu_only(0), &bvh.nodes)?;
        let triangles = match gpu.upload_buffer("reference-bvh-triangles", BufferDesc::gpu_only(0), &bvh.triangles) {
            Ok(t) => t,
            Err(e) => {
                gpu.destroy_buffer(nodes);
                return Err(e);
            }
        };
        Ok(Self { nodes, triangles, pose, world })
    }

    fn destroy(self, gpu: &Gpu) {
        gpu.destroy_buffer(self.nodes);
        gpu.destroy_buffer(self.triangles);
    }
}

/// `skin_matrix` of shaders-glsl/common/skinning.glsl in f32, operation for operation: Σ w_k B_{j_k} in k order
/// from the zero matrix, the identity when the weights do not sum to a positive number, a bone index out of
/// range counting as the identity. The reference poses its triangles with it, so that they are the G-buffer's
/// (tests/tests/reference_skin.rs compares them with the skin pass's world vertices).
pub fn skin_matrix(joints: [u32; 4], weights: [f32; 4], bones: &[Mat4]) -> Mat4 {
    let total = weights[0] + weights[1] + weights[2] + weights[3];
    // `!(total > 0)` of the GLSL, NaN included.
    if total.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return Mat4::IDENTITY;
    }
    let mut m = Mat4::ZERO;
    for k in 0..4 {
        m += bones.get(joints[k] as usize).copied().unwrap_or(Mat4::IDENTITY) * weights[k];
    }
    m
}

/// shaders-glsl/skin/skin.comp's position: `(model * (bone * vec4(p, 1))).xyz`.
pub fn skinned_position(model: Mat4, bone: Mat4, p: Vec3) -> Vec3 {
    (model * (bone * Vec4::new(p.x, p.y, p.z, 1.0))).truncate()
}

/// Deepest BVH the GLSL traversal stack (`TRACE_STACK` in trace.glsl) holds.
const TRACE_STACK: usize = 64;

/// The reference technique.
pub struct Reference {
    pipelines: TargetPipelines,
    options: ReferenceOptions,
    tables: Option<Tables>,
    pixel_accum: RefCell<Option<Accum>>,
    pixel_samples: Cell<u32>,
    vertex_samples: Cell<u32>,
    /// The view the accumulated samples belong to (frame constants without the exposure).
    view: Cell<Option<FrameData>>,
}

/// Accumulated statistics per item (pixel, row-major from the top-left, or vertex).
#[derive(Clone, Debug)]
pub struct ReferenceStats {
    /// Samples per covered item.
    pub samples: u32,
    pub mean: Vec<[f32; 3]>,
    /// Standard error of each mean, per channel (infinite below two samples).
    pub stderr: Vec<[f32; 3]>,
    /// Items that are surfaces (background pixels are not).
    pub covered: Vec<bool>,
    /// Samples that came out NaN or infinite since `prepare` (counted, replaced by zero).
    pub nonfinite_samples: u32,
}

impl ReferenceStats {
    /// sqrt(Σ se²) / sqrt(Σ mean²) over covered items and channels: the expected relative RMSE of
    /// the reference against the exact answer, in the form of the relative RMSE of a measurement.
    pub fn relative_stderr(&self) -> f64 {
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for ((m, s), c) in self.mean.iter().zip(&self.stderr).zip(&self.covered) {
            if !*c {
                continue;
            }
            for k in 0..3 {
                num += (s[k] as f64) * (s[k] as f64);
                den += (m[k] as f64) * (m[k] as f64);
            }
        }
        engine_math::linalg::sqrt_ratio(num, den)
    }
}

impl Reference {
    pub fn new(gpu: &Gpu) -> Result<Self> {
        Ok(Self {
            pipelines: TargetPipelines::new(gpu, "reference")?,
            options: ReferenceOptions::default(),
            tables: None,
            pixel_accum: RefCell::new(None),
            pixel_samples: Cell::new(0),
            vertex_samples: Cell::new(0),
            view: Cell::new(None),
        })
    }

    pub fn options(&self) -> ReferenceOptions {
        self.options
    }

    /// New options; accumulation restarts.
    pub fn set_options(&mut self, options: ReferenceOptions) -> Result<()> {
        if options.samples_per_frame == 0 || options.samples_per_frame > 4096 {
            return Err(OptionError(format!(
                "reference: samples per frame {} not in 1..=4096",
                options.samples_per_frame
            ))
            .into());
        }
        if !(options.ray_offset >= 0.0 && options.ray_offset < 0.1) {
            return Err(OptionError(format!("reference: ray offset {} not in [0, 0.1)", options.ray_offset)).into());
        }
        self.options = options;
        self.reset();
        Ok(())
    }

    /// Discard accumulated samples (the next frame starts again from sample 0).
    pub fn reset(&self) {
        self.pixel_samples.set(0);
        self.vertex_samples.set(0);
    }

    /// Samples accumulated per item for the pixel (`per_vertex == false`) or vertex target.
    pub fn samples(&self, per_vertex: bool) -> u32 {
        if per_vertex {
            self.vertex_samples.get()
        } else {
            self.pixel_samples.get()
        }
    }

    /// Read the accumulated statistics of the pixel or vertex target back to the host.
    pub fn stats(&self, gpu: &Gpu, per_vertex: bool) -> Result<ReferenceStats> {
        let tables = self.tables.as_ref().ok_or_else(|| GpuError::Other("reference: stats before prepare()".into()))?;
        let pixel = self.pixel_accum.borrow();
        let accum = if per_vertex {
            &tables.vertex_accum
        } else {
            pixel.as_ref().ok_or_else(|| GpuError::Other("reference: no pixel samples yet".into()))?
        };
        let n = self.samples(per_vertex);
        let mean: Vec<[f32; 4]> = gpu.read_buffer(&accum.mean)?;
        let m2: Vec<[f32; 4]> = gpu.read_buffer(&accum.m2)?;
        let diag: Vec<u32> = tables.diagnostics.read()?;
        let items = accum.items as usize;
        let stderr = |m: f32| {
            if n < 2 {
                f32::INFINITY
            } else {
                (m.max(0.0) as f64 / ((n - 1) as f64 * n as f64)).sqrt() as f32
            }
        };
        Ok(ReferenceStats {
            samples: n,
            mean: mean[..items].iter().map(|m| [m[0], m[1], m[2]]).collect(),
            stderr: m2[..items].iter().map(|m| [stderr(m[0]), stderr(m[1]), stderr(m[2])]).collect(),
            covered: mean[..items].iter().map(|m| m[3] > 0.5).collect(),
            nonfinite_samples: diag.first().copied().unwrap_or(0),
        })
    }

    fn destroy_tables(&mut self, gpu: &Gpu) {
        if let Some(t) = self.tables.take() {
            t.destroy(gpu);
        }
        if let Some(a) = self.pixel_accum.get_mut().take() {
            a.destroy(gpu);
        }
        self.reset();
    }

    fn build_tables(gpu: &Gpu, inputs: &ShadeInputs) -> Result<Tables> {
        let env = EnvSampling::build(&inputs.environment.cpu)?;
        let geometry = inputs.geometry()?;
        let rest = RestGeometry::read(gpu, geometry, inputs.thin()?)?;
        // The pose the scene has now (its initial bones and transforms, or the last set_bones): the G-buffer's.
        let triangles = PosedTriangles::build(gpu, &rest, Pose::read(geometry)?)?;
        let mut made: Vec<Buffer> = Vec::new();
        let built = (|| -> Result<()> {
            made.push(gpu.upload_buffer("reference-env-marginal", BufferDesc::gpu_only(0), &env.marginal)?);
            made.push(gpu.upload_buffer("reference-env-conditional", BufferDesc::gpu_only(0), &env.conditional)?);
            let mut diag = gpu.create_buffer("reference-diagnostics", BufferDesc::readback(16))?;
            let zeroed = diag.write(&[0u32; 4]);
            made.push(diag);
            zeroed
        })();
        let vertex_accum = built.and_then(|_| Accum::new(gpu, "reference-vertex-accum", geometry.vertex_count));
        let vertex_accum = match vertex_accum {
            Ok(a) => a,
            Err(e) => {
                for b in made {
                    gpu.destroy_buffer(b);
                }
                triangles.destroy(gpu);
                return Err(e);
            }
        };
        let mut it = made.into_iter();
        let mut next = || it.next().ok_or_else(|| GpuError::Other("internal: reference buffer list".into()));
        Ok(Tables {
            marginal: next()?,
            conditional: next()?,
            diagnostics: next()?,
            triangles: RefCell::new(triangles),
            rest,
            vertex_accum,
            env_size: (env.width as u32, env.height as u32),
            env_total: env.total as f32,
        })
    }

    /// Rebuild the triangle BVH if the scene's pose (bones, instance transforms) differs from the one it was
    /// built for; accumulated samples belong to the old pose and are discarded. Called while recording a
    /// frame, when no frame is in flight (run_frame waits), so the old buffers are free.
    fn follow_pose(&self, gpu: &Gpu, tables: &Tables, geometry: &Geometry) -> Result<()> {
        let pose = Pose::read(geometry)?;
        if tables.triangles.borrow().pose.same_bits(&pose) {
            return Ok(());
        }
        let fresh = PosedTriangles::build(gpu, &tables.rest, pose)?;
        tables.triangles.replace(fresh).destroy(gpu);
        self.reset();
        Ok(())
    }

    /// The world-space triangles (scene index order) of the pose the triangle BVH was built for: the pose of the
    /// last recorded frame, or of `prepare` before any. What the rays see, for tests against the skin pass, except
    /// the thin meshes' triangles (see [`Reference::thin_triangles`]), which the rays see as the `thin_shells`
    /// pass writes them.
    pub fn posed_triangles(&self) -> Option<Ref<'_, [[Vec3; 3]]>> {
        self.tables.as_ref().map(|t| Ref::map(t.triangles.borrow(), |p| p.world.as_slice()))
    }

    /// Per scene triangle (index order), whether it belongs to a thin mesh: left out of the triangle BVH and
    /// traced from the live thin triangles instead (`None` before `prepare`).
    pub fn thin_triangles(&self) -> Option<&[bool]> {
        self.tables.as_ref().map(|t| t.rest.thin.as_slice())
    }

    /// Samples the next frames add per item, keeping what is accumulated (integrate.glsl merges batches of any
    /// size, Chan et al.'s update): how `demo --spp N` accumulates exactly N in frames of at most 64.
    pub fn set_samples_per_frame(&mut self, samples: u32) -> Result<()> {
        if samples == 0 || samples > 4096 {
            return Err(OptionError(format!("reference: samples per frame {samples} not in 1..=4096")).into());
        }
        self.options.samples_per_frame = samples;
        Ok(())
    }
}

impl Technique for Reference {
    fn name(&self) -> &'static str {
        "reference"
    }

    fn prepare(&mut self, gpu: &Gpu, inputs: &ShadeInputs) -> Result<()> {
        self.destroy_tables(gpu);
        self.tables = Some(Self::build_tables(gpu, inputs)?);
        self.view.set(None);
        Ok(())
    }

    fn record(&self, rec: &mut Recorder, inputs: &ShadeInputs, target: ShadeTarget) -> Result<()> {
        let Some(t) = &self.tables else {
            return Err(GpuError::Other("technique 'reference' recorded before prepare()".into()));
        };
        // A new view (camera, resolution) restarts accumulation; exposure does not change radiance.
        let mut view = inputs.frame.read::<FrameData>()?.first().copied().unwrap_or_default();
        view.exposure = 0.0;
        if self.view.get() != Some(view) {
            self.reset();
            self.view.set(Some(view));
        }
        // A new pose (set_bones, set_instance_transform) moves the triangles the rays must see.
        self.follow_pose(rec.gpu(), t, inputs.geometry()?)?;
        let posed = t.triangles.borrow();
        let (counter, items, name) = match target {
            ShadeTarget::Pixel { radiance, .. } => {
                (&self.pixel_samples, radiance.desc.width * radiance.desc.height, "shade/reference")
            }
            ShadeTarget::Vertex { count, .. } => (&self.vertex_samples, count, "shade/reference (per vertex)"),
        };
        if let ShadeTarget::Pixel { .. } = target {
            let mut slot = self.pixel_accum.borrow_mut();
            if slot.as_ref().is_none_or(|a| a.items != items) {
                // No frame is in flight while recording (run_frame waits), so the old buffers are free.
                if let Some(old) = slot.take() {
                    old.destroy(rec.gpu());
                }
                *slot = Some(Accum::new(rec.gpu(), "reference-pixel-accum", items)?);
                counter.set(0);
            }
        }
        let base = counter.get();
        let samples = self.options.samples_per_frame;
        if base as u64 + samples as u64 > MAX_SAMPLES as u64 {
            return Err(GpuError::Other(format!("reference: {base} samples accumulated; at most {MAX_SAMPLES}")));
        }
        let (blockers, thin, lights) = (inputs.blockers()?, inputs.thin()?, inputs.lights()?);
        let params = ReferenceParams {
            sample_base: base,
            samples,
            seed: self.options.seed,
            pad_lights: 0,
            env_width: t.env_size.0,
            env_height: t.env_size.1,
            visibility: match self.options.visibility {
                Visibility::Triangles => 0,
                Visibility::Unoccluded => 1,
                Visibility::Spheres => 2,
            },
            item_count: items,
            ray_offset: self.options.ray_offset,
            env_total: t.env_total,
            sphere_count: blockers.sphere_count,
            pad0: 0.0,
        };
        let pixel = self.pixel_accum.borrow();
        let accum = match target {
            ShadeTarget::Pixel { .. } => {
                pixel.as_ref().ok_or_else(|| GpuError::Other("internal: pixel accumulation".into()))?
            }
            ShadeTarget::Vertex { .. } => &t.vertex_accum,
        };
        let mut b = vec![
            Binding::buffer("FrameBuf", inputs.frame),
            Binding::buffer("Materials", inputs.materials),
            Binding::sampled("env_map", &inputs.environment.image),
            Binding::buffer("AccumMean", &accum.mean),
            Binding::buffer("AccumM2", &accum.m2),
            Binding::buffer("EnvMarginal", &t.marginal),
            Binding::buffer("EnvConditional", &t.conditional),
            Binding::buffer("TriNodes", &posed.nodes),
            Binding::buffer("Tris", &posed.triangles),
            Binding::buffer("Lights", &lights.buffer),
            Binding::buffer("Diagnostics", &t.diagnostics),
            Binding::buffer("BlockerSpheres", &blockers.spheres),
            Binding::buffer("BvhNodes", &blockers.bvh_nodes),
            Binding::buffer("BlockerPlanes", &blockers.planes),
            Binding::buffer("ThinTriangles", &thin.triangles),
            Binding::buffer("ThinClusters", &thin.clusters),
        ];
        rec.begin_pass(name);
        let push = bytemuck::bytes_of(&params);
        match target {
            ShadeTarget::Pixel { gbuffer, radiance } => {
                b.push(Binding::storage_image("gbuf_position", &gbuffer.position));
                b.push(Binding::storage_image("gbuf_normal", &gbuffer.normal));
                b.push(Binding::storage_image("gbuf_geometric", &gbuffer.geometric));
                b.push(Binding::storage_image("radiance", radiance));
                b.push(Binding::buffer("WorldVertices", &inputs.geometry()?.world_vertices));
                let pipeline = self.pipelines.pixel(rec.gpu())?;
                rec.dispatch(pipeline, &b, push, [radiance.desc.width, radiance.desc.height, 1])?;
            }
            ShadeTarget::Vertex { world_vertices, radiance, count } => {
                b.push(Binding::buffer("WorldVertices", world_vertices));
                b.push(Binding::buffer("VertexRadiance", radiance));
                let pipeline = self.pipelines.vertex(rec.gpu())?;
                rec.dispatch(pipeline, &b, push, [count, 1, 1])?;
            }
        }
        counter.set(base + samples);
        Ok(())
    }

    fn destroy(mut self: Box<Self>, gpu: &Gpu) {
        self.destroy_tables(gpu);
        let this = *self;
        this.pipelines.destroy(gpu);
    }

    /// Samples accumulated under the old materials belong to another image.
    fn materials_changed(&mut self) {
        self.reset();
    }

    fn as_any_mut(&mut self) -> Option<&mut dyn std::any::Any> {
        Some(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{offset_of, size_of};

    #[test]
    fn std430_layouts() {
        assert_eq!(size_of::<ReferenceParams>(), 48);
        assert_eq!(offset_of!(ReferenceParams, ray_offset), 32);
        assert_eq!(offset_of!(ReferenceParams, env_total), 36);
        assert_eq!(offset_of!(ReferenceParams, sphere_count), 40);
    }

    #[test]
    fn env_sampling_probabilities_follow_luminance_times_solid_angle() {
        let (w, h) = (16, 8);
        let mut env = LatLongMap::constant(w, h, [0.1, 0.2, 0.3]);
        env.texels[3 * w + 5] = [50.0, 40.0, 30.0];
        env.texels[7 * w] = [0.0; 3];
        let s = EnvSampling::build(&env).expect("tables");
        assert_eq!(s.marginal.len(), h + 1);
        assert_eq!(s.conditional.len(), h * (w + 1));
        assert_eq!((s.marginal[0], s.marginal[h]), (0.0, 1.0));
        assert!(s.marginal.windows(2).all(|p| p[0] <= p[1]));
        assert!(s.conditional.chunks(w + 1).all(|r| r[0] == 0.0 && r[w] == 1.0 && r.windows(2).all(|p| p[0] <= p[1])));
        let mut sum = 0.0;
        for row in 0..h {
            for col in 0..w {
                let p = s.texel_probability(col, row);
                let want = luminance(env.texel(col, row)) * texel_solid_angle(row, w, h) / s.total;
                // The f32 CDFs round each entry by ≤ 2^-24 of 1: differences carry ~1e-7 absolute.
                assert!((p - want).abs() <= 3e-7, "texel ({col},{row}): {p} vs {want}");
                sum += p;
            }
        }
        assert!((sum - 1.0).abs() < 1e-6);
        assert_eq!(s.texel_probability(0, 7), 0.0);
    }

    #[test]
    fn env_sampling_bad_and_black_maps() {
        let mut env = LatLongMap::constant(4, 2, [0.0; 3]);
        let black = EnvSampling::build(&env).expect("black map");
        assert_eq!(black.total, 0.0);
        assert!(
            (black.texel_probability(1, 1) - texel_solid_angle(1, 4, 2) / (4.0 * std::f64::consts::PI)).abs() < 1e-6
        );
        env.texels[2] = [f32::NAN, 0.0, 0.0];
        assert!(EnvSampling::build(&env).is_err());
        env.texels[2] = [-1.0, 0.0, 0.0];
        assert!(EnvSampling::build(&env).is_err());
    }
}
