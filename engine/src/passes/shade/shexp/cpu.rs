//! The f64 twin of `shaders-glsl/shade/shexp/shade.glsl` per receiver (spheres, planes, diffuse):
//! the same tables (read from the asset files the GPU uploads), the same §6.2 rules, the same exp
//! methods (engine-math `shexp`), in f64. The GPU cut at `theta_max = 0` visits every leaf in the
//! tangent half-space, which is what [`Twin::log_visibility`] does over the sphere list. The receiver
//! clusters' pass (clusters.glsl) has its twin in [`Twin::cluster_cut`] and [`Twin::visibility_clustered`].

use super::{ExpChoice, ShexpOptions};
use engine_blockers::bvh::GpuBvhNode;
use engine_blockers::geom::{blocker_for_receiver, blocker_for_receiver_alpha, Sphere};
use engine_blockers::plane::BlockerPlane;
use engine_blockers::traverse;
use engine_math::envmap::LatLongMap;
use engine_math::sh::{
    circle_visibility, irradiance_weighting, project_latlong, theta_of_u, zh_rotate_star_into, CircleLogTable,
    ShTensor, SQRT_4PI,
};
use engine_math::shexp::{exp_hyb, exp_ol, exp_ps_star, OlTable};
use engine_math::table_gen::MathTable;
use engine_math::tables::Table;
use glam::DVec3;
use std::f64::consts::PI;

/// Everything the twin needs at one order.
pub struct Twin {
    pub options: ShexpOptions,
    pub tensor: ShTensor,
    pub ol: OlTable,
    pub circles: CircleLogTable,
    /// The windowed order-n projection of the environment, per RGB channel.
    pub env: [Vec<f64>; 3],
    /// `large=product`'s threshold in u (as the GPU's, in f32).
    pub large_u: f64,
}

/// At most this many large spheres multiply per receiver (SHEXP_MAX_LARGE in shade.glsl).
pub const MAX_LARGE: usize = 4;

fn read(t: MathTable) -> Result<Table, String> {
    let path = crate::tables::default_dir().join(format!("{}.bin", t.name()));
    Table::read(&path).map_err(|e| format!("{}: {e}", path.display()))
}

/// The OL table as the GPU reads it: the file's f32 (a, b), uniform in ‖f̂‖ over [0, hi].
pub fn ol_from_table(n: usize, t: &Table) -> OlTable {
    let v = t.f32_values();
    let count = v.len() / 2;
    let hi = t.header.axes[0].hi;
    OlTable {
        n,
        theta_stop: 0.0,
        norms: (0..count).map(|k| hi * k as f64 / (count - 1) as f64).collect(),
        a: (0..count).map(|k| v[2 * k] as f64).collect(),
        b: (0..count).map(|k| v[2 * k + 1] as f64).collect(),
    }
}

/// The circle log table as the GPU reads it: per entry n ratios and u, segment-major.
pub fn circles_from_table(n: usize, t: &Table) -> CircleLogTable {
    let v = t.f32_values();
    let segments = t.header.axes[0].count as usize;
    let samples = t.header.axes[1].count as usize;
    let mut knots: Vec<f64> = (0..segments).map(|s| v[s * samples * (n + 1) + n] as f64).collect();
    knots.push(v[(segments * samples - 1) * (n + 1) + n] as f64);
    let ratio =
        (0..segments * samples).flat_map(|e| (0..n).map(move |l| (e, l))).map(|(e, l)| v[e * (n + 1) + l] as f64);
    CircleLogTable { n, knots, ratio: ratio.collect() }
}

impl Twin {
    pub fn new(options: &ShexpOptions, env: &LatLongMap) -> Result<Self, String> {
        let n = options.order;
        let ol = ol_from_table(n, &read(MathTable::ShOl(n))?);
        let circles = circles_from_table(n, &read(MathTable::ShCircleLog(n))?);
        Ok(Self {
            options: options.clone(),
            tensor: ShTensor::new(n),
            ol,
            circles,
            env: project_latlong(env, n, options.window()),
            large_u: super::large_u(options) as f32 as f64,
        })
    }

    fn add_circle(&self, f: &mut [f64], u: f64, axis: DVec3) {
        self.add_circle_weighted(f, u, axis, &[1.0; 8]);
    }

    /// The circle's log scaled per band by a ratio vector (SHEXP Eq. 38).
    fn add_circle_weighted(&self, f: &mut [f64], u: f64, axis: DVec3, w: &[f64; 8]) {
        let n = self.options.order;
        let mut v = vec![0.0; n * n];
        let fstar: Vec<f64> = self.circles.lookup_u(u).iter().zip(w).map(|(a, b)| a * b).collect();
        zh_rotate_star_into(&fstar, axis.to_array(), &mut v);
        f.iter_mut().zip(&v).for_each(|(a, b)| *a += b);
    }

    /// The receiver-cluster pass (shaders-glsl/shade/shexp/clusters.glsl) for one cluster: `items` its
    /// receivers' positions in the shader's order (row-major in the tile, or vertex order), `nodes` the
    /// GPU's BVH over `sphere_count` spheres. `None` when the cut exceeds [`super::CLUSTER_CAP`] even after
    /// [`super::CLUSTER_COARSEN`] coarser retries (the shader then cuts per receiver). The bounding sphere, p*, the cut and W as the shader computes them.
    pub fn cluster_cut(&self, nodes: &[GpuBvhNode], sphere_count: u32, items: &[DVec3]) -> Option<ClusterCut> {
        self.cluster_cut_grown(nodes, sphere_count, items, 0.0)
    }

    /// [`Self::cluster_cut`] with the bounding sphere's radius grown by `reach` (`pixel_clusters=world`: the
    /// items are a vertex cluster's vertices and `reach` its [`super::vertex_clusters::pixel_reach`]).
    pub fn cluster_cut_grown(
        &self,
        nodes: &[GpuBvhNode],
        sphere_count: u32,
        items: &[DVec3],
        reach: f64,
    ) -> Option<ClusterCut> {
        if items.is_empty() || sphere_count == 0 {
            return Some(ClusterCut {
                entries: Vec::new(),
                p_star: DVec3::ZERO,
                receiver: Sphere::new(DVec3::ZERO, 0.0),
            });
        }
        let (lo, hi) =
            items.iter().fold((DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)), |(a, b), p| (a.min(*p), b.max(*p)));
        let centre = 0.5 * (lo + hi);
        let radius = items.iter().map(|p| p.distance(centre)).fold(0.0, f64::max) + reach;
        let mut ps = items[0];
        for p in items {
            if p.distance(centre) < ps.distance(centre) {
                ps = *p;
            }
        }
        let o = &self.options;
        let mut sin_max = o.theta_max_deg.to_radians().sin() as f32 as f64;
        let sin_min = o.theta_min_deg.to_radians().sin() as f32 as f64;
        let receiver = Sphere::new(centre, radius);
        // Past the cap, retried with sin θ_max doubled (as the shader: at most CLUSTER_COARSEN times, up to 1).
        let mut attempt = 0;
        let cut = loop {
            let cut = traverse::cut_dropping(
                nodes,
                sphere_count,
                &receiver,
                sin_max,
                |s| s.radius < sin_min * (s.center.distance(centre) - radius),
                traverse::STACK_SIZE,
            );
            let fits = cut.nodes.len() <= super::CLUSTER_CAP as usize;
            if fits || attempt >= super::CLUSTER_COARSEN || sin_max <= 0.0 || sin_max >= 1.0 {
                break cut;
            }
            sin_max = (2.0 * sin_max).min(1.0);
            attempt += 1;
        };
        if cut.nodes.len() > super::CLUSTER_CAP as usize {
            return None;
        }
        let entries = cut
            .nodes
            .iter()
            .map(|&v| {
                let node = &nodes[v as usize];
                let s = traverse::node_sphere(node);
                let w = if traverse::is_leaf(node) || !o.ratio_vectors {
                    [1.0; 8]
                } else {
                    self.ratio_vector(nodes, v, ps, sin_min)
                };
                (s, w)
            })
            .collect();
        Some(ClusterCut { entries, p_star: ps, receiver })
    }

    /// W of node `v` at p* (SHEXP Eq. 37): per band the least-squares scale of the node sphere's raw log
    /// f_b onto the sum f_d of its leaves' raw logs (leaves below θ_min from p* dropped); 1 where f_b
    /// vanishes.
    fn ratio_vector(&self, nodes: &[GpuBvhNode], v: u32, ps: DVec3, sin_min: f64) -> [f64; 8] {
        let mut w = [1.0; 8];
        let s = traverse::node_sphere(&nodes[v as usize]);
        let ub = sphere_u(ps, &s);
        if !(ub > 0.0 && ub < 1.0) {
            return w;
        }
        let n = self.options.order;
        let mut fb = vec![0.0; n * n];
        self.add_circle(&mut fb, ub, s.center - ps);
        let mut fd = vec![0.0; n * n];
        for u in traverse::leaves_under(nodes, v, |q| q.radius < sin_min * q.center.distance(ps), traverse::STACK_SIZE)
        {
            let q = traverse::node_sphere(&nodes[u as usize]);
            self.add_circle(&mut fd, sphere_u(ps, &q), q.center - ps);
        }
        for (l, wl) in w.iter_mut().enumerate().take(n) {
            let band = l * l..(l + 1) * (l + 1);
            let num: f64 = band.clone().map(|i| fb[i] * fd[i]).sum();
            let den: f64 = band.map(|i| fb[i] * fb[i]).sum();
            if den > 1e-30 {
                *wl = num / den;
            }
        }
        w
    }

    /// The visibility vector at receiver `p` of a cluster from its cut (`visibility` with the cluster's
    /// entries, each node's log scaled by its W, in place of the receiver's own cut).
    pub fn visibility_clustered(
        &self,
        p: DVec3,
        n: DVec3,
        cut: &ClusterCut,
        planes: &[BlockerPlane],
    ) -> (Vec<f64>, usize) {
        let c = self.options.order * self.options.order;
        let mut f = vec![0.0; c];
        let mut count = 0;
        let mut large = Vec::new();
        for (s, w) in &cut.entries {
            let Some((u, axis)) = sphere_circle(p, n, s, self.options.alpha_scale) else { continue };
            if u > self.large_u && large.len() < MAX_LARGE {
                large.push((u, axis));
                continue;
            }
            self.add_circle_weighted(&mut f, u, axis, w);
            count += 1;
        }
        self.finish_visibility(p, f, count, large, planes)
    }

    /// Σ of the sphere blockers' log vectors at receiver `p` with unit normal `n`, how many, and the
    /// large spheres (u, axis) that multiply instead (`large=product`, in visit order).
    pub fn log_visibility_split(&self, p: DVec3, n: DVec3, spheres: &[Sphere]) -> (Vec<f64>, usize, Vec<(f64, DVec3)>) {
        let c = self.options.order * self.options.order;
        let mut f = vec![0.0; c];
        let mut count = 0;
        let mut large = Vec::new();
        for (u, axis) in self.sphere_circles(p, n, spheres) {
            if u > self.large_u && large.len() < MAX_LARGE {
                large.push((u, axis));
                continue;
            }
            self.add_circle(&mut f, u, axis);
            count += 1;
        }
        (f, count, large)
    }

    /// The circles of the spheres that block `p` (in list order), those subtending a half-angle below
    /// `theta_min` dropped first (the shader drops them, and whole BVH nodes that small, in its cut).
    fn sphere_circles(&self, p: DVec3, n: DVec3, spheres: &[Sphere]) -> Vec<(f64, DVec3)> {
        let sin_min = self.options.theta_min_deg.to_radians().sin() as f32 as f64;
        spheres
            .iter()
            .filter(|s| s.radius >= sin_min * s.center.distance(p))
            .filter_map(|s| sphere_circle(p, n, s, self.options.alpha_scale))
            .collect()
    }

    /// [`Self::log_visibility_split`] without the large spheres.
    pub fn log_visibility(&self, p: DVec3, n: DVec3, spheres: &[Sphere]) -> (Vec<f64>, usize) {
        let (f, count, _) = self.log_visibility_split(p, n, spheres);
        (f, count)
    }

    /// The plane blockers' visibility factors at `p`: (u, axis) of the circle each multiplies by.
    pub fn plane_circles(&self, p: DVec3, planes: &[BlockerPlane]) -> Vec<(f64, DVec3)> {
        planes
            .iter()
            .filter(|pl| pl.blocks_receiver(p))
            .map(|pl| match pl.corners() {
                None => (1.0, -pl.normal),
                Some(k) => {
                    let a = k.map(|x| x - p);
                    let omega = triangle_solid_angle(a[0], a[1], a[2]) + triangle_solid_angle(a[0], a[2], a[3]);
                    let centre = pl.rect.map(|r| r.0).unwrap_or(p) - p;
                    ((omega / (2.0 * PI)).clamp(0.0, 1.0), cone_mean_direction(&a, centre))
                }
            })
            .collect()
    }

    /// `exp*` of a log vector by the configured method; non-finite results are no visibility.
    pub fn exp(&self, f: &[f64]) -> Vec<f64> {
        let o = &self.options;
        let g = match o.exp {
            ExpChoice::Hyb => exp_hyb(&self.tensor, &self.ol, f, o.hyb_target),
            ExpChoice::Ol => exp_ol(&self.ol, f),
            ExpChoice::PsStar => exp_ps_star(&self.tensor, f, o.ps_degree),
        };
        if g.iter().all(|v| v.is_finite()) {
            g
        } else {
            vec![0.0; g.len()]
        }
    }

    /// The visibility vector at `p` (exactly 1 without blockers, as the shader): the exponential of the
    /// spheres' summed log, times the exact projection of each plane's circle visibility.
    pub fn visibility(&self, p: DVec3, n: DVec3, spheres: &[Sphere], planes: &[BlockerPlane]) -> (Vec<f64>, usize) {
        if self.options.accumulate_product {
            return self.product_visibility(p, n, spheres, planes);
        }
        let (f, count, large) = self.log_visibility_split(p, n, spheres);
        self.finish_visibility(p, f, count, large, planes)
    }

    /// [`Self::visibility`] (log accumulation) with the spheres' summed log exponentiated by `exp` instead of
    /// the configured method (e.g. the exact exp* of the error decomposition, `shexp_errors`).
    pub fn visibility_with_exp(
        &self,
        p: DVec3,
        n: DVec3,
        spheres: &[Sphere],
        planes: &[BlockerPlane],
        exp: &dyn Fn(&[f64]) -> Vec<f64>,
    ) -> (Vec<f64>, usize) {
        let (f, count, large) = self.log_visibility_split(p, n, spheres);
        self.finish_visibility_by(p, f, count, large, planes, exp)
    }

    /// g from the summed sphere log `f` of `count` spheres: its exponential (1 without spheres), times each
    /// large sphere's and each plane's exact projected visibility.
    fn finish_visibility(
        &self,
        p: DVec3,
        f: Vec<f64>,
        count: usize,
        large: Vec<(f64, DVec3)>,
        planes: &[BlockerPlane],
    ) -> (Vec<f64>, usize) {
        self.finish_visibility_by(p, f, count, large, planes, &|f| self.exp(f))
    }

    fn finish_visibility_by(
        &self,
        p: DVec3,
        f: Vec<f64>,
        mut count: usize,
        large: Vec<(f64, DVec3)>,
        planes: &[BlockerPlane],
        exp: &dyn Fn(&[f64]) -> Vec<f64>,
    ) -> (Vec<f64>, usize) {
        let mut g = if count == 0 {
            let mut g = vec![0.0; f.len()];
            g[0] = SQRT_4PI;
            g
        } else {
            exp(&f)
        };
        for (u, axis) in large.into_iter().chain(self.plane_circles(p, planes)) {
            let v = circle_visibility(self.options.order, theta_of_u(u), axis.to_array());
            g = if count == 0 { v } else { self.tensor.product(&g, &v) };
            count += 1;
        }
        if !g.iter().all(|v| v.is_finite()) {
            g.iter_mut().for_each(|v| *v = 0.0);
        }
        (g, count)
    }

    /// `accumulate=product`: g multiplied by every sphere's (in list order: the GPU's is the BVH's, and
    /// truncated products are not associative, so the twin matches it for up to two spheres per receiver),
    /// then by each plane's, projected visibility.
    fn product_visibility(&self, p: DVec3, n: DVec3, spheres: &[Sphere], planes: &[BlockerPlane]) -> (Vec<f64>, usize) {
        let order = self.options.order;
        let mut circles = self.sphere_circles(p, n, spheres);
        circles.extend(self.plane_circles(p, planes));
        let mut g = vec![0.0; order * order];
        g[0] = SQRT_4PI;
        for (k, (u, axis)) in circles.iter().enumerate() {
            let v = circle_visibility(order, theta_of_u(*u), axis.to_array());
            g = if k == 0 { v } else { self.tensor.product(&g, &v) };
        }
        if !g.iter().all(|v| v.is_finite()) {
            g.iter_mut().for_each(|v| *v = 0.0);
        }
        (g, circles.len())
    }

    /// Diffuse radiance `ρ max(L·(H(N) * g), 0)` (`diffuse=sh`) and the unshadowed `L·H(N)` per channel.
    pub fn shade_diffuse(
        &self,
        p: DVec3,
        n: DVec3,
        rho: [f64; 3],
        spheres: &[Sphere],
        planes: &[BlockerPlane],
    ) -> ([f64; 3], [f64; 3]) {
        let (g, count) = self.visibility(p, n, spheres, planes);
        self.shade_diffuse_with(&g, count, n, rho)
    }

    /// [`Self::shade_diffuse`] from a visibility vector `g` of `count` blockers.
    pub fn shade_diffuse_with(&self, g: &[f64], count: usize, n: DVec3, rho: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        let h = irradiance_weighting(self.options.order, n.to_array());
        let pv = if count == 0 { h.clone() } else { self.tensor.product(&h, g) };
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let free = [0, 1, 2].map(|c| dot(&self.env[c], &h));
        let e = [0, 1, 2].map(|c| dot(&self.env[c], &pv));
        let e = if count == 0 { e } else { ringing_fallback(e, free, g[0]) };
        let shaded = [0, 1, 2].map(|c| rho[c] * e[c].max(0.0));
        (shaded, free)
    }
}

/// The shadowed irradiance `e` (order n, per channel) where ringing took a channel to 0 or below: the
/// visibility's mean over the sphere (`g_0 Y_0`, clamped at 0) times the unshadowed irradiance `free`, for all
/// three channels; elsewhere `e` itself. In crevices the truncated product falls below 0 where the truth is small
/// but positive (shexp's black pixels of the artefact gate, cloth at 40×30); GLSL twin in shade/shexp/shade.glsl.
pub fn ringing_fallback(e: [f64; 3], free: [f64; 3], g0: f64) -> [f64; 3] {
    if e.iter().all(|&x| x > 0.0) {
        return e;
    }
    let mean = (g0 * 0.5 / std::f64::consts::PI.sqrt()).max(0.0);
    free.map(|f| mean * f.max(0.0))
}

/// One receiver cluster's cut ([`Twin::cluster_cut`]): each blocker sphere with its ratio vector (w_l, l < 8).
#[derive(Clone, Debug)]
pub struct ClusterCut {
    pub entries: Vec<(Sphere, [f64; 8])>,
    /// The central point p* where W was computed.
    pub p_star: DVec3,
    /// The receivers' bounding sphere the cut was made for.
    pub receiver: Sphere,
}

/// The circle a sphere blocks at receiver `p` (normal `n`) after the §6.2 rules (with the radius scale α when
/// `alpha_scale`): (u = 1 − cos θ, axis to its centre), `None` when culled or of no radius.
fn sphere_circle(p: DVec3, n: DVec3, s: &Sphere, alpha_scale: bool) -> Option<(f64, DVec3)> {
    let b = if alpha_scale { blocker_for_receiver_alpha(p, n, s)? } else { blocker_for_receiver(p, n, s)? };
    if b.radius <= 0.0 {
        return None;
    }
    Some((sphere_u(p, &b), b.center - p))
}

/// u = 1 − cos θ of sphere `b` seen from `p` without cancellation, 1 on or inside it, 0 without radius
/// (shn_sphere_u in shexp_n.glsl).
fn sphere_u(p: DVec3, b: &Sphere) -> f64 {
    if b.radius <= 0.0 {
        return 0.0;
    }
    let d = b.center.distance(p);
    if d <= b.radius {
        1.0
    } else {
        let s = b.radius / d;
        s * s / (1.0 + (1.0 - s * s).max(0.0).sqrt())
    }
}

/// Solid angle of the triangle (a, b, c) seen from the origin (Van Oosterom–Strackee).
pub fn triangle_solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = a.dot(b.cross(c)).abs();
    let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * num.atan2(den)
}

/// The mean direction `∫ ω dω` over the cone from the origin through the polygon `a` (Arvo 1994:
/// ½ Σ_edges Θ_e n_e), oriented towards `towards` (`towards` itself when it vanishes).
pub fn cone_mean_direction(a: &[DVec3; 4], towards: DVec3) -> DVec3 {
    let mut mean = DVec3::ZERO;
    for k in 0..4 {
        let x = a[k].cross(a[(k + 1) % 4]);
        let lx = x.length();
        if lx > 0.0 {
            mean += 0.5 * lx.atan2(a[k].dot(a[(k + 1) % 4])) * x / lx;
        }
    }
    if mean.dot(towards) < 0.0 {
        mean = -mean;
    }
    if mean.length_squared() > 0.0 {
        mean
    } else {
        towards
    }
}

#[cfg(test)]
mod tests {
    use super::ringing_fallback;

    /// Positive irradiance passes through; a channel at or below 0 gives the mean visibility times the unshadowed
    /// irradiance for all three (a constant visibility v has g_0 = v √(4π), so its mean is v).
    #[test]
    fn ringing_fallback_only_where_a_channel_is_not_positive() {
        let free = [2.0, 1.0, 0.5];
        assert_eq!(ringing_fallback([0.3, 0.2, 0.1], free, 1.0), [0.3, 0.2, 0.1]);
        let g0 = 0.25 * (4.0 * std::f64::consts::PI).sqrt();
        for e in [[0.3, -0.1, 0.1], [0.0, 0.0, 0.0], [-1.0, -1.0, -1.0]] {
            let f = ringing_fallback(e, free, g0);
            for c in 0..3 {
                assert!((f[c] - 0.25 * free[c]).abs() < 1e-12, "{e:?}: {f:?}");
            }
        }
        // A negative mean (an exp method's error) clamps at 0, as do negative unshadowed channels.
        assert_eq!(ringing_fallback([-1.0; 3], free, -0.5), [0.0; 3]);
        assert_eq!(ringing_fallback([-1.0; 3], [-1.0, 1.0, 1.0], g0)[0], 0.0);
    }
}
