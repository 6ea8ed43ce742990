//! The f64 twin of `shaders-glsl/shade/shexp/shade.glsl` per receiver (spheres, planes, diffuse):
//! the same tables (read from the asset files the GPU uploads), the same §6.2 rules, the same exp
//! methods (engine-math `shexp`), in f64. The GPU cut at `theta_max = 0` visits every leaf in the
//! tangent half-space, which is what [`Twin::log_visibility`] does over the sphere list.

use super::{ExpChoice, ShexpOptions};
use engine_blockers::geom::{blocker_for_receiver, Sphere};
use engine_blockers::plane::BlockerPlane;
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
        let n = self.options.order;
        let mut v = vec![0.0; n * n];
        zh_rotate_star_into(&self.circles.lookup_u(u), axis.to_array(), &mut v);
        f.iter_mut().zip(&v).for_each(|(a, b)| *a += b);
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
            .filter_map(|s| sphere_circle(p, n, s))
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
        let (f, mut count, large) = self.log_visibility_split(p, n, spheres);
        let mut g = if count == 0 {
            let mut g = vec![0.0; f.len()];
            g[0] = SQRT_4PI;
            g
        } else {
            self.exp(&f)
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
        let h = irradiance_weighting(self.options.order, n.to_array());
        let pv = if count == 0 { h.clone() } else { self.tensor.product(&h, &g) };
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let shaded = [0, 1, 2].map(|c| rho[c] * dot(&self.env[c], &pv).max(0.0));
        let free = [0, 1, 2].map(|c| dot(&self.env[c], &h));
        (shaded, free)
    }
}

/// The circle a sphere blocks at receiver `p` (normal `n`) after the §6.2 rules: (u = 1 − cos θ, axis to its
/// centre), `None` when culled or of no radius (shn_sphere_u in shexp_n.glsl; u = 1 inside it).
fn sphere_circle(p: DVec3, n: DVec3, s: &Sphere) -> Option<(f64, DVec3)> {
    let b = blocker_for_receiver(p, n, s)?;
    if b.radius <= 0.0 {
        return None;
    }
    let d = b.center.distance(p);
    let u = if d <= b.radius {
        1.0
    } else {
        let s = b.radius / d;
        s * s / (1.0 + (1.0 - s * s).max(0.0).sqrt())
    };
    Some((u, b.center - p))
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
