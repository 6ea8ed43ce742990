//! The f64 twin of `shaders-glsl/shade/shexp/shade.glsl` per receiver (spheres, planes, diffuse):
//! the same tables (read from the asset files the GPU uploads), the same §6.2 rules, the same exp
//! methods (engine-math `shexp`), in f64. The GPU cut at `theta_max = 0` visits every leaf in the
//! tangent half-space, which is what [`Twin::log_visibility`] does over the sphere list.

use super::{ExpChoice, ShexpOptions};
use engine_blockers::geom::{blocker_for_receiver, Sphere};
use engine_blockers::plane::BlockerPlane;
use engine_math::envmap::LatLongMap;
use engine_math::sh::{irradiance_weighting, project_latlong, zh_rotate_star_into, CircleLogTable, ShTensor, SQRT_4PI};
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
}

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
        })
    }

    fn add_circle(&self, f: &mut [f64], u: f64, axis: DVec3) {
        let n = self.options.order;
        let mut v = vec![0.0; n * n];
        zh_rotate_star_into(&self.circles.lookup_u(u), axis.to_array(), &mut v);
        f.iter_mut().zip(&v).for_each(|(a, b)| *a += b);
    }

    /// Σ of the blockers' log vectors at receiver `p` with unit normal `n`, and how many blocked.
    pub fn log_visibility(&self, p: DVec3, n: DVec3, spheres: &[Sphere], planes: &[BlockerPlane]) -> (Vec<f64>, usize) {
        let c = self.options.order * self.options.order;
        let mut f = vec![0.0; c];
        let mut count = 0;
        for s in spheres {
            let Some(b) = blocker_for_receiver(p, n, s) else { continue };
            let d = b.center.distance(p);
            if b.radius <= 0.0 {
                continue;
            }
            let u = if d <= b.radius {
                1.0
            } else {
                let s = b.radius / d;
                s * s / (1.0 + (1.0 - s * s).max(0.0).sqrt())
            };
            self.add_circle(&mut f, u, b.center - p);
            count += 1;
        }
        for pl in planes {
            if !pl.blocks_receiver(p) {
                continue;
            }
            match pl.corners() {
                None => self.add_circle(&mut f, 1.0, -pl.normal),
                Some(k) => {
                    let a = k.map(|x| x - p);
                    let omega = triangle_solid_angle(a[0], a[1], a[2]) + triangle_solid_angle(a[0], a[2], a[3]);
                    let centre = pl.rect.map(|r| r.0).unwrap_or(p) - p;
                    self.add_circle(&mut f, (omega / (2.0 * PI)).clamp(0.0, 1.0), cone_mean_direction(&a, centre));
                }
            }
            count += 1;
        }
        (f, count)
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

    /// The visibility vector at `p` (exactly 1 without blockers, as the shader).
    pub fn visibility(&self, p: DVec3, n: DVec3, spheres: &[Sphere], planes: &[BlockerPlane]) -> (Vec<f64>, usize) {
        let (f, count) = self.log_visibility(p, n, spheres, planes);
        if count == 0 {
            let mut g = vec![0.0; f.len()];
            g[0] = SQRT_4PI;
            return (g, 0);
        }
        (self.exp(&f), count)
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
