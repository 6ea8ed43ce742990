//! Technique `lobes` (shaders-glsl/shade/lobes): cosine lobes for direct lighting (Meunier et al.
//! 2009), per pixel and per vertex. The shader's header states the algorithm step by step; in short:
//!
//! - reflectance `f_r · cos` as lobes (§5.1): Lambert = the cosine lobe (n, ρ/π, e = 1); a
//!   Blinn-Phong specular as the Phong lobe about the mirror direction (e = s/4), Lafortune (Phong
//!   among them) as its own lobe about M v (Eq. 30), either times the cosine
//!   lobe. Other specular kinds: the exact SG light term times the light's lobe visibility.
//! - each spherical light as one cap lobe (§5.2, e_cap from the cap table); R × L first (§5.4), then
//!   the visibility lobes, every product from the product table, integrated over the hemisphere of
//!   n from the hemisphere table (§4);
//! - visibility per light (§5.3): blocker spheres in the light's cone (a cut of the BVH: leaves, and
//!   nodes narrower than `take_whole` cells of the mask's finest level taken whole as their bounding
//!   sphere; at most [`MAX_BLOCKERS`], else the cut is retried with the threshold doubled, up to
//!   `coarsen` times) and plane blockers classified against a quad-tree over a square
//!   perpendicular to the light axis, to `depth` (covered cells to `split`; a wholly covered mask
//!   hides the light); aggressive or conservative leaves; one cap lobe per
//!   shadow leaf from its bounding cone, weighted so that its integral is the cell's solid angle
//!   (times `weight`: the paper's hand-set w_i(dist, depth) are not reproduced);
//! - the environment: the shared irradiance / prefiltered terms times the visibility of the cosine
//!   lobe through the same kind of mask about the normal (half-angle 1.4 rad); plane blockers by their
//!   exact cosine-weighted solid angle, weighted by the environment they hide and leave free.
//!
//! Bounds per invocation: [`MAX_BLOCKERS`] blockers per light (more are counted as overflow in
//! [`LobesStats`]; the narrowest caps are dropped, with a bound on the shadow they cast: [`cpu::dropped_share`]), quad-tree depth ≤ 6 (stack 19 cells), [`MASK_WORK_BUDGET`] per mask (the
//! receivers that reach it are counted), four reflectance lobes (Lambert and up to three Lafortune lobes).
//! [`cpu`] is the f64 twin of the per-receiver computation.

use super::tiles::{sin_take_whole, BlockerTiles};
use super::{Reads, ShadeInputs, ShadeTarget, TargetPipelines, Technique, TechniqueEntry, Tolerances};
use crate::gpu::{Binding, Buffer, BufferDesc, Gpu, GpuError, Recorder, Result};
use crate::options::{Kind, OptionSpec, Options};
use crate::tables::MathTables;
use engine_math::sg::{EnvKernel, SgRgb};
use engine_math::table_gen::MathTable;

pub mod cpu;
pub mod fit;

/// Blockers kept per light and receiver (LOBES_MAX_BLOCKERS in shade.glsl).
pub const MAX_BLOCKERS: usize = 64;
/// Deepest quad-tree the shader supports (LOBES_MAX_DEPTH).
pub const MAX_DEPTH: u32 = 6;
/// The default work one mask may spend before it stops refining (option `budget`; a visited cell 4, each
/// blocker or plane tested 1; later cells are leaves at their depth): llvmpipe ends every loop of an
/// invocation after 65535 iterations in all, which deep masks over many blockers reached.
pub const MASK_WORK_BUDGET: u32 = 32768;
/// The mask's half-angle never exceeds this (radians; LOBES_MASK_MAX_HALF_ANGLE).
pub const MASK_MAX_HALF_ANGLE: f64 = 1.4;
/// Most environment lobes of `env=lobes` (option `K`): the shader keeps 2 K products R × L_k per receiver.
pub const MAX_ENV_LOBES: usize = 16;

pub const OPTIONS: &[OptionSpec] = &[
    OptionSpec {
        key: "depth",
        aliases: &[],
        kind: Kind::Int { min: 1, max: MAX_DEPTH as i64 },
        default: Some("4"),
        help: "maximal depth of each light's quad-tree visibility mask (paper §5.3: 4 or 5)",
    },
    OptionSpec {
        key: "split",
        aliases: &[],
        kind: Kind::Int { min: 0, max: MAX_DEPTH as i64 },
        default: Some("3"),
        help: "covered cells are split down to this depth (capped by depth) so that leaf lobes are narrower than the light's",
    },
    OptionSpec {
        key: "leaves",
        aliases: &[],
        kind: Kind::Choice(&["half", "aggressive", "conservative"]),
        default: Some("half"),
        help: "partially covered cells at the maximal depth: half (half-weight shadow leaves; ours), aggressive (lit, the paper) or conservative (shadow)",
    },
    OptionSpec {
        key: "threshold",
        aliases: &["t"],
        kind: Kind::closed(0.0, 1.0),
        default: Some("0.0001"),
        help: "t_i (§4.3): visibility products whose integral is below t_i times the light's unshadowed integral are pruned",
    },
    OptionSpec {
        key: "weights",
        aliases: &[],
        kind: Kind::Choice(&["uniform", "fitted"]),
        default: Some("uniform"),
        help: "light leaf weights by quad-tree depth: uniform (1) or fitted (assets/tables/lobes_weights.txt, `cargo xtask lobes-weights`: fitted at the default depth, split and leaves)",
    },
    OptionSpec {
        key: "weight",
        aliases: &["w"],
        kind: Kind::closed(0.0, 4.0),
        default: Some("1"),
        help: "factor of the leaf weights w_i = weight · Ω_cell / ∫c_i",
    },
    OptionSpec {
        key: "extent",
        aliases: &[],
        kind: Kind::closed(1.0, 4.0),
        default: Some("1.5"),
        help: "the mask's half-angle over the light's (the cap lobe reaches past the cap)",
    },
    OptionSpec {
        key: "light",
        aliases: &[],
        kind: Kind::Choice(&["lobes", "ratio"]),
        default: Some("lobes"),
        help: "light term: lobes (max(U − S, 0), the paper) or ratio (the exact unshadowed light × (1 − S/U))",
    },
    OptionSpec {
        key: "sharpen",
        aliases: &[],
        kind: Kind::closed(1.0, 16.0),
        default: Some("2"),
        help: "the light lobe's exponent is e_cap times this (1: the paper's L2 cap fit, whose tail past the cap widens penumbrae; 2 measured best on the bunny under one and two lights)",
    },
    OptionSpec {
        key: "light_scale",
        aliases: &[],
        kind: Kind::Choice(&["energy", "paper"]),
        default: Some("energy"),
        help: "light lobe scale: energy (its integral is the cap's solid angle × L) or paper (L, Eq. 31)",
    },
    OptionSpec {
        key: "take_whole",
        aliases: &[],
        kind: Kind::closed(0.0, 16.0),
        default: Some("1"),
        help: "BVH nodes whose angular diameter is below this many cells of the mask's finest level (local size, w cos θ) are taken whole as their bounding sphere (0: leaves only; ≤ 1 changes no covered cell)",
    },
    OptionSpec {
        key: "coarsen",
        aliases: &[],
        kind: Kind::Int { min: 0, max: 8 },
        default: Some("4"),
        help: "when a mask's cut still holds more than 64 blockers, retry it with `take_whole` doubled up to this many times before dropping (and counting) its narrowest caps",
    },
    OptionSpec {
        key: "budget",
        aliases: &[],
        kind: Kind::Int { min: 64, max: 1 << 24 },
        default: Some("32768"),
        help: "work a mask may spend before it stops refining (a visited cell 4, each blocker or plane tested 1; its later cells become leaves at their depth; the receivers that reach it are counted): keeps lavapipe under its 65535 loop iterations per invocation",
    },
    OptionSpec {
        key: "env",
        aliases: &[],
        kind: Kind::Choice(&["map", "lobes"]),
        default: Some("map"),
        help: "environment: map (the shared irradiance and prefiltered terms × the cosine lobe's visibility through the normal's mask, leaves weighted by the prefiltered map; ours) or lobes (K fitted cosine lobes, each taken through R × L_k and the normal's mask as the paper takes a light)",
    },
    OptionSpec {
        key: "K",
        aliases: &["k"],
        kind: Kind::Int { min: 1, max: MAX_ENV_LOBES as i64 },
        default: Some("10"),
        help: "environment cosine lobes (env=lobes; isg's greedy least-squares fit with the cosine-lobe kernel, refined; 10 as isg's K)",
    },
    OptionSpec {
        key: "refine",
        aliases: &[],
        kind: Kind::Int { min: 0, max: 100 },
        default: Some("6"),
        help: "coordinate-descent rounds refining the greedy environment lobe fit (env=lobes; 0: greedy only)",
    },
    OptionSpec {
        key: "phase",
        aliases: &[],
        kind: Kind::Choice(&PHASES),
        default: Some("all"),
        help: "cost split (paper Table 1; a timing variant, its image is not the technique's): every receiver stops after lobes (reflectance and light lobes, R × L, U), gather (+ the masks' blocker cuts), mask (+ the quad-trees), leaves (+ the shadow leaves' lobes) or all (+ the visibility products and integrals)",
    },
    OptionSpec {
        key: "light_rule",
        aliases: &[],
        kind: Kind::Choice(&["auto", "plain", "alpha"]),
        default: Some("auto"),
        help: "receiver rule of the lights' masks for a sphere straddling the tangent plane: plain (SHEXP §6.2, as the sphere reference), alpha (with its radius scale α, as the environment's mask) or auto (alpha in a scene with thin shells, whose stand-in spheres straddle every receiver on the sheet; plain otherwise)",
    },
    super::env_lights_option("on"),
    super::tiles::TILES_OPTION,
    super::tiles::TILE_CAP_OPTION,
    super::tiles::TILE_LOD_OPTION,
    super::tiles::REACH_OPTION,
];

/// The values of option `phase`, in order: phase k (1-based) is `LOBES_PHASE` k in shade.glsl.
pub const PHASES: [&str; 5] = ["lobes", "gather", "mask", "leaves", "all"];

pub const ENTRY: TechniqueEntry = TechniqueEntry {
    name: "lobes",
    summary: "cosine lobes (Meunier et al. 2009): spherical lights as cap lobes, quad-tree visibility masks, products from tables; environment × first-order lobe occlusion",
    options: OPTIONS,
    reads: Reads { lights: true, blockers: true, thin: false, geometry: false, env_lights: false },
    // Measured by tests/tests/techniques.rs at the defaults: furnace 3.01e-4 (the irradiance grid, as
    // `isg`), no blockers vs `none` 0 (the visibility is exactly 1: the same shared terms), one sphere
    // 2.09 % (the environment mask at depth 5: cells about the normal ~10° wide, half-weight partial
    // leaves, round leaf lobes for square cells), the ball above a half-space 0.005 % and above a rectangle
    // 0.056 % (both exact: the plate's cosine-weighted solid angle by Lambert's formula; 1.93 % with the
    // equal-solid-angle cap lobe it replaced). Bounds: the measurement with margin.
    tolerances: Tolerances {
        furnace: 1e-3,
        unoccluded_vs_none: 1e-5,
        one_sphere: Some(0.03),
        one_plane: Some(0.005),
        samples: 0,
    },
    create: |gpu, o| {
        let options = LobesOptions::from_options(o).map_err(crate::options::OptionError)?;
        Ok(Box::new(Lobes::new(gpu, options)?))
    },
};

/// Partially covered cells at the maximal depth.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Leaves {
    /// Dropped (lit): the paper's choice.
    Aggressive = 0,
    /// Shadow leaves.
    Conservative = 1,
    /// Shadow leaves of half weight.
    Half = 2,
}

/// The typed options (see [`OPTIONS`]).
#[derive(Clone, Debug, PartialEq)]
pub struct LobesOptions {
    pub depth: u32,
    pub split: u32,
    pub leaves: Leaves,
    pub threshold: f64,
    pub weight: f64,
    pub extent: f64,
    /// `light=ratio`.
    pub ratio: bool,
    /// `light_scale=energy`.
    pub energy: bool,
    pub sharpen: f64,
    /// Nodes narrower than this many finest mask cells are taken whole (0: leaves only).
    pub take_whole: f64,
    /// Retries of an overflowing cut with `take_whole` doubled.
    pub coarsen: u32,
    /// The work one mask may spend before it stops refining ([`MASK_WORK_BUDGET`] by default).
    pub budget: u32,
    /// `env=lobes`: the environment as this many fitted cosine lobes (0: `env=map`).
    pub env_lobes: usize,
    /// Refinement rounds of the environment lobe fit.
    pub refine: usize,
    /// `phase`: the last phase each receiver runs, 1..=5 ([`PHASES`]; 5 = all, the image).
    pub phase: u32,
    /// The receiver rule of the lights' masks for spheres straddling the tangent plane.
    pub light_rule: LightRule,
    /// Factor of the light masks' leaf weights by the leaf's depth (index 0..=6; `weights=fitted`: the
    /// fitted table `assets/tables/lobes_weights.json`, else all 1).
    pub light_weights: [f64; WEIGHT_DEPTHS],
    /// The blocker tiles (`tiles`, `tile_cap`).
    pub tiles: super::tiles::TileOptions,
}

/// Depths of the per-depth light weights (0..=[`MAX_DEPTH`]).
pub const WEIGHT_DEPTHS: usize = MAX_DEPTH as usize + 1;

impl Default for LobesOptions {
    fn default() -> Self {
        Self {
            depth: 4,
            split: 3,
            leaves: Leaves::Half,
            threshold: 1e-4,
            weight: 1.0,
            extent: 1.5,
            ratio: false,
            energy: true,
            sharpen: 2.0,
            take_whole: 1.0,
            coarsen: 4,
            budget: MASK_WORK_BUDGET,
            env_lobes: 0,
            refine: 6,
            phase: PHASES.len() as u32,
            light_weights: [1.0; WEIGHT_DEPTHS],
            light_rule: LightRule::Auto,
            tiles: Default::default(),
        }
    }
}

impl LobesOptions {
    /// The options from the parsed spec; `weights=fitted` reads the fitted table (an error names the file).
    pub fn from_options(o: &Options) -> std::result::Result<Self, String> {
        let light_weights = match o.choice("weights") {
            "fitted" => fit::load_table(&crate::tables::default_dir())?,
            _ => [1.0; WEIGHT_DEPTHS],
        };
        Ok(Self {
            depth: o.int("depth") as u32,
            split: o.int("split") as u32,
            leaves: match o.choice("leaves") {
                "aggressive" => Leaves::Aggressive,
                "conservative" => Leaves::Conservative,
                _ => Leaves::Half,
            },
            threshold: o.float("threshold"),
            weight: o.float("weight"),
            extent: o.float("extent"),
            ratio: o.choice("light") == "ratio",
            energy: o.choice("light_scale") == "energy",
            sharpen: o.float("sharpen"),
            take_whole: o.float("take_whole"),
            coarsen: o.int("coarsen") as u32,
            budget: o.int("budget") as u32,
            env_lobes: if o.choice("env") == "lobes" { o.int("K") as usize } else { 0 },
            refine: o.int("refine") as usize,
            phase: PHASES.iter().position(|&p| p == o.choice("phase")).map_or(PHASES.len(), |i| i + 1) as u32,
            light_weights,
            light_rule: match o.choice("light_rule") {
                "plain" => LightRule::Plain,
                "alpha" => LightRule::Alpha,
                _ => LightRule::Auto,
            },
            tiles: super::tiles::TileOptions::from_options(o),
        })
    }
}

/// The receiver rule of the lights' masks (option `light_rule`) for a blocker sphere straddling the receiver's
/// tangent plane: SHEXP §6.2's plain rule (the sphere reference's), or the rule with its radius scale α (the
/// environment mask's, and `shexp`'s). A sheet's stand-in spheres straddle the tangent plane of every receiver
/// on the sheet: with the plain rule each becomes a blocker over the horizon, and light near the horizon draws
/// the stand-ins' grid on the sheet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightRule {
    /// α in a scene with thin shells (the cloth), plain otherwise: resolved by [`LightRule::resolve`] at prepare.
    Auto,
    Plain,
    Alpha,
}

impl LightRule {
    /// `Auto` resolved for a scene with or without thin shells.
    pub fn resolve(self, thin_shells: bool) -> Self {
        match self {
            LightRule::Auto if thin_shells => LightRule::Alpha,
            LightRule::Auto => LightRule::Plain,
            r => r,
        }
    }
}

/// `LobesParams` in shaders-glsl/shade/lobes/shade.glsl (std430).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuLobesParams {
    pub sphere_count: u32,
    pub depth: u32,
    pub conservative: u32,
    pub threshold: f32,
    pub weight: f32,
    pub extent: f32,
    /// 0 lobes, 1 ratio.
    pub light_mode: u32,
    pub energy_scale: u32,
    pub split: u32,
    pub sharpen: f32,
    /// Nodes narrower than this many cells of the finest mask level are taken whole.
    pub take_whole: f32,
    /// Retries of an overflowing cut with `take_whole` doubled.
    pub coarsen: u32,
    /// Per-depth factors of the light masks' leaf weights (7 used).
    pub light_weights: [f32; 8],
    /// Environment lobes in `EnvLobes` (`env=lobes`; 0 with `env=map`).
    pub env_lobe_count: u32,
    /// The work budget of one mask.
    pub budget: u32,
    /// 1: the environment is black everywhere (the shader skips its term and mask).
    pub env_black: u32,
    /// 1: the lights' masks take the receiver rules with α ([`LightRule`]).
    pub light_alpha: u32,
    /// The bounded reach (option `reach`, scene units; 0: off).
    pub reach: f32,
}

/// `EnvLobe` in shaders-glsl/shade/lobes/shade.glsl (std430): one environment cosine lobe
/// `scale · max(axis·v, 0)^e`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuEnvLobe {
    /// Unit axis (xyz) and exponent e (w).
    pub axis_e: [f32; 4],
    /// RGB scale (w unused).
    pub scale: [f32; 4],
}

impl GpuEnvLobe {
    pub fn from_fit(l: &SgRgb) -> Self {
        let a = l.axis.map(|x| x as f32);
        let m = l.mu.map(|x| x as f32);
        Self { axis_e: [a[0], a[1], a[2], l.lambda as f32], scale: [m[0], m[1], m[2], 0.0] }
    }
}

/// The environment as `k` cosine lobes: engine-math's fit ([`engine_math::sg::fit_environment`] with
/// the cosine-lobe kernel, the fit `isg` makes with SGs). Returns the lobes and the relative L2 error.
pub fn fit_environment(env: &engine_math::envmap::LatLongMap, k: usize, refine: usize) -> (Vec<SgRgb>, f64) {
    engine_math::sg::fit_environment(env, k, refine, EnvKernel::CosineLobe)
}

/// A cheap fingerprint of an environment map (its size and every texel's bits), to refit only when
/// the environment changed.
fn environment_key(env: &engine_math::envmap::LatLongMap) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325 ^ ((env.width as u64) << 32 | env.height as u64);
    for t in &env.texels {
        for c in t {
            h = (h ^ c.to_bits() as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    h
}

/// The parameter block for `o`.
pub fn params(o: &LobesOptions, sphere_count: u32) -> GpuLobesParams {
    GpuLobesParams {
        sphere_count,
        depth: o.depth.min(MAX_DEPTH),
        conservative: o.leaves as u32,
        threshold: o.threshold as f32,
        weight: o.weight as f32,
        extent: o.extent as f32,
        light_mode: o.ratio as u32,
        energy_scale: o.energy as u32,
        split: o.split,
        sharpen: o.sharpen as f32,
        take_whole: o.take_whole as f32,
        coarsen: o.coarsen,
        light_weights: std::array::from_fn(|d| o.light_weights.get(d).map_or(1.0, |&w| w as f32)),
        env_lobe_count: o.env_lobes.min(MAX_ENV_LOBES) as u32,
        budget: o.budget,
        env_black: 0,
        light_alpha: u32::from(o.light_rule == LightRule::Alpha),
        reach: o.tiles.reach as f32,
    }
}

/// The counters the shader accumulates (LOBES_STATS of shade.glsl).
const STATS_LEN: usize = 14;

/// The counters the shader accumulates (cumulative since the last [`Lobes::reset_stats`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LobesStats {
    /// Receivers shaded.
    pub receivers: u64,
    /// Receivers where some mask's cut (the coarsest tried) held more than [`MAX_BLOCKERS`] blockers
    /// (the narrowest caps dropped).
    pub overflowed: u64,
    /// Lobe products computed.
    pub products: u64,
    /// Visibility products below the threshold t_i (computed, then dropped; part of `products`).
    pub pruned: u64,
    /// Shadow leaves (visibility lobes) of all masks.
    pub leaves: u64,
    /// Receivers whose environment mask overflowed (part of `overflowed`).
    pub env_overflowed: u64,
    /// Receivers where some light's mask overflowed (part of `overflowed`).
    pub light_overflowed: u64,
    /// Receivers where some mask stopped refining at [`MASK_WORK_BUDGET`] (its later cells became leaves at
    /// their depth: a coarser mask there, not a dropped blocker).
    pub budget_limited: u64,
    /// The largest share of the cosine-weighted sky that the blockers an environment mask dropped could hide at
    /// one receiver (a bound on the shadow they cast: [`cpu::dropped_share`]); 0 when none was dropped.
    pub dropped_env_max: f64,
    /// The largest share of a light that the blockers its mask dropped could hide at one receiver.
    pub dropped_light_max: f64,
    /// Receivers where the environment's dropped share passes 1 %.
    pub dropped_env_over_1pc: u64,
    /// Receivers where some light's dropped share passes 1 %.
    pub dropped_light_over_1pc: u64,
    /// The environment's dropped shares summed over the receivers (in thousandths, each at most 1).
    pub dropped_env_sum: f64,
    /// The lights' largest dropped shares summed over the receivers (in thousandths, each at most 1).
    pub dropped_light_sum: f64,
}

/// The work per shaded receiver (none before any receiver was shaded): lobe products computed (each
/// integrated over the hemisphere), of which visibility products below t_i × U (dropped from S: their
/// environment lookup and sum are skipped, their product and integral are not: the visibility product is
/// the last of the chain, so nothing later is saved; cf. paper Fig. 16), and shadow leaves.
pub fn work_line(s: &LobesStats) -> Option<String> {
    (s.receivers > 0).then(|| {
        let per = |x: u64| x as f64 / s.receivers as f64;
        format!(
            "lobes: per shaded receiver {:.1} lobe products, {:.1} of them below t_i and dropped ({:.1} %), {:.1} \
             shadow leaves, masks cut short by the work budget at {:.2} % ({} receivers)",
            per(s.products),
            per(s.pruned),
            if s.products > 0 { 100.0 * s.pruned as f64 / s.products as f64 } else { 0.0 },
            per(s.leaves),
            100.0 * per(s.budget_limited),
            s.receivers
        )
    })
}

/// The user's line for overflowed receivers (none when nothing overflowed).
pub fn overflow_warning(s: &LobesStats) -> Option<String> {
    (s.overflowed > 0).then(|| {
        format!(
            "lobes: {} of {} shaded receivers ({:.1} %) had more than {MAX_BLOCKERS} blockers in a light's or the \
             environment's mask cone even after coarsening the cut (environment masks {}, light masks {}); the \
             narrowest (farthest) were dropped; their shadow is bounded by {:.2} % of the cosine-weighted sky on \
             average over those receivers ({:.1} % at most, over 1 % at {} receivers) and {:.2} % of a light on \
             average ({:.1} % at most, over 1 % at {})",
            s.overflowed,
            s.receivers,
            100.0 * s.overflowed as f64 / s.receivers.max(1) as f64,
            s.env_overflowed,
            s.light_overflowed,
            100.0 * s.dropped_env_sum / s.env_overflowed.max(1) as f64,
            100.0 * s.dropped_env_max,
            s.dropped_env_over_1pc,
            100.0 * s.dropped_light_sum / s.light_overflowed.max(1) as f64,
            100.0 * s.dropped_light_max,
            s.dropped_light_over_1pc,
        )
    })
}

/// The tables the technique reads.
pub const TABLES: [MathTable; 3] = [MathTable::LobeProduct, MathTable::LobeHemisphere, MathTable::LobeCap];

struct Prepared {
    params: Buffer,
    tables: MathTables,
    /// The environment lobes (one zero lobe with `env=map`: a storage buffer may not be empty).
    env_lobes: Buffer,
}

/// The environment fit of `env=lobes`, kept while the environment does not change.
#[derive(Clone, Debug)]
pub struct EnvFit {
    key: u64,
    pub lobes: Vec<SgRgb>,
    /// Relative L2 error of the fit over the 128×64 resampled map.
    pub error: f64,
}

/// The largest half-angle below which a first cut of a mask takes a BVH node whole (the tile lists stop above
/// such nodes): lobes_node_is_small's 2β < cells cos(·) gives β < cells/2 = take_whole tan(h)/2^depth with the
/// widest mask (h = LOBES_MASK_MAX_HALF_ANGLE, 1.4) at the coarsest maximal depth (the lights', `depth`). A
/// coarsened retry takes wider nodes whole: it traverses from the root (shade.glsl `g_from_root`).
pub fn take_whole_bound(o: &LobesOptions) -> f64 {
    o.take_whole * 1.4f64.tan() / f64::from(1u32 << o.depth.min(MAX_DEPTH))
}

pub struct Lobes {
    pipelines: TargetPipelines,
    pub options: LobesOptions,
    prepared: Option<Prepared>,
    stats: Option<Buffer>,
    /// `env=lobes`: the last environment fit.
    pub env_fit: Option<EnvFit>,
    /// The fit's line is reported once per fit.
    env_fit_reported: bool,
    /// The blocker tiles of the per-pixel target (`tiles`).
    tiles: BlockerTiles,
}

impl Lobes {
    pub fn new(gpu: &Gpu, options: LobesOptions) -> Result<Self> {
        let phase = options.phase.to_string();
        let env_k = options.env_lobes.min(MAX_ENV_LOBES).to_string();
        let mut defines: Vec<(&str, &str)> = Vec::new();
        if options.phase < PHASES.len() as u32 {
            defines.push(("LOBES_PHASE", phase.as_str()));
        }
        if options.env_lobes > 0 {
            defines.push(("LOBES_ENV_K", env_k.as_str()));
        }
        defines.extend(options.tiles.defines());
        let pipelines = if defines.is_empty() {
            TargetPipelines::new(gpu, "lobes")?
        } else {
            TargetPipelines::with_defines(gpu, "lobes", &defines)?
        };
        let tiles = BlockerTiles::new(options.tiles);
        Ok(Self { pipelines, options, prepared: None, stats: None, env_fit: None, env_fit_reported: false, tiles })
    }

    fn release(&mut self, gpu: &Gpu) {
        if let Some(p) = self.prepared.take() {
            gpu.destroy_buffer(p.params);
            gpu.destroy_buffer(p.env_lobes);
            p.tables.destroy(gpu);
        }
    }

    /// The counters since the last reset (a readback: waits for the GPU).
    pub fn stats(&self, gpu: &Gpu) -> Result<LobesStats> {
        let Some(b) = &self.stats else { return Ok(LobesStats::default()) };
        let v: Vec<u32> = gpu.read_buffer(b)?;
        let g = |i: usize| v.get(i).copied().unwrap_or(0) as u64;
        let f = |i: usize| f32::from_bits(v.get(i).copied().unwrap_or(0)) as f64;
        Ok(LobesStats {
            receivers: g(0),
            overflowed: g(1),
            products: g(2),
            pruned: g(3),
            leaves: g(4),
            env_overflowed: g(5),
            light_overflowed: g(6),
            budget_limited: g(7),
            dropped_env_max: f(8),
            dropped_light_max: f(9),
            dropped_env_over_1pc: g(10),
            dropped_light_over_1pc: g(11),
            dropped_env_sum: g(12) as f64 / 1000.0,
            dropped_light_sum: g(13) as f64 / 1000.0,
        })
    }

    /// Zero the counters.
    pub fn reset_stats(&self, gpu: &Gpu) -> Result<()> {
        match &self.stats {
            Some(b) => gpu.copy_to_buffer(b, bytemuck::cast_slice(&[0u32; STATS_LEN])),
            None => Ok(()),
        }
    }
}

impl Technique for Lobes {
    fn name(&self) -> &'static str {
        "lobes"
    }

    /// Receivers whose blocker list overflowed since the last call (then the counters restart).
    fn warnings(&mut self, gpu: &Gpu) -> Result<Vec<String>> {
        Ok(self.report(gpu)?.warnings)
    }

    /// The overflow warning and the work per receiver since the last call (then the counters restart).
    fn report(&mut self, gpu: &Gpu) -> Result<super::TechniqueReport> {
        let s = self.stats(gpu)?;
        self.reset_stats(gpu)?;
        let mut counts: Vec<String> = work_line(&s).into_iter().collect();
        if let Some(f) = self.env_fit.as_ref().filter(|_| !self.env_fit_reported) {
            counts.push(format!(
                "lobes: the environment as {} cosine lobes (refined {} rounds): relative L2 fit error {:.1} %",
                f.lobes.len(),
                self.options.refine,
                100.0 * f.error
            ));
            self.env_fit_reported = true;
        }
        Ok(super::TechniqueReport { warnings: overflow_warning(&s).into_iter().collect(), counts })
    }

    fn prepare(&mut self, gpu: &Gpu, inputs: &ShadeInputs) -> Result<()> {
        self.release(gpu);
        let tables = MathTables::load(gpu, &crate::tables::default_dir(), &TABLES)
            .map_err(|e| GpuError::Other(e.to_string()))?;
        let mut gpu_lobes = vec![GpuEnvLobe::default()];
        if self.options.env_lobes > 0 {
            let env = &inputs.environment.cpu;
            let key = environment_key(env);
            if self.env_fit.as_ref().is_none_or(|f| f.key != key) {
                let (lobes, error) = fit_environment(env, self.options.env_lobes, self.options.refine);
                self.env_fit = Some(EnvFit { key, lobes, error });
                self.env_fit_reported = false;
            }
            if let Some(f) = self.env_fit.as_ref().filter(|f| !f.lobes.is_empty()) {
                gpu_lobes = f.lobes.iter().map(GpuEnvLobe::from_fit).collect();
            }
        }
        let rule = self.options.light_rule.resolve(inputs.has_thin_shells());
        let mut p = params(&LobesOptions { light_rule: rule, ..self.options.clone() }, inputs.blockers()?.sphere_count);
        p.env_lobe_count = if self.options.env_lobes > 0 { gpu_lobes.len().min(MAX_ENV_LOBES) as u32 } else { 0 };
        p.env_black = u32::from(inputs.environment.cpu.texels.iter().all(|t| t.iter().all(|&c| c == 0.0)));
        let params = match gpu.upload_buffer("lobes-params", BufferDesc::gpu_only(0), std::slice::from_ref(&p)) {
            Ok(b) => b,
            Err(e) => {
                tables.destroy(gpu);
                return Err(e);
            }
        };
        let env_lobes = match gpu.upload_buffer("lobes-env-lobes", BufferDesc::gpu_only(0), &gpu_lobes) {
            Ok(b) => b,
            Err(e) => {
                gpu.destroy_buffer(params);
                tables.destroy(gpu);
                return Err(e);
            }
        };
        if self.stats.is_none() {
            match gpu.upload_buffer("lobes-stats", BufferDesc::gpu_only(0), &[0u32; STATS_LEN]) {
                Ok(b) => self.stats = Some(b),
                Err(e) => {
                    gpu.destroy_buffer(params);
                    gpu.destroy_buffer(env_lobes);
                    tables.destroy(gpu);
                    return Err(e);
                }
            }
        }
        self.prepared = Some(Prepared { params, tables, env_lobes });
        Ok(())
    }

    fn record(&self, rec: &mut Recorder, inputs: &ShadeInputs, target: ShadeTarget) -> Result<()> {
        let (Some(p), Some(stats)) = (&self.prepared, &self.stats) else {
            return Err(GpuError::Other("technique 'lobes' recorded before prepare()".into()));
        };
        let table = |t: MathTable| {
            p.tables
                .get(t)
                .map(|g| &g.buffer)
                .ok_or_else(|| GpuError::Other(format!("lobes: table {} not loaded", t.name())))
        };
        let env = inputs.environment;
        let blockers = inputs.blockers()?;
        let tiles =
            self.tiles.record(rec, "lobes", blockers, &target, sin_take_whole(take_whole_bound(&self.options)))?;
        let [visits, lists] = tiles.bindings()?;
        self.pipelines.record(
            rec,
            "lobes",
            inputs,
            target,
            &[
                visits,
                lists,
                Binding::sampled("irradiance_map", &env.irradiance),
                Binding::sampled("prefiltered_env", &env.prefiltered),
                Binding::buffer("LobeProduct", table(MathTable::LobeProduct)?),
                Binding::buffer("LobeHemisphere", table(MathTable::LobeHemisphere)?),
                Binding::buffer("LobeCap", table(MathTable::LobeCap)?),
                Binding::buffer("BvhNodes", &blockers.bvh_nodes),
                Binding::buffer("LobesParamsBuf", &p.params),
                Binding::buffer("LobesStats", stats),
                Binding::buffer("EnvLobes", &p.env_lobes),
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
        std::mem::replace(&mut self.tiles, BlockerTiles::new(Default::default())).destroy(gpu);
        if let Some(b) = self.stats.take() {
            gpu.destroy_buffer(b);
        }
        self.pipelines.destroy(gpu);
    }

    fn as_any_mut(&mut self) -> Option<&mut dyn std::any::Any> {
        Some(self)
    }
}
