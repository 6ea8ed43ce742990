//! The f64 twin of `shaders-glsl/shade/lobes/shade.glsl` per receiver: the same tables (read from the
//! asset files the GPU uploads), the same reflectance and light lobes, the same quad-tree (frame,
//! cell order, classification, leaf lobes and weights), the same environment occlusion, in f64.
//! The blockers are gathered by the shader's cut of the blocker BVH ([`TwinBvh`]: the same node array,
//! the same traversal order, the same take-whole rule [`node_is_small`] and the same coarsening
//! retries, the same choice of the narrowest caps to drop), so the twin drops the same blockers when a mask
//! overflows.
//! Covers `light=lobes` (both light scales, both leaf modes); `light=ratio` reuses the same S/U.

use super::{Leaves, LobesOptions};
use crate::tables::default_dir;
use engine_blockers::bvh::{GpuBvhNode, SphereBvh, INVALID};
use engine_blockers::geom::{
    blocker_for_receiver, blocker_for_receiver_alpha, cone_intersects_sphere, subtended_half_angle, Cone, Sphere,
};
use engine_blockers::plane::BlockerPlane;
use engine_math::lobes::{
    angle_between, product_axis, product_log_peak, CapTable, HemisphereTable, ProductTable, MAX_EXPONENT,
};
use engine_math::table_gen::MathTable;
use engine_math::tables::Table;
use glam::DVec3;
use std::f64::consts::PI;

/// Depth adaptation: a partial cell whose products are bounded below `ADAPT` × t_i × |U| is not refined
/// (`LOBES_ADAPT` in shade.glsl; [`Twin::cell_negligible`]).
pub const ADAPT: f64 = 300.0;

/// A lobe with an RGB scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbLobe {
    pub axis: DVec3,
    pub e: f64,
    pub s: [f64; 3],
}

/// A spherical light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwinLight {
    pub center: DVec3,
    pub radius: f64,
    pub radiance: [f64; 3],
}

/// Which caps a cut keeps (the shader's g_min_width, g_boundary_low, g_boundary_room).
#[derive(Clone, Copy)]
enum Keep {
    /// All, up to [`super::MAX_BLOCKERS`].
    All,
    /// Those at least `min_width` wide (sin(β/2)), then `boundary_room` of those in [`boundary_low`, `min_width`)
    /// in traversal order.
    Widest { min_width: f64, boundary_low: f64, boundary_room: usize },
}

/// Width bins of [`width_bin`] (LOBES_WIDTH_BINS).
const WIDTH_BINS: usize = 8;

/// The bin of a cap's width w = sin(β/2) (the shader's `lobes_width_bin`): k for w in [2^-(k+1), 2^-k), the last
/// bin below 2^-7. A mask whose coarsest cut still overflows keeps the widest bins that fit.
pub fn width_bin(w: f64) -> usize {
    (-(w.max(1e-30)).log2()).floor().clamp(0.0, (WIDTH_BINS - 1) as f64) as usize
}

/// The share of the light a dropped blocker's cap of half-angle `beta` could hide (the shader's `g_dropped`): in
/// the environment's mask (`light_alpha` None) its solid angle over π, 4 sin²(β/2), which bounds its
/// cosine-weighted share of the sky; for a light of angular radius α, its solid angle over the light's,
/// sin²(β/2) / sin²(α/2). Summed over a mask's dropped caps (clamped to 1) it bounds what they hide, loosely: the
/// caps may overlap each other or miss the light.
pub fn dropped_share(beta: f64, light_alpha: Option<f64>) -> f64 {
    let s2 = (0.5 * beta).sin().powi(2);
    match light_alpha {
        None => 4.0 * s2,
        Some(alpha) => s2 / (0.5 * alpha).sin().powi(2).max(1e-30),
    }
}

/// One receiver: position, unit shading normal, unit direction to the viewer, diffuse albedo and an
/// specular lobes f_s without the cosine ([`specular_lobes`]; empty: none).
#[derive(Clone, Debug, PartialEq)]
pub struct TwinReceiver {
    pub p: DVec3,
    pub n: DVec3,
    pub view: DVec3,
    pub rho: [f64; 3],
    pub specular: Vec<RgbLobe>,
}

/// The specular term as cosine lobes (§5.1), where the model is made of them: Blinn-Phong as the Phong
/// lobe about the mirror direction with e = s/4 and scale k_s (s+8)/(8π); Lafortune (Phong among them)
/// exactly, each lobe i about d_i = M_i v/|M_i v| with e_i and scale w_i k_s (e_i+2)/(2π) |M_i v|^e_i
/// (Eq. 28–30). Empty for the other models and where k_s = 0. `t` is the unit tangent. Twin of the
/// shader's `lobes_specular_lobes`.
pub fn specular_lobes(
    model: &engine_math::brdf::SpecularModel,
    ks: [f64; 3],
    n: DVec3,
    t: DVec3,
    view: DVec3,
) -> Vec<RgbLobe> {
    use engine_math::brdf::{lafortune_lobe, lafortune_norm, SpecularModel};
    if ks.iter().all(|&k| k == 0.0) {
        return Vec::new();
    }
    match *model {
        SpecularModel::BlinnPhong { s } => {
            let mirror = 2.0 * n.dot(view) * n - view;
            vec![RgbLobe { axis: mirror, e: 0.25 * s, s: ks.map(|k| k * (s + 8.0) / (8.0 * PI)) }]
        }
        SpecularModel::Lafortune { .. } => model
            .lafortune_terms()
            .iter()
            .map(|l| {
                let (d, peak) = lafortune_lobe(l.c, l.e, n.to_array(), t.to_array(), view.to_array());
                RgbLobe { axis: DVec3::from_array(d), e: l.e, s: ks.map(|k| k * l.w * lafortune_norm(l.e) * peak) }
            })
            .collect(),
        _ => Vec::new(),
    }
}

/// One light's terms at a receiver: U (unshadowed lobe integral), S (shadow), whether its blocker
/// list overflowed, and the counts of leaves and of products (computed, pruned).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LightTerms {
    pub u: [f64; 3],
    pub s: [f64; 3],
    pub overflow: bool,
    pub leaves: usize,
    pub products: usize,
    pub pruned: usize,
    /// False: the receiver is inside the light (the shader then adds the closed form).
    pub outside: bool,
    /// The whole mask was covered (S = U).
    pub hidden: bool,
    /// Some cell was kept from splitting by the work budget (`LobesOptions::budget`).
    pub budget_limited: bool,
    /// S (green channel) by the depth of its leaves before the per-depth light weights (light masks
    /// only): S = Σ_d w_d `s_by_depth[d]` when nothing is pruned (the weight fit's regressors).
    pub s_by_depth: [f64; super::WEIGHT_DEPTHS],
    /// The environment's mask with `env=map` ([`MaskKind::EnvMap`]): the light of its free cells and of the
    /// uncovered share of its half-weight leaves (the shader's `g_env_free`).
    pub free: [f64; 3],
}

/// Which mask [`Twin::mask`] builds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MaskKind {
    /// A light's: its planes tested, its leaves weighted by depth ([`LobesOptions::light_weights`]).
    Light,
    /// The environment's with `env=map`: unit weights, and the free light ([`LightTerms::free`]) beside S.
    EnvMap,
    /// The environment's with `env=lobes`: unit weights, S only.
    EnvLobes,
}

impl LightTerms {
    /// What `light=lobes` adds: max(U − S, 0) per channel.
    pub fn radiance(&self) -> [f64; 3] {
        [0, 1, 2].map(|c| (self.u[c] - self.s[c]).max(0.0))
    }
    /// The luminance visibility clamp(1 − S/U, 0, 1) (`light=ratio`).
    pub fn visibility(&self) -> f64 {
        let u = lum(self.u);
        if u > 0.0 {
            (1.0 - lum(self.s) / u).clamp(0.0, 1.0)
        } else {
            1.0
        }
    }
}

fn lum(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

fn read(t: MathTable) -> Result<Table, String> {
    let path = default_dir().join(format!("{}.bin", t.name()));
    Table::read(&path).map_err(|e| format!("{}: {e}", path.display()))
}

fn pairs(t: &Table) -> Vec<[f32; 2]> {
    t.f32_values().chunks_exact(2).map(|c| [c[0], c[1]]).collect()
}

/// The frame of frame.glsl's `orthonormal_basis` (Duff et al.), in f64.
pub fn orthonormal_basis(z: DVec3) -> (DVec3, DVec3) {
    let s = if z.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (s + z.z);
    let c = z.x * z.y * a;
    (DVec3::new(1.0 + s * z.x * z.x * a, s * c, -s * z.x), DVec3::new(c, s + z.y * z.y * a, -z.y))
}

/// Solid angle of the triangle (a, b, c) seen from the origin (Van Oosterom–Strackee).
pub fn triangle_solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = a.dot(b.cross(c)).abs();
    let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * num.atan2(den)
}

fn cap_solid_angle(alpha: f64) -> f64 {
    let h = (0.5 * alpha.min(PI)).sin();
    4.0 * PI * h * h
}

/// The blocker spheres as the shader sees them: the BVH node array (device layout) and the input
/// spheres its leaves refer to (a leaf is gathered as its input sphere, an internal node taken whole as
/// its node sphere).
#[derive(Clone, Debug, Default)]
pub struct TwinBvh {
    pub nodes: Vec<GpuBvhNode>,
    pub spheres: Vec<Sphere>,
}

impl TwinBvh {
    /// The CPU reference LBVH over `spheres` (the GPU build's topology; node spheres within f32
    /// rounding of the GPU's). No spheres: an empty set.
    pub fn new(spheres: &[Sphere]) -> Result<Self, String> {
        if spheres.is_empty() {
            return Ok(Self::default());
        }
        let bvh = SphereBvh::build(spheres).map_err(|e| e.to_string())?;
        Ok(Self { nodes: bvh.gpu_nodes(), spheres: spheres.to_vec() })
    }

    /// A node array read back from the GPU (its first 2n − 1 nodes) with the n spheres it was built over.
    pub fn from_nodes(nodes: Vec<GpuBvhNode>, spheres: Vec<Sphere>) -> Self {
        Self { nodes, spheres }
    }

    pub fn is_empty(&self) -> bool {
        self.spheres.is_empty()
    }

    fn sphere(&self, v: u32) -> Sphere {
        let n = &self.nodes[v as usize];
        if n.left == INVALID && (n.sphere as usize) < self.spheres.len() {
            self.spheres[n.sphere as usize]
        } else {
            engine_blockers::traverse::node_sphere(n)
        }
    }
}

/// The shader's `lobes_node_is_small`: node sphere `s` seen from `p` may be taken whole in a mask
/// about `axis` (corner half-angle `corner`) when its angular diameter 2β is below `cells` (take_whole
/// × the gnomonic side of a finest cell) times cos(θ + β), the gnomonic map's tangential scale at its
/// far edge (θ: its centre's angle from the axis, θ + β capped at `corner`): every finest cell's
/// longest chord is at least that, so with take_whole ≤ 1 such a node covers no cell, nor does any
/// sphere under it, and taking it whole changes no covered cell; it can only mark partial the finest
/// cells its cap touches.
pub fn node_is_small(p: DVec3, axis: DVec3, s: &Sphere, cells: f64, corner: f64) -> bool {
    let d = s.center - p;
    let l = d.length();
    // Inside the node's sphere (or NaN): never taken whole.
    if s.radius.partial_cmp(&l) != Some(std::cmp::Ordering::Less) {
        return false;
    }
    let beta = (s.radius / l).asin();
    let far = (angle_between((d / l).to_array(), axis.to_array()) + beta).min(corner);
    2.0 * beta < cells * far.cos()
}

/// Everything the twin reads.
pub struct Twin {
    pub options: LobesOptions,
    pub product: ProductTable,
    pub hemisphere: HemisphereTable,
    pub cap: CapTable,
}

impl Twin {
    pub fn new(options: &LobesOptions) -> Result<Self, String> {
        let product = ProductTable {
            per_decade: engine_math::lobes::PRODUCT_SAMPLES_PER_DECADE,
            alpha_samples: engine_math::lobes::PRODUCT_ALPHA_SAMPLES,
            data: pairs(&read(MathTable::LobeProduct)?),
        };
        let hemisphere = HemisphereTable {
            per_decade: engine_math::lobes::HEMISPHERE_SAMPLES_PER_DECADE,
            y_samples: engine_math::lobes::HEMISPHERE_Y_SAMPLES,
            data: pairs(&read(MathTable::LobeHemisphere)?),
        };
        let cap = CapTable { k: read(MathTable::LobeCap)?.f32_values() };
        Ok(Self { options: options.clone(), product, hemisphere, cap })
    }

    /// c1 · c2 as one lobe (the shader's `lobes_mul`): the product table, or past it (an exponent
    /// above 1e5) the SG rule e_r = |e1 a1 + e2 a2| with p_r the peak.
    pub fn mul(&self, c1: &RgbLobe, c2: &RgbLobe) -> RgbLobe {
        let alpha = angle_between(c1.axis.to_array(), c2.axis.to_array());
        let [ln_rel, e_r] = if c1.e > MAX_EXPONENT || c2.e > MAX_EXPONENT {
            [0.0, (c1.e * c1.e + c2.e * c2.e + 2.0 * c1.e * c2.e * alpha.cos()).max(0.0).sqrt()]
        } else {
            self.product.lookup_raw(c1.e, c2.e, alpha)
        };
        let peak = product_log_peak(c1.e, c2.e, alpha);
        let p = if peak == f64::NEG_INFINITY { 0.0 } else { (peak + ln_rel).exp() };
        RgbLobe {
            axis: DVec3::from_array(product_axis(c1.axis.to_array(), c1.e, c2.axis.to_array(), c2.e)),
            e: e_r.max(0.0),
            s: [0, 1, 2].map(|k| c1.s[k] * c2.s[k] * p),
        }
    }

    /// ∫ over the hemisphere of n (the hemisphere table).
    pub fn hemisphere_integral(&self, c: &RgbLobe, n: DVec3) -> [f64; 3] {
        let v = self.hemisphere.hemisphere_integral(c.e, c.axis.dot(n).clamp(-1.0, 1.0));
        c.s.map(|s| s * v)
    }

    /// The cap lobe of half-angle α (energy: its integral is the cap's solid angle × scale).
    pub fn cap_lobe(&self, axis: DVec3, alpha: f64, scale: [f64; 3], energy: bool, sharpen: f64) -> RgbLobe {
        let e = self.cap.exponent(alpha) * sharpen as f32 as f64;
        let f = if energy { cap_solid_angle(alpha) * (e + 1.0) / (2.0 * PI) } else { 1.0 };
        RgbLobe { axis, e, s: scale.map(|s| s * f) }
    }

    fn cosine(n: DVec3) -> RgbLobe {
        RgbLobe { axis: n, e: 1.0, s: [1.0; 3] }
    }

    /// The planes' part of the environment's visibility under a constant environment (the shader's
    /// `lobes_env_planes`, whose radiance weights are then 1): the product over the plane blockers in front of
    /// `p` of 1 − o/π, o the cosine-weighted solid angle each hides ([`BlockerPlane::projected_solid_angle`]:
    /// exact for half-spaces and rectangles).
    pub fn env_planes(&self, p: DVec3, n: DVec3, planes: &[BlockerPlane]) -> f64 {
        planes.iter().map(|pl| (1.0 - pl.projected_solid_angle(p, n) / PI).clamp(0.0, 1.0)).product()
    }

    /// The environment's visibility under a constant environment (where the shader's prefiltered
    /// weights are that constant), `env=map`: the mask about n (half-angle [`super::MASK_MAX_HALF_ANGLE`],
    /// planes left out of it) against the cosine lobe gives the hidden light S and the free light V of its
    /// cells; with the band it leaves out, B = max(U − S − V, 0), the visibility is (V + B) / (S + V + B),
    /// times the planes' ([`Self::env_planes`]); 0 when one blocker covers the whole mask. (The shader takes
    /// E(n) = πL from the irradiance grid, the twin U = ∫cos from the table: they differ by the table's
    /// interpolation error.)
    pub fn env_visibility(&self, p: DVec3, n: DVec3, spheres: &TwinBvh, planes: &[BlockerPlane]) -> f64 {
        let v_hs = self.env_planes(p, n, planes);
        if spheres.is_empty() {
            return v_hs;
        }
        let rl = [Self::cosine(n)];
        let u = self.hemisphere_integral(&rl[0], n)[0];
        let mut out = LightTerms { u: [u; 3], outside: true, ..Default::default() };
        self.env_mask(&mut out, p, n, &rl, spheres, MaskKind::EnvMap);
        if out.hidden {
            return 0.0;
        }
        let band = (u - out.s[0] - out.free[0]).max(0.0);
        let all = out.s[0] + out.free[0] + band;
        if all > 0.0 {
            (out.free[0] + band) / all * v_hs
        } else {
            v_hs
        }
    }

    /// The environment's mask about n (half-angle [`super::MASK_MAX_HALF_ANGLE`], one level deeper
    /// than the lights', no planes, unit leaf weights) against the lobes `rl`.
    fn env_mask(&self, out: &mut LightTerms, p: DVec3, n: DVec3, rl: &[RgbLobe], spheres: &TwinBvh, kind: MaskKind) {
        let tan_half = super::MASK_MAX_HALF_ANGLE.tan();
        self.mask(out, p, n, n, tan_half, rl, spheres, &[], kind, self.options.depth + 1);
    }

    /// `env=lobes` at a receiver: the environment as the cosine lobes `env` (scale · max(axis·v, 0)^e),
    /// each taken as the shader takes it: U = Σ_k Σ_r ∫ R_r L_k (k outer, r inner, the shader's order),
    /// S through the environment's mask about n. Returns the terms and the planes' visibility v_hs:
    /// `light=lobes` adds max(U − S, 0) · v_hs ([`LightTerms::radiance`] × v_hs; 0 when hidden).
    pub fn env_lobe_terms(
        &self,
        r: &TwinReceiver,
        env: &[RgbLobe],
        spheres: &TwinBvh,
        planes: &[BlockerPlane],
    ) -> (LightTerms, f64) {
        let reflectance = self.reflectance(r);
        let rl: Vec<RgbLobe> = env.iter().flat_map(|l| reflectance.iter().map(|c| self.mul(c, l))).collect();
        let mut out = LightTerms { outside: true, ..Default::default() };
        out.products = rl.len() + r.specular.len();
        for c in &rl {
            let v = self.hemisphere_integral(c, r.n);
            (0..3).for_each(|k| out.u[k] += v[k]);
        }
        let v_hs = self.env_planes(r.p, r.n, planes);
        if !spheres.is_empty() {
            self.env_mask(&mut out, r.p, r.n, &rl, spheres, MaskKind::EnvLobes);
        }
        (out, v_hs)
    }

    /// The reflectance lobes f_r · cos at the receiver (Lambert; the specular lobe × cosine).
    pub fn reflectance(&self, r: &TwinReceiver) -> Vec<RgbLobe> {
        let mut out = vec![RgbLobe { axis: r.n, e: 1.0, s: r.rho.map(|x| x / PI) }];
        for spec in &r.specular {
            out.push(self.mul(spec, &Self::cosine(r.n)));
        }
        out
    }

    /// U and S of one light at a receiver (the shader's light loop body).
    pub fn light_terms(
        &self,
        r: &TwinReceiver,
        light: &TwinLight,
        spheres: &TwinBvh,
        planes: &[BlockerPlane],
    ) -> LightTerms {
        let o = &self.options;
        let (p, n) = (r.p, r.n);
        let d = light.center - p;
        let dist = d.length();
        let mut out = LightTerms::default();
        if dist <= light.radius.max(0.0) {
            return out;
        }
        out.outside = true;
        let axis = d / dist;
        let alpha = light.radius.max(0.0).atan2(((dist - light.radius) * (dist + light.radius)).max(0.0).sqrt());
        let light_lobe = self.cap_lobe(axis, alpha, light.radiance, o.energy, o.sharpen);
        let rl: Vec<RgbLobe> = self.reflectance(r).iter().map(|c| self.mul(c, &light_lobe)).collect();
        out.products = rl.len() + r.specular.len();
        for c in &rl {
            let v = self.hemisphere_integral(c, n);
            (0..3).for_each(|k| out.u[k] += v[k]);
        }
        let u_lum = lum(out.u);
        if u_lum.is_nan() || u_lum <= 0.0 || (spheres.is_empty() && planes.is_empty()) {
            return out;
        }
        let tan_half = (o.extent * alpha).min(super::MASK_MAX_HALF_ANGLE).tan();
        self.mask(&mut out, p, n, axis, tan_half, &rl, spheres, planes, MaskKind::Light, o.depth);
        out
    }

    /// The shader's `lobes_gather`: the blockers of the mask about `axis` (square half-side `tan_half`,
    /// maximal depth `depth`) as (direction, half-angle), from the cut with `take_whole` cells, retried
    /// with the threshold doubled while it overflows [`super::MAX_BLOCKERS`], at most `coarsen` times;
    /// and whether the last cut still overflowed (its narrowest caps dropped). The environment's masks see each sphere
    /// through SHEXP §6.2's rules with the radius scale α, a light's through the plain rules (the shader's
    /// `lobes_light_visit`).
    #[allow(clippy::too_many_arguments)]
    pub fn gather(
        &self,
        p: DVec3,
        n: DVec3,
        axis: DVec3,
        tan_half: f64,
        depth: u32,
        spheres: &TwinBvh,
        kind: MaskKind,
    ) -> (Vec<(DVec3, f64)>, bool) {
        let o = &self.options;
        let corner = (tan_half * 2f64.sqrt()).atan();
        let mut cells = o.take_whole as f32 as f64 * 2.0 * tan_half / (1u32 << depth.min(super::MAX_DEPTH)) as f64;
        let first = cells;
        // The lights' masks take α with `light_rule=alpha` (the twin has no scene: `auto` is plain here).
        let alpha = kind != MaskKind::Light || o.light_rule == super::LightRule::Alpha;
        let mut i = 0;
        loop {
            let (blockers, overflow, _) = Self::collect(p, n, axis, corner, cells, spheres, alpha, Keep::All);
            if !overflow {
                return (blockers, false);
            }
            if cells.is_nan() || cells <= 0.0 || i >= o.coarsen {
                break;
            }
            cells *= 2.0;
            i += 1;
        }
        // Still too many: the first cut again, keeping its widest caps: the widest width bins that fit together,
        // then the next bin's caps in traversal order while there is room.
        let (_, _, bins) = Self::collect(p, n, axis, corner, first, spheres, alpha, Keep::All);
        let (mut kept, mut full) = (0, 0);
        for (k, &count) in bins.iter().enumerate() {
            if kept + count > super::MAX_BLOCKERS {
                break;
            }
            kept += count;
            full = k + 1;
        }
        let keep = Keep::Widest {
            min_width: (-(full as f64)).exp2(),
            boundary_low: if full + 1 < WIDTH_BINS { (-((full + 1) as f64)).exp2() } else { 0.0 },
            boundary_room: super::MAX_BLOCKERS - kept,
        };
        let (blockers, _, _) = Self::collect(p, n, axis, corner, first, spheres, alpha, keep);
        (blockers, true)
    }

    /// The shader's `lobes_collect`: one cut (cells = 0: leaves only); `alpha`: the receiver rules with α; `keep`:
    /// which caps it keeps. Returns the blockers kept, whether one it would keep found no room, and the count of
    /// every visited cap per width bin ([`width_bin`]).
    #[allow(clippy::too_many_arguments)]
    fn collect(
        p: DVec3,
        n: DVec3,
        axis: DVec3,
        corner: f64,
        cells: f64,
        bvh: &TwinBvh,
        alpha: bool,
        keep: Keep,
    ) -> (Vec<(DVec3, f64)>, bool, [usize; WIDTH_BINS]) {
        let (min_width, boundary_low, mut boundary_room) = match keep {
            Keep::All => (0.0, 0.0, 0),
            Keep::Widest { min_width, boundary_low, boundary_room } => (min_width, boundary_low, boundary_room),
        };
        let cone = Cone::new(p, axis, corner);
        let mut bins = [0; WIDTH_BINS];
        let mut blockers = Vec::new();
        let mut overflow = false;
        let mut stack: Vec<u32> = if bvh.is_empty() { Vec::new() } else { vec![0] };
        while let Some(v) = stack.pop() {
            let node = &bvh.nodes[v as usize];
            let s = bvh.sphere(v);
            if !cone_intersects_sphere(&cone, &s) {
                continue;
            }
            let leaf = node.left == INVALID;
            if !(leaf || cells > 0.0 && node_is_small(p, axis, &s, cells, corner)) {
                // The shader's stack (32) never overflows on the LBVH (bvh.glsl).
                stack.push(node.right);
                stack.push(node.left);
                continue;
            }
            let b = if alpha { blocker_for_receiver_alpha(p, n, &s) } else { blocker_for_receiver(p, n, &s) };
            let Some(b) = b else { continue };
            if b.radius <= 0.0 {
                continue;
            }
            let d = b.center - p;
            let dir = if d.length() > 0.0 { d.normalize() } else { n };
            let beta = subtended_half_angle(p, &b);
            // The shader stores and compares sin(β/2) in f32.
            let width = (0.5 * beta).sin();
            bins[width_bin(width)] += 1;
            if width < min_width {
                if width < boundary_low || boundary_room == 0 {
                    continue;
                }
                boundary_room -= 1;
            } else if blockers.len() >= super::MAX_BLOCKERS {
                overflow = true;
                continue;
            }
            blockers.push((dir, beta));
        }
        (blockers, overflow, bins)
    }

    /// The lobe of a mask cell (the shader's `lobes_cell_lobe`): the cap lobe of its bounding cone
    /// (half-angle `gamma` about `centre`), scaled so that its integral is `weight` × the cell's solid angle.
    fn cell_lobe(&self, raw: &[DVec3; 4], centre: DVec3, gamma: f64, weight: f64) -> RgbLobe {
        let omega = triangle_solid_angle(raw[0], raw[1], raw[2]) + triangle_solid_angle(raw[0], raw[2], raw[3]);
        let e = self.cap.exponent(gamma);
        RgbLobe { axis: centre, e, s: [weight * omega * (e + 1.0) / (2.0 * PI); 3] }
    }

    /// One visibility product ∫_{Ω+} (c · cell) (the shader's `lobes_leaf_product`), counted in `out`; `None`
    /// (pruned, counted) when its luminance is below t_i × |U|.
    fn cell_product(
        &self,
        c: &RgbLobe,
        cell: &RgbLobe,
        n: DVec3,
        u_lum: f64,
        out: &mut LightTerms,
    ) -> Option<[f64; 3]> {
        let v = self.hemisphere_integral(&self.mul(c, cell), n);
        out.products += 1;
        if lum(v).abs() < self.options.threshold * u_lum.abs() {
            out.pruned += 1;
            return None;
        }
        Some(v)
    }

    /// The shader's `lobes_cell_negligible` (depth adaptation): whether a partial cell (bounding cone of
    /// half-angle `gamma` about `centre`) can add so little through the lobes `rl` that it is not refined: its
    /// bound 2 Ω_γ Σ_k |rl_k| max_cell rl_k (Ω_γ = 4π sin²(γ/2); the maximum at the cell's point nearest the
    /// lobe's axis) below [`ADAPT`] × t_i × |U|.
    fn cell_negligible(&self, rl: &[RgbLobe], centre: DVec3, gamma: f64, u_lum: f64) -> bool {
        let bound: f64 = rl
            .iter()
            .map(|c| {
                let theta = angle_between(c.axis.to_array(), centre.to_array());
                let near = if theta <= gamma { 1.0 } else { (theta - gamma).cos() };
                if near > 0.0 {
                    lum(c.s).abs() * (c.e * near.ln()).exp()
                } else {
                    0.0
                }
            })
            .sum();
        let omega = 4.0 * PI * (0.5 * gamma).sin().powi(2);
        2.0 * omega * bound < ADAPT * self.options.threshold * u_lum.abs()
    }

    /// The quad-tree mask about `axis` (square half-side `tan_half` in gnomonic coordinates) against
    /// the lobes `rl`: adds S, the counts and the flags to `out` (whose `u` is the pruning scale). A
    /// light's mask tests `planes` and weighs its leaves by depth ([`LobesOptions::light_weights`]); the
    /// environment's with `env=map` also adds its free light to [`LightTerms::free`].
    #[allow(clippy::too_many_arguments)]
    pub fn mask(
        &self,
        out: &mut LightTerms,
        p: DVec3,
        n: DVec3,
        axis: DVec3,
        tan_half: f64,
        rl: &[RgbLobe],
        spheres: &TwinBvh,
        planes: &[BlockerPlane],
        kind: MaskKind,
        depth: u32,
    ) {
        let o = &self.options;
        let light = kind == MaskKind::Light;
        let u_lum = lum(out.u);
        let (blockers, overflow) = self.gather(p, n, axis, tan_half, depth, spheres, kind);
        out.overflow |= overflow;
        let (t, b) = orthonormal_basis(axis);
        let tested: &[BlockerPlane] = if light { planes } else { &[] };
        // The shader's cell state, counting its work (each blocker and plane tested, in its order). Only the
        // blockers in `subset` (those that met the parent cell) are tested; on return it holds those that meet
        // this cell (unchanged when one covers it).
        let state = |q: &[DVec3; 4], centre: DVec3, gamma: f64, subset: &mut u64, work: &mut u32| -> u8 {
            let mut partial = false;
            let mut met = 0u64;
            for (i, &(c, beta)) in blockers.iter().enumerate() {
                if *subset & (1u64 << i) == 0 {
                    continue;
                }
                *work += 1;
                if angle_between(c.to_array(), centre.to_array()) >= beta + gamma {
                    continue;
                }
                let cb = beta.cos();
                if q.iter().all(|x| x.dot(c) >= cb) {
                    return 2;
                }
                partial = true;
                met |= 1u64 << i;
            }
            *subset = met;
            for pl in tested {
                *work += 1;
                if !pl.blocks_receiver(p) {
                    continue;
                }
                match pl.edge_normals(p) {
                    None => {
                        let k = q.iter().filter(|x| pl.normal.dot(**x) < 0.0).count();
                        if k == 4 {
                            return 2;
                        }
                        if k > 0 {
                            partial = true;
                        }
                    }
                    Some(e) => {
                        let outside: Vec<usize> =
                            e.iter().map(|ek| q.iter().filter(|x| x.dot(*ek) < 0.0).count()).collect();
                        if outside.iter().all(|&k| k == 0) {
                            return 2;
                        }
                        if !outside.contains(&4) {
                            partial = true;
                        }
                    }
                }
            }
            u8::from(partial)
        };
        let depth_max = depth.min(super::MAX_DEPTH);
        // The gather holds at most MAX_BLOCKERS = 64 blockers: one bit each.
        let all = if blockers.len() >= 64 { u64::MAX } else { (1u64 << blockers.len()) - 1 };
        let mut stack: Vec<(u32, u32, u32, u64)> = vec![(0, 0, 0, all)];
        let mut work = 0u32;
        while let Some((d, ix, iy, mut subset)) = stack.pop() {
            let h = 1.0 / (1u32 << d) as f64;
            let cx = -1.0 + (2.0 * ix as f64 + 1.0) * h;
            let cy = -1.0 + (2.0 * iy as f64 + 1.0) * h;
            let raw: [DVec3; 4] = [0, 1, 2, 3].map(|c| {
                let x = cx + if c == 1 || c == 2 { h } else { -h };
                let y = cy + if c >= 2 { h } else { -h };
                axis + tan_half * (x * t + y * b)
            });
            let q = raw.map(|x| x.normalize());
            if !q.iter().any(|x| x.dot(n) > 0.0) {
                continue;
            }
            let centre = (axis + tan_half * (cx * t + cy * b)).normalize();
            let gamma = q.iter().map(|x| angle_between(centre.to_array(), x.to_array())).fold(0.0, f64::max);
            work += 4;
            let st = state(&q, centre, gamma, &mut subset, &mut work);
            // A free cell's light (the environment's mask, env=map).
            if st == 0 && kind == MaskKind::EnvMap {
                if let Some(v) =
                    self.cell_product(&rl[0], &self.cell_lobe(&raw, centre, gamma, o.weight), n, u_lum, out)
                {
                    (0..3).for_each(|k| out.free[k] += v[k]);
                }
                continue;
            }
            let refine = work < o.budget;
            // A cell the budget keeps from splitting (the shader counts its receiver).
            out.budget_limited |= !refine && ((st == 2 && d < o.split.min(depth_max)) || (st == 1 && d < depth_max));
            if st == 2 && d == 0 {
                // The whole mask covered: hidden (S = U).
                out.s = out.u;
                out.hidden = true;
                return;
            }
            if st == 2 && d < o.split.min(depth_max) && refine {
                for k in 0..4u32 {
                    stack.push((d + 1, 2 * ix + (k & 1), 2 * iy + (k >> 1), subset));
                }
                continue;
            }
            match st {
                0 => continue,
                1 if d < depth_max
                    && refine
                    && (kind == MaskKind::EnvLobes || !self.cell_negligible(rl, centre, gamma, u_lum)) =>
                {
                    // Pushed in the shader's order (k = 0..3), popped last first.
                    for k in 0..4u32 {
                        stack.push((d + 1, 2 * ix + (k & 1), 2 * iy + (k >> 1), subset));
                    }
                    continue;
                }
                1 if o.leaves == Leaves::Aggressive => continue,
                _ => {}
            }
            let leaf_weight = if st == 1 && o.leaves == Leaves::Half { 0.5 } else { 1.0 };
            out.leaves += 1;
            let w_d = if light { o.light_weights[d as usize] } else { 1.0 };
            if kind == MaskKind::EnvMap {
                // The leaf's light at unit weight: its covered share hidden, the rest free.
                if let Some(v) =
                    self.cell_product(&rl[0], &self.cell_lobe(&raw, centre, gamma, o.weight), n, u_lum, out)
                {
                    (0..3).for_each(|k| out.s[k] += leaf_weight * v[k]);
                    (0..3).for_each(|k| out.free[k] += (1.0 - leaf_weight) * v[k]);
                }
                continue;
            }
            let leaf = self.cell_lobe(&raw, centre, gamma, leaf_weight * o.weight * w_d);
            for c in rl {
                let Some(v) = self.cell_product(c, &leaf, n, u_lum, out) else { continue };
                (0..3).for_each(|k| out.s[k] += v[k]);
                if light && w_d > 0.0 {
                    out.s_by_depth[d as usize] += v[1] / w_d;
                }
            }
        }
    }
}
