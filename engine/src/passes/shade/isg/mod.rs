//! Technique `isg` (shaders-glsl/shade/isg): soft shadows from blocker spheres under all-frequency
//! environment lighting with integral spherical Gaussians (Iwasaki et al. 2012).
//!
//! - Diffuse, default `diffuse=map` (ours): E(n) from the irradiance grid minus, over the occluded
//!   patches of one P × P grid spanning the hemisphere above n, the prefiltered environment at each
//!   patch centre (filter matched to the patch) times the patch's exact cosine-weighted solid angle.
//!   The paper's diffuse (§3–4, Eq. 5–6, `diffuse=sg`): the environment as K spherical Gaussians (a
//!   greedy least-squares fit, engine-math `fit_envmap_sgs`, refined), the clamped cosine as one SG;
//!   each product lobe integrated against the visibility as its unoccluded integral minus the ISG of
//!   its occluded patches; `diffuse=ratio` scales the exact E(n) by those lobes' visibility ratio.
//! - Specular (Eq. 7–10): normalized Blinn-Phong as one warped SG, lighting from the SG-prefiltered
//!   environment maps (Γ_L, the same maps as technique `none`), times the visibility ratio of Eq. 9
//!   computed on the product of the BRDF lobe and the cosine lobe.
//! - Occluded patches (§4.1, §5): a P × P grid within the limiting angle Γ (ε), the sphere BVH
//!   traversed with cone culling and a projected-size threshold; the SHEXP §6.2 self-shadowing rules
//!   for spheres near the receiver. See shaders-glsl/common/isg_visibility.glsl.
//!
//! Options (`--technique isg:patches=32,eps=0.01,threshold=1,evaluator=table,diffuse=map,K=10`):
//! `patches` per side P (P² patches, 1..32), `eps` the limiting-angle threshold ε, `threshold` the
//! BVH node size (in patch widths) below which a node is taken whole, `evaluator` `table` (ours,
//! engine-math IsgLut) or `paper` (the paper's sigmoid fit), `diffuse` `map` (default), `ratio` or
//! `sg` (the paper's Eq. 5), and for `ratio`/`sg`: `K` environment lobes (1..32) and `refine` rounds
//! of coordinate descent on the greedy environment fit (6; 0 = greedy only).
//!
//! Thin shells (§5): triangles of meshes marked thin are rasterized into the patch grids (the
//! hemisphere grid of `diffuse=map`, each lobe's grid otherwise, the specular lobe's always;
//! shaders-glsl/common/isg_thin.glsl, f64 twin [`thin`]), OR-ed with the spheres' patches.
//! Not modelled: anisotropic BRDF lobes. [`cpu`] is the f64 twin of the whole per-point integral.

use super::tiles::{sin_take_whole, BlockerTiles};
use super::{Reads, ShadeInputs, ShadeTarget, TargetPipelines, Technique, TechniqueEntry, Tolerances};
use crate::gpu::{Binding, Buffer, BufferDesc, Gpu, GpuError, Recorder, Result};
use crate::tables::MathTables;
use engine_math::sg::{SgRgb, COSINE_SG_LAMBDA, COSINE_SG_MU};
use engine_math::table_gen::MathTable;

pub mod cpu;
pub mod grid;
pub mod options;
pub mod thin;

pub use options::{Diffuse, Evaluator, IsgOptions, OPTIONS, REFINE_ROUNDS};

pub const ENTRY: TechniqueEntry = TechniqueEntry {
    name: "isg",
    summary: "integral spherical Gaussians (Iwasaki et al. 2012): soft shadows from the sphere set and thin shells",
    options: OPTIONS,
    reads: Reads { lights: true, blockers: true, thin: true, geometry: false, env_lights: false },
    tolerances: Tolerances {
        // No blockers: the map diffuse equals `none` exactly (same irradiance grid, no occluded patch).
        furnace: 1e-3,
        unoccluded_vs_none: 1e-5,
        // The patch grid's marking of one cap (tests/tests/isg.rs measures 0.25 % at 32 patches).
        one_sphere: Some(0.01),
        one_plane: Some(0.05),
        samples: 0,
    },
    create: |gpu, o| Ok(Box::new(Isg::new(gpu, IsgOptions::from_options(o))?)),
};

/// `IsgParams` in shaders-glsl/shade/isg/shade.glsl (std430).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuIsgParams {
    /// K: the environment lobes in the `EnvSgs` buffer.
    pub lobe_count: u32,
    /// Patches per side of the visibility grid.
    pub side: u32,
    /// 0 table, 1 paper.
    pub evaluator: u32,
    pub sphere_count: u32,
    /// ln ε.
    pub log_epsilon: f32,
    /// In patch widths.
    pub node_threshold: f32,
    pub cosine_lambda: f32,
    pub cosine_mu: f32,
    /// Angular radius (radians) below which the shared gather of the diffuse lobes takes a BVH node
    /// whole: `threshold` widths of the finest grid any diffuse product lobe can have (its sharpness
    /// is at most max_k λ_k + λ_cos), computed once here instead of per point.
    pub gather_take_whole: f32,
    /// [`diffuse_code`]: 0 sg, 1 ratio, 2 map.
    pub diffuse_mode: u32,
    /// The bounded reach (option `reach`, scene units; 0: off).
    pub reach: f32,
    pub pad1: u32,
}

/// One environment lobe, `EnvLobe` in shade.glsl: G(v) = μ e^{λ(axis·v − 1)}.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuSgLobe {
    pub axis: [f32; 3],
    pub lambda: f32,
    /// RGB amplitude.
    pub mu: [f32; 3],
    pub pad0: f32,
}

struct Prepared {
    env_sgs: Buffer,
    params: Buffer,
    tables: MathTables,
}

pub struct Isg {
    pipelines: TargetPipelines,
    /// The variant with thin shells (`ISG_THIN_SHELLS`), built at the first prepare of a scene with a
    /// thin mesh: scenes without one run shaders with no thin-shell code at all.
    thin_pipelines: Option<TargetPipelines>,
    pub options: IsgOptions,
    prepared: Option<Prepared>,
    /// The blocker tiles of the per-pixel target (`tiles`).
    tiles: BlockerTiles,
}

impl Isg {
    pub fn new(gpu: &Gpu, options: IsgOptions) -> Result<Self> {
        let pipelines = TargetPipelines::with_defines(gpu, "isg", &shader_defines(&options))?;
        let tiles = BlockerTiles::new(options.tiles);
        Ok(Self { pipelines, thin_pipelines: None, options, prepared: None, tiles })
    }

    fn release(&mut self, gpu: &Gpu) {
        if let Some(p) = self.prepared.take() {
            gpu.destroy_buffer(p.env_sgs);
            gpu.destroy_buffer(p.params);
            p.tables.destroy(gpu);
        }
    }
}

impl Technique for Isg {
    fn name(&self) -> &'static str {
        "isg"
    }

    fn prepare(&mut self, gpu: &Gpu, inputs: &ShadeInputs) -> Result<()> {
        self.release(gpu);
        let thin_count = inputs.thin()?.triangle_count;
        if thin_count > 0 && self.thin_pipelines.is_none() {
            let mut defines = shader_defines(&self.options);
            defines.push(("ISG_THIN_SHELLS", "1"));
            self.thin_pipelines = Some(TargetPipelines::with_defines(gpu, "isg", &defines)?);
        }
        // `diffuse=map` reads the prefiltered environment itself: no SG fit.
        let fitted = match self.options.diffuse {
            Diffuse::Map => Vec::new(),
            _ => fit_environment(&inputs.environment.cpu, self.options.k, self.options.refine).0,
        };
        let lobes: Vec<GpuSgLobe> = fitted
            .iter()
            .map(|l| GpuSgLobe {
                axis: l.axis.map(|x| x as f32),
                lambda: l.lambda as f32,
                mu: l.mu.map(|x| x as f32),
                pad0: 0.0,
            })
            .collect();
        let o = &self.options;
        let params = GpuIsgParams {
            lobe_count: lobes.len() as u32,
            side: o.side as u32,
            evaluator: (o.evaluator == Evaluator::Paper) as u32,
            sphere_count: inputs.blockers()?.sphere_count,
            log_epsilon: o.epsilon.ln() as f32,
            node_threshold: o.node_threshold as f32,
            cosine_lambda: COSINE_SG_LAMBDA as f32,
            cosine_mu: COSINE_SG_MU as f32,
            gather_take_whole: gather_take_whole(&fitted, o) as f32,
            diffuse_mode: diffuse_code(o.diffuse),
            reach: o.tiles.reach as f32,
            ..GpuIsgParams::default()
        };
        let [env_sgs, params] = crate::resources::make_buffers(
            gpu,
            [&|| gpu.upload_buffer("isg-env-sgs", BufferDesc::gpu_only(0), &lobes_or_one(&lobes)), &|| {
                gpu.upload_buffer("isg-params", BufferDesc::gpu_only(0), std::slice::from_ref(&params))
            }],
        )?;
        match MathTables::load(gpu, &crate::tables::default_dir(), &[MathTable::IsgLut]) {
            Ok(tables) => {
                self.prepared = Some(Prepared { env_sgs, params, tables });
                Ok(())
            }
            Err(e) => {
                gpu.destroy_buffer(env_sgs);
                gpu.destroy_buffer(params);
                Err(GpuError::Other(e.to_string()))
            }
        }
    }

    fn record(&self, rec: &mut Recorder, inputs: &ShadeInputs, target: ShadeTarget) -> Result<()> {
        let Some(p) = &self.prepared else {
            return Err(GpuError::Other("technique 'isg' recorded before prepare()".into()));
        };
        let lut = p.tables.get(MathTable::IsgLut).ok_or_else(|| GpuError::Other("isg: table not loaded".into()))?;
        let thin = inputs.thin()?;
        let pipelines = match &self.thin_pipelines {
            Some(t) if thin.triangle_count > 0 => t,
            _ if thin.triangle_count > 0 => {
                return Err(GpuError::Other("isg: a scene with thin meshes recorded before prepare()".into()))
            }
            _ => &self.pipelines,
        };
        let env = inputs.environment;
        let o = &self.options;
        let tiles = self.tiles.record(rec, "isg", inputs.blockers()?, &target, sin_take_whole(take_whole_bound(o)))?;
        let [visits, lists] = tiles.bindings()?;
        pipelines.record(
            rec,
            "isg",
            inputs,
            target,
            &[
                visits,
                lists,
                Binding::sampled("prefiltered_env", &env.prefiltered),
                Binding::sampled("irradiance_map", &env.irradiance),
                Binding::buffer("EnvSgs", &p.env_sgs),
                Binding::buffer("IsgTable", &lut.buffer),
                Binding::buffer("BvhNodes", &inputs.blockers()?.bvh_nodes),
                Binding::buffer("BlockerPlanes", &inputs.blockers()?.planes),
                Binding::buffer("IsgParamsBuf", &p.params),
                Binding::buffer("ThinTriangles", &thin.triangles),
                Binding::buffer("ThinClusters", &thin.clusters),
                Binding::buffer("Lights", &inputs.lights()?.buffer),
            ],
        )
    }

    fn tile_counts(&mut self, gpu: &Gpu) -> Result<Option<super::tiles::TileCounts>> {
        self.tiles.counts(gpu).map(Some)
    }

    fn destroy(mut self: Box<Self>, gpu: &Gpu) {
        self.release(gpu);
        std::mem::replace(&mut self.tiles, BlockerTiles::new(Default::default())).destroy(gpu);
        self.pipelines.destroy(gpu);
        if let Some(t) = self.thin_pipelines.take() {
            t.destroy(gpu);
        }
    }
}

/// The environment as K SGs: engine-math's [`engine_math::sg::fit_environment`] with the SG kernel (the
/// greedy fit of a 128×64 resampling, refined by `refine` rounds). Returns the lobes and the fit's error.
pub fn fit_environment(env: &engine_math::envmap::LatLongMap, k: usize, refine: usize) -> (Vec<SgRgb>, f64) {
    engine_math::sg::fit_environment(env, k, refine, engine_math::sg::EnvKernel::Sg)
}

/// The shared gather's node-size threshold (radians): `threshold` patch widths of the finest grid a
/// diffuse product lobe can have. |λ_k a_k + λ_cos n| ≤ λ_k + λ_cos, and the grid narrows as λ grows.
pub fn gather_take_whole(lobes: &[SgRgb], o: &IsgOptions) -> f64 {
    if o.diffuse == Diffuse::Map {
        // One grid over the hemisphere: patches π/P wide.
        return o.node_threshold * std::f64::consts::PI / o.side.clamp(1, 32) as f64;
    }
    let sharpest = lobes.iter().map(|l| l.lambda).fold(0.0, f64::max) + COSINE_SG_LAMBDA;
    o.node_threshold * 2.0 * cpu::limiting_angle(sharpest, o.epsilon) / o.side.clamp(1, 32) as f64
}

/// The shaders' defines: the counter variant's (option `counters`, the cost model; none for the radiance
/// shader) and the blocker tiles' (option `tiles`).
fn shader_defines(o: &IsgOptions) -> Vec<(&'static str, &'static str)> {
    let mut d = match o.counters {
        1 => vec![("ISG_COUNTERS", "1")],
        2 => vec![("ISG_COUNTERS", "2")],
        _ => Vec::new(),
    };
    d.extend(o.tiles.defines());
    d
}

/// The largest half-angle below which any traversal of the shader takes a BVH node whole (the tile lists stop
/// above such nodes): `threshold` patch widths of the widest grid. The hemisphere grid's and a lobe's patches are
/// at most π/P wide (Γ ≤ π/2), a small light's own grid's 2α/8 < π/16 (α < π/4); the shared gather's threshold
/// ([`gather_take_whole`]) is one of those widths.
pub fn take_whole_bound(o: &IsgOptions) -> f64 {
    o.node_threshold * std::f64::consts::PI / o.side.clamp(1, 16) as f64
}

/// The shader's diffuse mode code (`IsgParams::diffuse_mode`).
fn diffuse_code(d: Diffuse) -> u32 {
    match d {
        Diffuse::Sg => 0,
        Diffuse::Ratio => 1,
        Diffuse::Map => 2,
    }
}

/// A storage buffer may not be empty: K ≥ 1 always, but keep one zero lobe if a fit returned none.
fn lobes_or_one(lobes: &[GpuSgLobe]) -> Vec<GpuSgLobe> {
    if lobes.is_empty() {
        vec![GpuSgLobe::default()]
    } else {
        lobes.to_vec()
    }
}
