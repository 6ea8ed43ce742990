//! Technique `shexp` (shaders-glsl/shade/shexp): soft shadows by SH exponentiation (Ren et al. 2006).
//!
//! Per receiver: the blockers of a cut of the GPU sphere BVH by subtended angle θ_max (SHEXP Eq. 36;
//! a node taken whole blocks as its bounding sphere: the GPU BVH has no ratio vectors), the SHEXP
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
use crate::gpu::{Binding, Buffer, BufferDesc, Gpu, GpuError, Recorder, Result};
use crate::options::{Kind, OptionSpec, Options};
use crate::tables::MathTables;
use engine_math::sh::{irradiance_weighting_star, project_latlong, Window};
use engine_math::shexp::HYB_DEFAULT_TARGET;
use engine_math::table_gen::MathTable;

pub mod cpu;

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
];

pub const ENTRY: TechniqueEntry = TechniqueEntry {
    name: "shexp",
    summary: "SH exponentiation (Ren et al. 2006): log-space sphere blockers, HYB/OL/PS* exp; diffuse only, glossy = unshadowed lobe × diffuse visibility ratio",
    options: OPTIONS,
    reads: Reads { lights: true, blockers: true, thin: false, geometry: false },
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
        }
    }
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
        }
    }

    /// The lighting window (§7: cos(π/2 · l/h), h = 2n by default).
    pub fn window(&self) -> Window {
        Window::Cosine { h: self.window_h.unwrap_or(2.0 * self.order as f64) }
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
    pub pad: u32,
    pub h_star: [f32; 8],
    pub window: [f32; 8],
}

struct Prepared {
    params: Buffer,
    env_sh: Buffer,
    tables: MathTables,
}

pub struct Shexp {
    pipelines: TargetPipelines,
    pub options: ShexpOptions,
    prepared: Option<Prepared>,
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
        pad: 0,
        h_star,
        window,
    }
}

impl Shexp {
    pub fn new(gpu: &Gpu, options: ShexpOptions) -> Result<Self> {
        let n = options.order.to_string();
        let pipelines = TargetPipelines::with_defines(gpu, "shexp", &[("SHEXP_N", n.as_str())])?;
        Ok(Self { pipelines, options, prepared: None })
    }

    fn release(&mut self, gpu: &Gpu) {
        if let Some(p) = self.prepared.take() {
            gpu.destroy_buffer(p.params);
            gpu.destroy_buffer(p.env_sh);
            p.tables.destroy(gpu);
        }
    }
}

impl Technique for Shexp {
    fn name(&self) -> &'static str {
        "shexp"
    }

    fn prepare(&mut self, gpu: &Gpu, inputs: &ShadeInputs) -> Result<()> {
        self.release(gpu);
        let o = &self.options;
        let tables = MathTables::load(gpu, &crate::tables::default_dir(), &tables_of(o.order))
            .map_err(|e| GpuError::Other(e.to_string()))?;
        let ol = tables.get(MathTable::ShOl(o.order)).map(|t| t.header.axes[0].hi).unwrap_or(0.0);
        let gamma = tables.get(MathTable::ShGamma(o.order)).map(|t| t.header.entry_count() as u32).unwrap_or(0);
        let p = params(o, inputs.blockers()?.sphere_count, ol, gamma);
        let env = environment_sh(&inputs.environment.cpu, o);
        let made = crate::resources::make_buffers(
            gpu,
            [&|| gpu.upload_buffer("shexp-params", BufferDesc::gpu_only(0), std::slice::from_ref(&p)), &|| {
                gpu.upload_buffer("shexp-env-sh", BufferDesc::gpu_only(0), &env)
            }],
        );
        match made {
            Ok([params, env_sh]) => {
                self.prepared = Some(Prepared { params, env_sh, tables });
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
        self.pipelines.record(
            rec,
            "shexp",
            inputs,
            target,
            &[
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

    fn destroy(mut self: Box<Self>, gpu: &Gpu) {
        self.release(gpu);
        self.pipelines.destroy(gpu);
    }
}
