//! Technique `shexp` (shaders-glsl/shade/shexp): soft shadows by SH exponentiation (Ren et al. 2006).
//!
//! Per receiver: the blockers of a cut of the GPU sphere BVH by subtended angle θ_max (SHEXP Eq. 36),
//! made once per receiver cluster (`cluster=T`, default 16: T×T pixel tiles or spatial groups of at
//! most T² vertices, [`vertex_clusters`]) by the cluster pass (shaders-glsl/shade/shexp/clusters.glsl),
//! each node taken whole scaled by its ratio vector W (Eq. 37–38; `cluster=0`: a cut per receiver, a
//! node taken whole blocking as its bounding sphere), the SHEXP
//! §6.2 rules (`blocker_for_receiver`: spheres behind the tangent plane culled, straddling ones
//! shrunk, receivers inside handled), each blocker's circle log-visibility from the order-n table
//! (`sh{n}_circle_log`, exact small-angle limit, knots at the clip's kinks) rotated to its direction
//! (Eq. 34), summed, exponentiated by HYB (default), OL or PS*-p (Sec. 4). Plane blockers multiply
//! the visibility by the exact order-n projection of their visibility (not a log: the clipped log of
//! a hemisphere-sized circle darkens an upward receiver by 7 % at n = 4): a half-space exactly, a
//! rectangle as a circle of the same solid angle about its cone's mean direction (Arvo's ½ Σ Θ_e n_e).
//! `accumulate=product` is the paper's speed baseline (Fig. 8, after Zhou et al. 2005): every sphere
//! multiplies g by its exact order-n projected visibility through the triple-product tensor Γ, no log and
//! no exponential (order-n truncation at every product, and not associative: the result depends on the
//! BVH's visit order).
//!
//! Shading: diffuse `ρ L·(H(N) * g)` with L the environment's order-n projection windowed by
//! cos(π/2 · l/h) (§7), H(N) the clamped cosine rotated to N (a ZH rotation per receiver, no table);
//! `diffuse=ratio` scales the exact irradiance E(n) by (L·(H*g))/(L·H). Spherical lights: the exact
//! unshadowed term times the SH visibility (C·(H*g))/(C·H), C the windowed SH of the light's cap
//! (a simpler model than the paper's single-lobe L_H(θ, φ) table). Glossy BRDFs: not shadowed by SH;
//! the unshadowed prefiltered glossy term (as `none`) times the diffuse visibility ratio.
//!
//! The order n is a compile-time define (`SHEXP_N`, 3..8) with every table read from device
//! buffers. [`cpu`] is the f64 twin of the per-receiver pipeline.

use super::{Reads, ShadeInputs, ShadeTarget, TargetPipelines, Technique, TechniqueEntry, Tolerances};
use crate::gpu::{Binding, Buffer, BufferDesc, ComputePipeline, Gpu, GpuError, Recorder, Result};
use crate::options::{Kind, OptionSpec, Options};
use crate::tables::MathTables;
use engine_math::sh::{irradiance_weighting_star, project_latlong, Window};
use engine_math::shexp::HYB_DEFAULT_TARGET;
use engine_math::table_gen::MathTable;

pub mod cpu;
pub mod vertex_clusters;

pub const OPTIONS: &[OptionSpec] = &[
    OptionSpec {
        key: "order",
        aliases: &["n"],
        kind: Kind::Int { min: 3, max: 8 },
        default: Some("4"),
        help: "SH order n (n² coefficients; a compile-time define of the shaders)",
    },
    OptionSpec {
        key: "theta_max",
        aliases: &[],
        kind: Kind::closed(0.0, 90.0),
        default: Some("25"),
        help: "BVH cut angle θ_max in degrees (SHEXP Eq. 36): nodes subtending less are taken whole as their bounding sphere (0: leaves only)",
    },
    OptionSpec {
        key: "theta_min",
        aliases: &[],
        kind: Kind::closed(0.0, 90.0),
        default: Some("0"),
        help: "drop tiny blockers (SHEXP §7): a node or sphere subtending a half-angle below θ_min degrees is skipped with its subtree (0: keep all)",
    },
    OptionSpec {
        key: "exp",
        aliases: &[],
        kind: Kind::Choice(&["hyb", "ol", "ps"]),
        default: Some("hyb"),
        help: "SH exponential: hyb (scale, OL, square; paper default), ol (optimal linear) or ps (PS*-p)",
    },
    OptionSpec {
        key: "p",
        aliases: &[],
        kind: Kind::Int { min: 1, max: 8 },
        default: Some("2"),
        help: "degree p of PS*-p (exp=ps)",
    },
    OptionSpec {
        key: "target",
        aliases: &[],
        kind: Kind::Float { min: 0.0, max: 16.0, min_open: true, max_open: false },
        default: Some("0.25"),
        help: "HYB: ‖f̂‖ after scaling by 2^-s (exp=hyb)",
    },
    OptionSpec {
        key: "h",
        aliases: &[],
        kind: Kind::Float { min: 0.0, max: 64.0, min_open: true, max_open: false },
        default: None,
        help: "lighting window cos(π/2 · l/h) (default 2n)",
    },
    OptionSpec {
        key: "diffuse",
        aliases: &[],
        kind: Kind::Choice(&["sh", "ratio"]),
        default: Some("sh"),
        help: "diffuse: sh (ρ L·(H*g), the paper) or ratio (exact E(n) times the SH visibility ratio)",
    },
    OptionSpec {
        key: "large",
        aliases: &[],
        kind: Kind::Choice(&["product", "log"]),
        default: Some("product"),
        help: "spheres past the log's eigenvalue clip (θ > θ_clip): product (ours: multiply g by their exact projected visibility, ≤ 4 per receiver) or log (the paper: add their clipped log)",
    },
    OptionSpec {
        key: "accumulate",
        aliases: &[],
        kind: Kind::Choice(&["log", "product"]),
        default: Some("log"),
        help: "log (the paper: sum the log vectors, one exponential) or product (the baseline of SHEXP Fig. 8, Zhou et al. 2005: multiply g by every sphere's projected visibility with the triple-product tensor; exp, large are then unused)",
    },
    OptionSpec {
        key: "cluster",
        aliases: &[],
        kind: Kind::Int { min: 0, max: 32 },
        default: Some("16"),
        help: "receiver clusters T (SHEXP §6.3): per pixel T×T screen tiles, per vertex spatial groups of at most T² vertices of one instance; one θ_max cut per cluster from its bounding sphere, with ratio vectors W at its central point (0: a cut per receiver, no W; accumulate=log only)",
    },
    OptionSpec {
        key: "ratio_vectors",
        aliases: &[],
        kind: Kind::Choice(&["on", "off"]),
        default: Some("on"),
        help: "with cluster > 0: on (W of Eq. 37 scales each node taken whole) or off (W = 1: nodes block as their bounding spheres, SHEXP Fig. 6b)",
    },
    OptionSpec {
        key: "alpha_scale",
        aliases: &[],
        kind: Kind::Choice(&["on", "off"]),
        default: Some("on"),
        help: "on: the paper's radius scale α for spheres straddling the tangent plane (§6.2, our reading: the blocker grows from the inside rule's on the sphere to S' at twice the circle's radius), removing the jump as a receiver leaves a sphere; off: the rule without α that the reference and isg use",
    },
    OptionSpec {
        key: "bake",
        aliases: &[],
        kind: Kind::Choice(&["off", "on"]),
        default: Some("off"),
        help: "on (§7, static receivers keep their visibility): a receiver (vertex, or pixel up to 256 MiB of records) that has not moved, in a cluster whose cut (spheres and W) equals the last frame's, reuses its last visibility vector g instead of accumulating and exponentiating again (the same g, so the same image); off: every receiver every frame, so that timings measure the whole computation",
    },
    OptionSpec {
        key: "vertex_clusters",
        aliases: &[],
        kind: Kind::Choice(&["kd", "lloyd"]),
        default: Some("kd"),
        help: "how the vertex clusters are made (per vertex, and per pixel with pixel_clusters=world): kd (median splits, at most T² vertices and 1/8 of the scene's diagonal a side) or lloyd (the same, then up to 10 Lloyd iterations, the paper's clustering, re-split to the same bounds)",
    },
    OptionSpec {
        key: "pixel_clusters",
        aliases: &[],
        kind: Kind::Choice(&["tiles", "world"]),
        default: Some("tiles"),
        help: "per-pixel receiver clusters (cluster > 0): tiles (T×T screen tiles) or world (the per-vertex clusters: a pixel joins its triangle's first vertex's cluster, whose bounding sphere grows to hold the cluster's triangles)",
    },
    OptionSpec {
        key: "phase",
        aliases: &[],
        kind: Kind::Choice(&PHASES),
        default: Some("all"),
        help: "cost split (a timing variant, its image is not the technique's): every receiver stops after visit (the cut list walked, the §6.2 rules and each blocker's angle), logs (+ the circle logs summed), exp (+ the exponential and the planes) or all (+ the shading and the lights)",
    },
    super::env_lights_option("on"),
    super::tiles::TILES_OPTION,
    super::tiles::TILE_CAP_OPTION,
    super::tiles::TILE_LOD_OPTION,
    super::tiles::REACH_OPTION,
];

/// The values of option `phase`, in order: phase k (1-based) is `SHEXP_PHASE` k in shade.glsl.
pub const PHASES: [&str; 4] = ["visit", "logs", "exp", "all"];

pub const ENTRY: TechniqueEntry = TechniqueEntry {
    name: "shexp",
    summary: "SH exponentiation (Ren et al. 2006): log-space sphere blockers, HYB/OL/PS* exp; diffuse only, glossy = unshadowed lobe × diffuse visibility ratio",
    options: OPTIONS,
    reads: Reads { lights: true, blockers: true, thin: false, geometry: true, env_lights: false },
    // Measured by tests/tests/techniques.rs at the defaults (order 4, HYB): furnace 4.65e-4 (the f32
    // projection of a constant map), no blockers vs `none` 2.89e-3 (the windowed order-4 lighting on
    // the sphere scene's smooth sky), one sphere 0.378 %, the ball above a half-space 0.023 % and above
    // a rectangle 0.058 % (plane visibility multiplied as its exact projection). Bounds: the
    // measurement with margin.
    tolerances: Tolerances {
        furnace: 1e-3,
        unoccluded_vs_none: 5e-3,
        one_sphere: Some(0.01),
        one_plane: Some(0.005),
        samples: 0,
    },
    create: |gpu, o| Ok(Box::new(Shexp::new(gpu, ShexpOptions::from_options(o))?)),
};

/// Which SH exponential.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ExpChoice {
    Hyb,
    Ol,
    PsStar,
}

/// The typed options (see [`OPTIONS`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ShexpOptions {
    pub order: usize,
    pub theta_max_deg: f64,
    /// `theta_min`: blockers subtending a half-angle below this (degrees) are dropped.
    pub theta_min_deg: f64,
    pub exp: ExpChoice,
    pub ps_degree: usize,
    pub hyb_target: f64,
    /// The window's h (`None`: 2n).
    pub window_h: Option<f64>,
    /// `diffuse=ratio`.
    pub ratio: bool,
    /// `large=product`: spheres subtending more than the clip's first kink multiply g by their
    /// projected visibility (at most 4 per receiver) instead of adding their clipped log.
    pub large_product: bool,
    /// `accumulate=product`: every sphere multiplies g (the product baseline) instead of adding its log.
    pub accumulate_product: bool,
    /// `cluster`: receiver clusters of T×T pixels or T² vertices (0: a cut per receiver).
    pub cluster: u32,
    /// `ratio_vectors=on`: the clusters' nodes taken whole are scaled by W (Eq. 37–38).
    pub ratio_vectors: bool,
    /// `vertex_clusters=lloyd`: the k-d partition refined by Lloyd iterations.
    pub lloyd: bool,
    /// `bake=on`: unchanged clusters' unmoved receivers reuse their last visibility.
    pub bake: bool,
    /// `alpha_scale=on`: the §6.2 rule with the radius scale α (`geom::blocker_for_receiver_alpha`).
    pub alpha_scale: bool,
    /// `pixel_clusters=world`: per pixel, the clusters are the per-vertex ones (by each triangle's first
    /// vertex) instead of screen tiles.
    pub world_pixel_clusters: bool,
    /// The cost split (option `phase`, a timing variant): 1 visit the blockers, 2 + their logs, 3 + the
    /// exponential, 4 everything (`SHEXP_PHASE` in shade.glsl).
    pub phase: u32,
    /// The blocker tiles (`tiles`, `tile_cap`): the start lists of the per-receiver cuts per pixel.
    pub tiles: super::tiles::TileOptions,
}

impl Default for ShexpOptions {
    fn default() -> Self {
        Self {
            order: 4,
            theta_max_deg: 25.0,
            theta_min_deg: 0.0,
            exp: ExpChoice::Hyb,
            ps_degree: 2,
            hyb_target: HYB_DEFAULT_TARGET,
            window_h: None,
            ratio: false,
            large_product: true,
            accumulate_product: false,
            cluster: 16,
            ratio_vectors: true,
            alpha_scale: true,
            lloyd: false,
            bake: false,
            world_pixel_clusters: false,
            phase: 4,
            tiles: Default::default(),
        }
    }
}

/// The keys' joint rules: `theta_min` drops blockers subtending less than it, `theta_max` takes nodes subtending
/// less than it whole. With θ_min ≥ θ_max > 0 every node small enough to be taken whole is dropped instead (no
/// blocker is left below θ_min); θ_min = 90° drops every blocker. Both were accepted and rendered no shadow.
pub fn check_options(o: &Options) -> std::result::Result<(), String> {
    let (min, max) = (o.float("theta_min"), o.float("theta_max"));
    if min >= 90.0 {
        return Err(format!("theta_min={min} drops every blocker (it must be below 90)"));
    }
    if max > 0.0 && min >= max {
        return Err(format!(
            "theta_min={min} is not below theta_max={max}: every node the θ_max cut takes whole would be dropped \
             (theta_max=0 cuts to the leaves, where any theta_min below 90 applies)"
        ));
    }
    Ok(())
}

impl ShexpOptions {
    pub fn from_options(o: &Options) -> Self {
        Self {
            order: o.int("order") as usize,
            theta_max_deg: o.float("theta_max"),
            theta_min_deg: o.float("theta_min"),
            exp: match o.choice("exp") {
                "ol" => ExpChoice::Ol,
                "ps" => ExpChoice::PsStar,
                _ => ExpChoice::Hyb,
            },
            ps_degree: o.int("p") as usize,
            hyb_target: o.float("target"),
            window_h: o.float_if_given("h"),
            ratio: o.choice("diffuse") == "ratio",
            large_product: o.choice("large") == "product",
            accumulate_product: o.choice("accumulate") == "product",
            cluster: o.int("cluster") as u32,
            ratio_vectors: o.choice("ratio_vectors") == "on",
            alpha_scale: o.choice("alpha_scale") == "on",
            lloyd: o.choice("vertex_clusters") == "lloyd",
            bake: o.choice("bake") == "on",
            world_pixel_clusters: o.choice("pixel_clusters") == "world",
            phase: PHASES.iter().position(|p| *p == o.choice("phase")).map_or(4, |k| k as u32 + 1),
            tiles: super::tiles::TileOptions::from_options(o),
        }
    }

    /// The lighting window (§7: cos(π/2 · l/h), h = 2n by default).
    pub fn window(&self) -> Window {
        Window::Cosine { h: self.window_h.unwrap_or(2.0 * self.order as f64) }
    }

    /// The cluster side in use: `cluster`, or 0 with `accumulate=product` (the product baseline has no
    /// log to scale, so it always cuts per receiver).
    pub fn cluster_side(&self) -> u32 {
        if self.accumulate_product {
            0
        } else {
            self.cluster
        }
    }
}

/// `ShexpParams` in shaders-glsl/shade/shexp/shade.glsl (std430).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuShexpParams {
    pub sphere_count: u32,
    pub sin_theta_max: f32,
    /// 0 hyb, 1 ol, 2 ps*.
    pub exp_method: u32,
    pub ps_degree: i32,
    pub hyb_target: f32,
    pub ol_norm_max: f32,
    pub gamma_count: u32,
    /// 0 sh, 1 ratio.
    pub diffuse_mode: u32,
    /// `u = 1 − cos θ` above which a sphere multiplies its projected visibility (`large=product`; 2: never).
    pub large_u: f32,
    /// 0 log, 1 product (`accumulate`).
    pub accumulate: u32,
    /// sin θ_min (`theta_min`; 0: keep every blocker).
    pub sin_theta_min: f32,
    /// Receiver clusters: the tile side T (0: a cut per receiver).
    pub cluster: u32,
    /// 1: ratio vectors W (Eq. 37); 0: W = 1.
    pub ratio_vectors: u32,
    /// Receiver clusters of the per-vertex target ([`vertex_clusters`]).
    pub vertex_clusters: u32,
    /// 1: per pixel, the vertex clusters (`pixel_clusters=world`; the cluster pass then grows each bounding
    /// sphere by the cluster's [`vertex_clusters::pixel_reach`]).
    pub pixel_world: u32,
    /// 1: the §6.2 rule with the radius scale α (`alpha_scale=on`).
    pub alpha_scale: u32,
    /// 1: reuse the visibility of unmoved receivers of unchanged clusters (`bake=on`; per pixel only where
    /// the records fit, which the shader checks against the records buffer's length).
    pub bake: u32,
    /// The bounded reach (option `reach`, scene units; 0: off).
    pub reach: f32,
    pub pad: [u32; 2],
    pub h_star: [f32; 8],
    pub window: [f32; 8],
}

struct Prepared {
    params: Buffer,
    env_sh: Buffer,
    tables: MathTables,
    /// The vertex clusters ([`vertex_clusters::VertexClusters`]): offsets, items, cluster of each vertex,
    /// and each cluster's pixel reach (one zero each without clusters, so the bindings are valid), and
    /// their count.
    vertex_clusters: [Buffer; 4],
    vertex_cluster_count: u32,
}

/// The vertex clusters of a scene and each cluster's pixel reach ([`scene_clusters`]).
pub type SceneClusters = (vertex_clusters::VertexClusters, Vec<f32>);

/// `pixel_clusters=world`: the G-buffer stores a triangle's first vertex index as an f32, exact up to 2²⁴.
pub const MAX_WORLD_PIXEL_VERTICES: u32 = 1 << 24;

/// `pixel_clusters=world` refuses a scene of more than [`MAX_WORLD_PIXEL_VERTICES`] vertices (their indices
/// would round in the G-buffer), with a message that names the way out.
pub fn check_world_pixel_vertices(o: &ShexpOptions, vertex_count: u32) -> Result<()> {
    if o.world_pixel_clusters && vertex_count > MAX_WORLD_PIXEL_VERTICES {
        return Err(crate::input::SceneInputError(format!(
            "shexp: pixel_clusters=world needs at most {MAX_WORLD_PIXEL_VERTICES} vertices (the G-buffer holds a \
             triangle's first vertex as a float); this scene has {vertex_count}: use pixel_clusters=tiles"
        ))
        .into());
    }
    Ok(())
}

/// The vertex clusters of `geometry` at most `max_size` each ([`vertex_clusters::scene_partition`] of its
/// vertices under the instances' current transforms, both read back; Lloyd-refined when `lloyd`) and their
/// pixel reach ([`vertex_clusters::pixel_reach`]): what the technique uses, for tests to check against.
pub fn scene_clusters(
    gpu: &Gpu,
    geometry: &crate::resources::Geometry,
    max_size: usize,
    lloyd: bool,
) -> Result<SceneClusters> {
    let mut v: Vec<crate::resources::layout::GpuVertex> = gpu.read_buffer(&geometry.vertices)?;
    v.truncate(geometry.vertex_count as usize);
    let objects: Vec<crate::resources::layout::GpuObject> = gpu.read_buffer(&geometry.objects)?;
    let models: Vec<[f32; 16]> = objects.iter().map(|o| o.model).collect();
    let mut indices: Vec<u32> = gpu.read_buffer(&geometry.indices)?;
    indices.truncate(geometry.index_count as usize);
    let points: Vec<([f32; 3], u32)> = v.iter().map(|x| (x.position, x.instance.max(0.0) as u32)).collect();
    let world = vertex_clusters::world_positions(&points, &models);
    let c = vertex_clusters::scene_partition(&world, max_size, lloyd);
    let reach = vertex_clusters::pixel_reach(&world, &indices, &c);
    Ok((c, reach))
}

/// Floats of a receiver's `bake=on` record past its n² visibility coefficients: the blockers counted, the
/// position and the shading normal (`SHEXP_BAKE_STRIDE` in bindings.glsl).
pub const BAKE_EXTRA: usize = 7;

/// `bake=on` per pixel keeps records only while they take at most this much device memory (n = 4 at
/// 1920×1080 needs 182 MiB; n = 8 at that size would need 562 MiB and is not baked).
pub const MAX_BAKE_BYTES: u64 = 256 << 20;

/// `SHEXP_CLUSTER_CAP` of shaders-glsl/shade/shexp/bindings.glsl: cut entries per receiver cluster.
pub const CLUSTER_CAP: u32 = 512;
/// `SHEXP_CLUSTER_COARSEN` of bindings.glsl: a cluster's cut past [`CLUSTER_CAP`] is retried this many times at
/// most, each with sin θ_max doubled (capped at 1), before its receivers cut per point.
pub const CLUSTER_COARSEN: u32 = 4;
/// Entries in the shared pool per cluster: the number of blocker spheres (no cut is longer), at most this
/// (then the clusters' average cut may be this long, one cluster's up to [`CLUSTER_CAP`]).
pub const CLUSTER_POOL_AVERAGE: u32 = 256;
/// Bytes of one `ClusterEntry` (sphere, w_lo, w_hi).
const CLUSTER_ENTRY_BYTES: u64 = 48;
/// The most device memory the cut lists may take (T = 16 at 1920×1080 needs at most 96 MiB, T = 8 384 MiB).
const MAX_CLUSTER_BYTES: u64 = 1 << 30;
/// Workgroups per row of the cluster dispatch (`SHEXP_CLUSTERS_PER_ROW` in clusters.glsl): the dispatch is
/// 2D so that a million clusters stay within the device's 65,535 workgroups per dimension.
const CLUSTERS_PER_ROW: u32 = 1024;

/// The receiver clusters of `target` at side `t` (T×T pixel tiles; for vertices, blocks of T² as an upper
/// bound: the technique uses its spatial [`vertex_clusters`]); 0 for `t = 0`.
pub fn cluster_count(target: &ShadeTarget, t: u32) -> u32 {
    if t == 0 {
        return 0;
    }
    match target {
        ShadeTarget::Pixel { radiance, .. } => radiance.desc.width.div_ceil(t) * radiance.desc.height.div_ceil(t),
        ShadeTarget::Vertex { count, .. } => count.div_ceil(t * t),
    }
}

/// The cluster pass's work counts since the last [`Technique::report`] (twin of `shexp_stats` in
/// bindings.glsl).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ClusterStats {
    /// Cluster-pass dispatches (frames shaded with clusters).
    pub frames: u64,
    /// Of them, frames with `bake=on` records for their receivers.
    pub bake_frames: u64,
    /// Clusters holding at least one receiver, summed over the frames.
    pub clusters: u64,
    /// Cut entries (leaves and nodes taken whole), summed.
    pub entries: u64,
    /// The largest cut of one cluster.
    pub max_entries: u64,
    /// Clusters whose cut exceeded [`CLUSTER_CAP`] (their receivers then cut per point).
    pub overflowed: u64,
    /// Entries that were nodes taken whole (scaled by W).
    pub whole: u64,
    /// Clusters the shared pool could not hold (their receivers then cut per point).
    pub pool_exhausted: u64,
    /// Clusters whose cut equalled the last frame's (`bake=on`: their unmoved receivers reused their visibility).
    pub unchanged: u64,
}

impl ClusterStats {
    /// The work line printed by `demo` and `compare`.
    pub fn line(&self) -> Option<String> {
        (self.clusters > 0).then(|| {
            format!(
                "shexp: {:.0} receiver clusters per frame, {:.1} cut spheres per cluster (max {}), {:.1} % of them \
                 nodes taken whole with ratio vectors; {} clusters over {CLUSTER_CAP} entries and {} past the pool \
                 cut per receiver instead{}",
                self.clusters as f64 / self.frames.max(1) as f64,
                self.entries as f64 / self.clusters as f64,
                self.max_entries,
                100.0 * self.whole as f64 / self.entries.max(1) as f64,
                self.overflowed,
                self.pool_exhausted,
                if self.bake_frames > 0 {
                    format!(
                        "; {:.1} % of the clusters unchanged since the frame before (bake: their unmoved \
                         receivers kept their visibility)",
                        100.0 * self.unchanged as f64 / self.clusters as f64
                    )
                } else {
                    String::new()
                }
            )
        })
    }
}

/// The cluster heads, the pool of cut entries and its use counter, and the cuts' hashes (`bake=on`), for up
/// to `capacity` clusters.
struct ClusterBuffers {
    heads: Buffer,
    cut: Buffer,
    pool: Buffer,
    hashes: Buffer,
    capacity: u32,
    /// Entries the pool holds.
    entries: u64,
}

pub struct Shexp {
    pipelines: TargetPipelines,
    /// The receiver-cluster pass, per pixel and per vertex, created on first use.
    cluster_pixel: std::cell::OnceCell<ComputePipeline>,
    cluster_vertex: std::cell::OnceCell<ComputePipeline>,
    /// Every cluster-buffer pair made so far (the last is the largest and in use; the others stay alive until
    /// destroy, as an earlier frame may still read them). A steady frame allocates nothing.
    clusters: std::cell::RefCell<Vec<ClusterBuffers>>,
    stats: Option<Buffer>,
    frames: std::cell::Cell<u64>,
    /// Of them, frames with `bake=on` records (whose cuts were compared with the last frame's).
    bake_frames: std::cell::Cell<u64>,
    /// `bake=on`: the receivers' visibility records ([`BAKE_EXTRA`] + n² floats each) and how many
    /// receivers they hold (the last is the largest and in use); made on the first frame, kept until destroy.
    baked: std::cell::RefCell<Vec<(u32, Buffer)>>,
    /// The vertex clusters and their pixel reach, keyed by (vertex count, largest cluster), computed on the
    /// first `prepare`.
    partition: Option<((u32, usize), SceneClusters)>,
    pub options: ShexpOptions,
    prepared: Option<Prepared>,
    /// The blocker tiles of the per-pixel target (`tiles`): the start lists of the per-receiver cuts.
    tiles: super::tiles::BlockerTiles,
}

/// The three tables of order `n`.
pub fn tables_of(n: usize) -> [MathTable; 3] {
    [MathTable::ShGamma(n), MathTable::ShOl(n), MathTable::ShCircleLog(n)]
}

/// The windowed order-n projection of the environment, one `vec4` (RGB, 0) per coefficient.
pub fn environment_sh(env: &engine_math::envmap::LatLongMap, o: &ShexpOptions) -> Vec<[f32; 4]> {
    let [r, g, b] = project_latlong(env, o.order, o.window());
    (0..o.order * o.order).map(|i| [r[i] as f32, g[i] as f32, b[i] as f32, 0.0]).collect()
}

/// `u = 1 − cos θ_clip` (the first kink of the eigenvalue clip) for `large=product`, 2 (never) for
/// `large=log` or an order without a kink up to π/2.
pub fn large_u(o: &ShexpOptions) -> f64 {
    if !o.large_product {
        return 2.0;
    }
    let t = engine_math::sh::ShTensor::new(o.order);
    engine_math::sh::circle_clip_kinks(&t).first().map(|&k| engine_math::sh::one_minus_cos(k)).unwrap_or(2.0)
}

/// The parameter block for `o`, with the OL table's range and the Γ table's size from their headers.
pub fn params(o: &ShexpOptions, sphere_count: u32, ol_norm_max: f64, gamma_count: u32) -> GpuShexpParams {
    let mut h_star = [0f32; 8];
    for (l, v) in irradiance_weighting_star(o.order).iter().enumerate() {
        h_star[l] = *v as f32;
    }
    let mut window = [0f32; 8];
    for (l, v) in o.window().band_factors(o.order).iter().enumerate() {
        window[l] = *v as f32;
    }
    GpuShexpParams {
        sphere_count,
        sin_theta_max: o.theta_max_deg.to_radians().sin() as f32,
        exp_method: match o.exp {
            ExpChoice::Hyb => 0,
            ExpChoice::Ol => 1,
            ExpChoice::PsStar => 2,
        },
        ps_degree: o.ps_degree as i32,
        hyb_target: o.hyb_target as f32,
        ol_norm_max: ol_norm_max as f32,
        gamma_count,
        diffuse_mode: o.ratio as u32,
        large_u: large_u(o) as f32,
        accumulate: o.accumulate_product as u32,
        sin_theta_min: o.theta_min_deg.to_radians().sin() as f32,
        cluster: o.cluster_side(),
        ratio_vectors: o.ratio_vectors as u32,
        vertex_clusters: 0,
        pixel_world: o.world_pixel_clusters as u32,
        alpha_scale: o.alpha_scale as u32,
        bake: (o.bake && o.cluster_side() > 0) as u32,
        reach: o.tiles.reach as f32,
        pad: [0; 2],
        h_star,
        window,
    }
}

impl Shexp {
    pub fn new(gpu: &Gpu, options: ShexpOptions) -> Result<Self> {
        let (n, phase) = (options.order.to_string(), options.phase.to_string());
        let defines = [("SHEXP_N", n.as_str()), ("SHEXP_PHASE", phase.as_str())];
        let mut shade_defines = defines.to_vec();
        shade_defines.extend(options.tiles.defines());
        let pipelines = TargetPipelines::with_defines(gpu, "shexp", &shade_defines)?;
        if options.cluster_side() > 0 {
            for target in ["pixel", "vertex"] {
                gpu.compile_compute_shader(&format!("shade/shexp/clusters_{target}.comp"), &defines)?;
            }
        }
        Ok(Self {
            pipelines,
            cluster_pixel: std::cell::OnceCell::new(),
            cluster_vertex: std::cell::OnceCell::new(),
            clusters: std::cell::RefCell::new(Vec::new()),
            stats: None,
            frames: std::cell::Cell::new(0),
            bake_frames: std::cell::Cell::new(0),
            baked: std::cell::RefCell::new(Vec::new()),
            partition: None,
            tiles: super::tiles::BlockerTiles::new(options.tiles),
            options,
            prepared: None,
        })
    }

    fn release(&mut self, gpu: &Gpu) {
        if let Some(p) = self.prepared.take() {
            gpu.destroy_buffer(p.params);
            gpu.destroy_buffer(p.env_sh);
            for b in p.vertex_clusters {
                gpu.destroy_buffer(b);
            }
            p.tables.destroy(gpu);
        }
    }

    /// The vertex clusters of the scene ([`vertex_clusters::scene_partition`] of the vertices read back once
    /// from the static vertex buffer, under the instances' transforms of this first `prepare`), at most
    /// `max_size` each, with their pixel reach. Kept across `prepare`s for the technique's life (a technique
    /// serves one renderer, whose object-space vertices never change). An environment turn makes a new
    /// technique (`Renderer::set_environment_rotation`, every frame under `--env-spin`), which partitions
    /// again, and loses the `bake=on` records with it.
    fn vertex_clusters(&mut self, gpu: &Gpu, inputs: &ShadeInputs, max_size: usize) -> Result<SceneClusters> {
        let geometry = inputs.geometry()?;
        let key = (geometry.vertex_count, max_size);
        if let Some((k, c)) = &self.partition {
            if *k == key {
                return Ok(c.clone());
            }
        }
        let c = scene_clusters(gpu, geometry, max_size, self.options.lloyd)?;
        self.partition = Some((key, c.clone()));
        Ok(c)
    }

    /// The cluster pass for the target, created on first use.
    fn cluster_pipeline(&self, gpu: &Gpu, per_vertex: bool) -> Result<&ComputePipeline> {
        let (cell, target) = if per_vertex { (&self.cluster_vertex, "vertex") } else { (&self.cluster_pixel, "pixel") };
        if cell.get().is_none() {
            let n = self.options.order.to_string();
            let p = gpu
                .create_compute_pipeline(&format!("shade/shexp/clusters_{target}.comp"), &[("SHEXP_N", n.as_str())])?;
            if let Err(p) = cell.set(p) {
                gpu.destroy_compute_pipeline(p);
            }
        }
        cell.get().ok_or_else(|| GpuError::Other("internal: shexp cluster pipeline missing".into()))
    }

    /// Cluster buffers for at least `count` clusters over `spheres` blocker spheres (at least one cluster:
    /// the shade pass always binds them).
    fn ensure_cluster_buffers(&self, gpu: &Gpu, count: u32, spheres: u32) -> Result<()> {
        let capacity = count.max(1);
        let entries = (spheres.clamp(1, CLUSTER_POOL_AVERAGE) as u64 * capacity as u64).max(CLUSTER_CAP as u64);
        let mut all = self.clusters.borrow_mut();
        if all.last().is_some_and(|b| b.capacity >= capacity && b.entries >= entries) {
            return Ok(());
        }
        let bytes = CLUSTER_ENTRY_BYTES * entries;
        if bytes > MAX_CLUSTER_BYTES {
            return Err(crate::options::OptionError(format!(
                "shexp: {capacity} receiver clusters would need {} MiB of cut lists (at most {} MiB): use a larger \
                 cluster=T",
                bytes >> 20,
                MAX_CLUSTER_BYTES >> 20
            ))
            .into());
        }
        let zeros = vec![[0u32; 2]; capacity as usize];
        let [heads, cut, pool, hashes] = crate::resources::make_buffers(
            gpu,
            [
                &|| gpu.create_buffer("shexp-cluster-heads", BufferDesc::gpu_only(16 * capacity as u64)),
                &|| gpu.create_buffer("shexp-cluster-cut", BufferDesc::gpu_only(bytes)),
                &|| gpu.create_buffer("shexp-cluster-pool", BufferDesc::gpu_only(16)),
                &|| gpu.upload_buffer("shexp-cluster-hashes", BufferDesc::gpu_only(0), &zeros),
            ],
        )?;
        all.push(ClusterBuffers { heads, cut, pool, hashes, capacity, entries });
        Ok(())
    }

    /// How many receivers of `target` keep `bake=on` records: every vertex, or every pixel while their
    /// records fit in [`MAX_BAKE_BYTES`]; 0 with `bake=off`, without clusters, or past the budget.
    fn bake_records(&self, target: &ShadeTarget) -> u32 {
        if !self.options.bake || self.options.cluster_side() == 0 {
            return 0;
        }
        let receivers = match target {
            ShadeTarget::Vertex { count, .. } => return *count,
            ShadeTarget::Pixel { radiance, .. } => radiance.desc.width as u64 * radiance.desc.height as u64,
        };
        let bytes = 4 * (self.options.order * self.options.order + BAKE_EXTRA) as u64 * receivers;
        if bytes <= MAX_BAKE_BYTES {
            receivers as u32
        } else {
            0
        }
    }

    /// The `bake=on` records for at least `receivers` receivers (one record without: the shade pass binds them
    /// either way), zeroed when made. A zero record is never reused even in a cluster marked unchanged: its
    /// normal (0, 0, 0) matches no receiver's unit shading normal. Earlier, smaller ones stay alive until
    /// destroy (an earlier frame may still read them).
    fn ensure_baked(&self, gpu: &Gpu, receivers: u32) -> Result<()> {
        let mut all = self.baked.borrow_mut();
        if all.last().is_some_and(|(n, _)| *n >= receivers.max(1)) {
            return Ok(());
        }
        let stride = self.options.order * self.options.order + BAKE_EXTRA;
        let floats = stride * receivers.max(1) as usize;
        let buffer = gpu.upload_buffer("shexp-baked", BufferDesc::gpu_only(0), &vec![0f32; floats])?;
        all.push((receivers.max(1), buffer));
        Ok(())
    }

    /// The cluster pass's counts since the last reset.
    pub fn cluster_stats(&self, gpu: &Gpu) -> Result<ClusterStats> {
        let Some(b) = &self.stats else { return Ok(ClusterStats::default()) };
        let v: Vec<u32> = gpu.read_buffer(b)?;
        let g = |i: usize| v.get(i).copied().unwrap_or(0) as u64;
        Ok(ClusterStats {
            frames: self.frames.get(),
            bake_frames: self.bake_frames.get(),
            clusters: g(0),
            entries: g(1),
            max_entries: g(2),
            overflowed: g(3),
            whole: g(4),
            pool_exhausted: g(5),
            unchanged: g(6),
        })
    }

    fn reset_cluster_stats(&self, gpu: &Gpu) -> Result<()> {
        self.frames.set(0);
        self.bake_frames.set(0);
        match &self.stats {
            Some(b) => gpu.copy_to_buffer(b, bytemuck::cast_slice(&[0u32; 8])),
            None => Ok(()),
        }
    }
}

impl Technique for Shexp {
    fn name(&self) -> &'static str {
        "shexp"
    }

    /// The receiver clusters' work line (`cluster` > 0) since the last call (then the counters restart).
    fn report(&mut self, gpu: &Gpu) -> Result<super::TechniqueReport> {
        let s = self.cluster_stats(gpu)?;
        self.reset_cluster_stats(gpu)?;
        Ok(super::TechniqueReport { warnings: Vec::new(), counts: s.line().into_iter().collect() })
    }

    fn prepare(&mut self, gpu: &Gpu, inputs: &ShadeInputs) -> Result<()> {
        self.release(gpu);
        if self.stats.is_none() {
            self.stats = Some(gpu.upload_buffer("shexp-stats", BufferDesc::gpu_only(0), &[0u32; 8])?);
        }
        let o = self.options.clone();
        let o = &o;
        check_world_pixel_vertices(o, inputs.geometry()?.vertex_count)?;
        let tables = MathTables::load(gpu, &crate::tables::default_dir(), &tables_of(o.order))
            .map_err(|e| GpuError::Other(e.to_string()))?;
        let ol = tables.get(MathTable::ShOl(o.order)).map(|t| t.header.axes[0].hi).unwrap_or(0.0);
        let gamma = tables.get(MathTable::ShGamma(o.order)).map(|t| t.header.entry_count() as u32).unwrap_or(0);
        let (clusters, reach) = match o.cluster_side() {
            0 => (vertex_clusters::VertexClusters { offsets: vec![0], items: vec![0], cluster_of: vec![0] }, vec![0.0]),
            t => match self.vertex_clusters(gpu, inputs, (t * t) as usize) {
                Ok(c) => c,
                Err(e) => {
                    tables.destroy(gpu);
                    return Err(e);
                }
            },
        };
        let mut p = params(o, inputs.blockers()?.sphere_count, ol, gamma);
        p.vertex_clusters = clusters.count() as u32;
        let env = environment_sh(&inputs.environment.cpu, o);
        let nonempty = |v: &[u32]| if v.is_empty() { vec![0u32] } else { v.to_vec() };
        let made = crate::resources::make_buffers(
            gpu,
            [
                &|| gpu.upload_buffer("shexp-params", BufferDesc::gpu_only(0), std::slice::from_ref(&p)),
                &|| gpu.upload_buffer("shexp-env-sh", BufferDesc::gpu_only(0), &env),
                &|| gpu.upload_buffer("shexp-vertex-cluster-offsets", BufferDesc::gpu_only(0), &clusters.offsets),
                &|| {
                    gpu.upload_buffer("shexp-vertex-cluster-items", BufferDesc::gpu_only(0), &nonempty(&clusters.items))
                },
                &|| {
                    gpu.upload_buffer(
                        "shexp-vertex-cluster-of",
                        BufferDesc::gpu_only(0),
                        &nonempty(&clusters.cluster_of),
                    )
                },
                &|| {
                    let reach = if reach.is_empty() { vec![0.0] } else { reach.clone() };
                    gpu.upload_buffer("shexp-vertex-cluster-reach", BufferDesc::gpu_only(0), &reach)
                },
            ],
        );
        match made {
            Ok([params, env_sh, offsets, items, cluster_of, reach]) => {
                self.prepared = Some(Prepared {
                    params,
                    env_sh,
                    tables,
                    vertex_clusters: [offsets, items, cluster_of, reach],
                    vertex_cluster_count: p.vertex_clusters,
                });
                Ok(())
            }
            Err(e) => {
                tables.destroy(gpu);
                Err(e)
            }
        }
    }

    fn record(&self, rec: &mut Recorder, inputs: &ShadeInputs, target: ShadeTarget) -> Result<()> {
        let Some(p) = &self.prepared else {
            return Err(GpuError::Other("technique 'shexp' recorded before prepare()".into()));
        };
        let n = self.options.order;
        let table = |t: MathTable| {
            p.tables
                .get(t)
                .map(|g| &g.buffer)
                .ok_or_else(|| GpuError::Other(format!("shexp: table {} not loaded", t.name())))
        };
        let env = inputs.environment;
        let blockers = inputs.blockers()?;
        let stats = self.stats.as_ref().ok_or_else(|| GpuError::Other("shexp: stats missing".into()))?;
        let side = self.options.cluster_side();
        let world = self.options.world_pixel_clusters;
        let clusters = match target {
            ShadeTarget::Vertex { .. } if side > 0 => p.vertex_cluster_count,
            ShadeTarget::Pixel { .. } if side > 0 && world => p.vertex_cluster_count,
            _ => cluster_count(&target, side),
        };
        self.ensure_cluster_buffers(rec.gpu(), clusters, blockers.sphere_count)?;
        let all = self.clusters.borrow();
        let cb = all.last().ok_or_else(|| GpuError::Other("internal: shexp cluster buffers missing".into()))?;
        if clusters > 0 && blockers.sphere_count > 0 {
            let mut b = vec![
                Binding::buffer("FrameBuf", inputs.frame),
                Binding::buffer("BvhNodes", &blockers.bvh_nodes),
                Binding::buffer("ShCircle", table(MathTable::ShCircleLog(n))?),
                Binding::buffer("ShexpParamsBuf", &p.params),
                Binding::buffer("ClusterHeads", &cb.heads),
                Binding::buffer("ClusterCut", &cb.cut),
                Binding::buffer("ClusterPool", &cb.pool),
                Binding::buffer("ShexpStats", stats),
                Binding::buffer("VertexClusterOffsets", &p.vertex_clusters[0]),
                Binding::buffer("VertexClusterItems", &p.vertex_clusters[1]),
                Binding::buffer("VertexClusterReach", &p.vertex_clusters[3]),
                Binding::buffer("ClusterHashes", &cb.hashes),
            ];
            let per_vertex = match target {
                ShadeTarget::Pixel { .. } if world => {
                    rec.begin_pass("shade/shexp clusters (world)");
                    b.push(Binding::buffer("WorldVertices", &inputs.geometry()?.world_vertices));
                    true
                }
                ShadeTarget::Pixel { gbuffer, .. } => {
                    rec.begin_pass("shade/shexp clusters");
                    b.push(Binding::storage_image("gbuf_position", &gbuffer.position));
                    false
                }
                ShadeTarget::Vertex { world_vertices, .. } => {
                    rec.begin_pass("shade/shexp clusters (per vertex)");
                    b.push(Binding::buffer("WorldVertices", world_vertices));
                    true
                }
            };
            rec.fill_buffer(&cb.pool, 0);
            rec.barrier();
            let pipeline = self.cluster_pipeline(rec.gpu(), per_vertex)?;
            let rows = clusters.div_ceil(CLUSTERS_PER_ROW);
            // (grow_by_reach, bake): see ClusterPush in clusters.glsl.
            let is_pixel = matches!(target, ShadeTarget::Pixel { .. });
            let push = [(world && is_pixel) as u32, (self.bake_records(&target) > 0) as u32];
            rec.dispatch(pipeline, &b, bytemuck::cast_slice(&push), [clusters.min(CLUSTERS_PER_ROW) * 64, rows, 1])?;
            self.frames.set(self.frames.get() + 1);
            if push[1] != 0 {
                self.bake_frames.set(self.bake_frames.get() + 1);
            }
        }
        self.ensure_baked(rec.gpu(), self.bake_records(&target))?;
        let baked = self.baked.borrow();
        let baked = &baked.last().ok_or_else(|| GpuError::Other("internal: shexp bake records missing".into()))?.1;
        // The per-receiver cut takes a node whole below θ_max (SHEXP Eq. 36).
        let sin_t = super::tiles::sin_take_whole(self.options.theta_max_deg.to_radians());
        let tiles = self.tiles.record(rec, "shexp", blockers, &target, sin_t)?;
        let [visits, lists] = tiles.bindings()?;
        self.pipelines.record(
            rec,
            "shexp",
            inputs,
            target,
            &[
                visits,
                lists,
                Binding::buffer("ShexpBaked", baked),
                Binding::buffer("ClusterHeads", &cb.heads),
                Binding::buffer("ClusterCut", &cb.cut),
                Binding::buffer("ShexpStats", stats),
                Binding::buffer("VertexCluster", &p.vertex_clusters[2]),
                Binding::sampled("prefiltered_env", &env.prefiltered),
                Binding::sampled("irradiance_map", &env.irradiance),
                Binding::buffer("ShGamma", table(MathTable::ShGamma(n))?),
                Binding::buffer("ShOl", table(MathTable::ShOl(n))?),
                Binding::buffer("ShCircle", table(MathTable::ShCircleLog(n))?),
                Binding::buffer("BvhNodes", &blockers.bvh_nodes),
                Binding::buffer("ShexpParamsBuf", &p.params),
                Binding::buffer("EnvSh", &p.env_sh),
                Binding::buffer("BlockerPlanes", &blockers.planes),
                Binding::buffer("Lights", &inputs.lights()?.buffer),
            ],
        )
    }

    fn tile_counts(&mut self, gpu: &Gpu) -> Result<Option<super::tiles::TileCounts>> {
        self.tiles.counts(gpu).map(Some)
    }

    fn destroy(mut self: Box<Self>, gpu: &Gpu) {
        self.release(gpu);
        std::mem::replace(&mut self.tiles, super::tiles::BlockerTiles::new(Default::default())).destroy(gpu);
        for b in self.clusters.take() {
            gpu.destroy_buffer(b.heads);
            gpu.destroy_buffer(b.cut);
            gpu.destroy_buffer(b.pool);
            gpu.destroy_buffer(b.hashes);
        }
        for (_, b) in self.baked.take() {
            gpu.destroy_buffer(b);
        }
        if let Some(b) = self.stats.take() {
            gpu.destroy_buffer(b);
        }
        for p in [self.cluster_pixel.take(), self.cluster_vertex.take()].into_iter().flatten() {
            gpu.destroy_compute_pipeline(p);
        }
        self.pipelines.destroy(gpu);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn world_pixel_clusters_refuse_more_vertices_than_the_g_buffer_holds() {
        let world = ShexpOptions { world_pixel_clusters: true, ..ShexpOptions::default() };
        assert!(check_world_pixel_vertices(&world, MAX_WORLD_PIXEL_VERTICES).is_ok());
        let e = check_world_pixel_vertices(&world, MAX_WORLD_PIXEL_VERTICES + 1).unwrap_err().to_string();
        assert!(e.contains("pixel_clusters=tiles") && e.contains("16777217"), "{e}");
        assert!(check_world_pixel_vertices(&ShexpOptions::default(), u32::MAX).is_ok(), "tiles: no limit");
    }
}
