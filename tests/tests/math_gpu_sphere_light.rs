//! GPU (f32 GLSL, shaders-glsl/common/sphere_light.glsl) vs CPU (f64, engine_math::sphere_light)
//! twins through shaders-glsl/tests/sphere_light_twin.comp (layout documented there: 20 floats in,
//! 10 out per case). The CPU twin sees exactly the f32 inputs.
//!
//! Each tolerance is the f32 arithmetic bound of the shader's formula (in units of EPS = 2⁻²⁴, with
//! `exp` accurate to (EXP_ULP + 2|x|) ulp, twin/mod.rs) plus, where the shader first derives
//! geometry from its inputs (the cap from p, c, r; the angle between the SG and cap axes), the
//! conditioning of the f64 result under perturbations of that geometry by its f32 rounding bound:
//! `max |f(perturbed) − f|` over the perturbation's corners, computed by the f64 twin itself.
//! The worst error / tolerance of each output is printed (`--nocapture`); the p95 and the maximum
//! of |error| / |value| are printed too, so that a reader sees the typical accuracy.

mod twin;

use engine::gpu::testing::{run_f32_kernel, test_gpu};
use engine::math::rng::Pcg32;
use engine::math::sg::sg_integral;
use engine::math::sphere_light::{
    cap_clamped_cosine, cap_from_sphere, cap_sg_integral, sphere_light_clamped_cosine, sphere_light_sg_integral,
};
use std::f64::consts::{FRAC_PI_2, PI};
use twin::*;

const IN: usize = 20;
const OUT: usize = 10;

struct Case {
    cos_theta: f32,
    sin_alpha: f32,
    cos_alpha: f32,
    lambda: f32,
    sg_axis: [f32; 3],
    cap_axis: [f32; 3],
    p: [f32; 3],
    center: [f32; 3],
    radius: f32,
    n: [f32; 3],
}

impl Case {
    fn pack(&self) -> [f32; IN] {
        let mut x = [0.0f32; IN];
        x[0] = self.cos_theta;
        x[1] = self.sin_alpha;
        x[2] = self.cos_alpha;
        x[3] = self.lambda;
        x[4..7].copy_from_slice(&self.sg_axis);
        x[7..10].copy_from_slice(&self.cap_axis);
        x[10..13].copy_from_slice(&self.p);
        x[13..16].copy_from_slice(&self.center);
        x[16] = self.radius;
        x[17..20].copy_from_slice(&self.n);
        x
    }
}

/// A unit vector perpendicular to unit `a`.
fn perpendicular(a: [f64; 3], rng: &mut Pcg32) -> [f64; 3] {
    loop {
        let c = cross(a, rng.unit_vector());
        let l = dot(c, c).sqrt();
        if l > 1e-3 {
            return c.map(|x| x / l);
        }
    }
}

/// `a` rotated by angle `beta` towards the unit perpendicular `t`.
fn rotate_towards(a: [f64; 3], t: [f64; 3], beta: f64) -> [f64; 3] {
    normalize(madd(a.map(|x| x * beta.cos()), beta.sin(), t))
}

fn cases() -> Vec<Case> {
    let mut rng = Pcg32::new(2718, 28);
    let lambdas = [0.0, 1e-4, 9.99e-4, 1e-3, 0.05, 1.0, 7.0, 60.0, 500.0, 4e3, 3e4, 1e5];
    let alphas = [1e-5, 1e-4, 3e-3, 0.05, 0.3, std::f64::consts::FRAC_PI_4, 1.2, FRAC_PI_2 - 1e-3, FRAC_PI_2];
    let mut out = Vec::new();
    for c in 0..1536 {
        let alpha =
            if c < alphas.len() * 24 { alphas[c % alphas.len()] } else { log_uniform(&mut rng, 1e-5, FRAC_PI_2) };
        let (sa, ca) = ((alpha.sin() as f32), (alpha.cos() as f32));
        let sa64 = sa as f64;
        // cos θ: the transitions ±sin α exactly and just off them, ±1, 0, the straddling band, anywhere.
        let cos_theta = match c % 9 {
            0 => sa64,
            1 => -sa64,
            2 => sa64 * (1.0 - 1e-6),
            3 => -sa64 * (1.0 - 1e-6),
            4 => [1.0, -1.0, 0.0][(c / 9) % 3],
            5 | 6 => sa64 * rng.uniform(-1.0, 1.0),
            _ => rng.uniform(-1.0, 1.0),
        };
        let lambda = if c % 3 == 0 { lambdas[(c / 3) % lambdas.len()] } else { log_uniform(&mut rng, 1e-4, 1e5) };
        // SG axis at angle β from the cap axis: identical, inside, the edge, a few lobe widths
        // either side of it, anywhere, antipodal.
        let cap_axis = rng.unit_vector();
        let width = 1.0 / lambda.max(1e-12).sqrt();
        let beta = match c % 8 {
            0 => 0.0,
            1 => alpha * rng.next_f64(),
            2 => alpha,
            3 | 4 => (alpha + rng.uniform(-3.0, 3.0) * width).clamp(0.0, PI),
            5 => rng.uniform(0.0, PI),
            6 => PI,
            _ => (alpha + rng.uniform(0.0, 10.0) * width).min(PI),
        };
        let t = perpendicular(cap_axis, &mut rng);
        let cap32 = f32v(cap_axis);
        let sg_axis = if beta == 0.0 { cap32 } else { f32v(rotate_towards(cap_axis, t, beta)) };
        // The light seen from p: far, near, almost touching, on the surface, inside.
        let center = [rng.uniform(-5.0, 5.0), rng.uniform(-5.0, 5.0), rng.uniform(-5.0, 5.0)];
        let radius = log_uniform(&mut rng, 1e-3, 2.0);
        let dir = rng.unit_vector();
        let (p, radius) = match c % 6 {
            0 => (madd(center, radius * 1e4, dir), radius),          // far: α ≈ 1e-4
            1 => (madd(center, radius * (1.0 + 1e-4), dir), radius), // almost touching
            2 => (madd(center, radius * 0.5, dir), radius),          // inside
            3 => ([1.0, 0.0, 0.0], 1.0),                             // on the surface (exact in f32)
            _ => (madd(center, radius * rng.uniform(1.05, 30.0), dir), radius),
        };
        let (center, p) = if c % 6 == 3 { ([0.0; 3], p) } else { (center, p) };
        let n = if c % 5 == 0 { normalize(madd(center, -1.0, p)) } else { rng.unit_vector() };
        out.push(Case {
            cos_theta: cos_theta as f32,
            sin_alpha: sa,
            cos_alpha: ca,
            lambda: lambda as f32,
            sg_axis,
            cap_axis: cap32,
            p: f32v(p),
            center: f32v(center),
            radius: radius as f32,
            n: f32v(n),
        });
    }
    out
}

/// `atan x − x`, for magnitudes only.
fn atan_minus_x(x: f64) -> f64 {
    x.atan() - x
}

/// The sum of |terms| the shader's cap_clamped_cosine adds (its rounding is a few ulp of each;
/// the T2 term `sin²α (u − |c| atan(u/|c|))` also loses up to ×20 to cancellation when its series
/// is not used: (v − atan v)/v ≥ 0.052 for v ≥ tan(π/8)).
fn clamped_cosine_magnitude(c: f64, sa: f64, ca: f64) -> f64 {
    let (c, sa, ca) = (c.clamp(-1.0, 1.0), sa.clamp(0.0, 1.0), ca.clamp(0.0, 1.0));
    let sa2 = sa * sa;
    if c >= sa || c <= -sa {
        return PI * sa2 * c.max(0.0);
    }
    let w = ((sa - c) * (sa + c)).sqrt();
    let ac = c.abs();
    let m = if w < ca {
        let u = w / ca;
        atan_minus_x(u).abs() + 20.0 * sa2 * (u - ac * u.atan2(ac)).abs()
    } else {
        w.atan2(ca) + ca * w + sa2 * ac * w.atan2(ca * ac)
    };
    PI * sa2 * c.max(0.0) + m
}

/// Conditioning of cap_clamped_cosine under |δc| ≤ dc, |δ sin α| ≤ ds, |δ cos α| ≤ dk.
fn clamped_cosine_cond(c: f64, sa: f64, ca: f64, dc: f64, ds: f64, dk: f64) -> f64 {
    let base = cap_clamped_cosine(c, sa, ca);
    let mut worst = 0.0f64;
    for sc in [-1.0, 1.0] {
        for ss in [-1.0, 1.0] {
            for sk in [-1.0, 1.0] {
                let v = cap_clamped_cosine(c + sc * dc, sa + ss * ds, ca + sk * dk);
                worst = worst.max((v - base).abs());
            }
        }
    }
    worst
}

/// Conditioning of cap_sg_integral under `(dang, ds, dk)`: a rotation of the cap axis by ≤ dang
/// towards or away from the SG axis and |δ sin α| ≤ ds, |δ cos α| ≤ dk.
fn sg_cond(
    sg_axis: [f64; 3],
    lambda: f64,
    cap_axis: [f64; 3],
    sa: f64,
    ca: f64,
    (dang, ds, dk): (f64, f64, f64),
) -> f64 {
    let base = cap_sg_integral(sg_axis, lambda, cap_axis, sa, ca);
    let along = madd(sg_axis, -dot(sg_axis, cap_axis), cap_axis);
    let l = dot(along, along).sqrt();
    let t = if l > 1e-12 { along.map(|x| x / l) } else { normalize(cross(cap_axis, [0.6, 0.0, 0.8])) };
    let mut worst = 0.0f64;
    for sa_sign in [-1.0, 1.0] {
        let axis = rotate_towards(cap_axis, t, sa_sign * dang);
        for ss in [-1.0, 1.0] {
            for sk in [-1.0, 1.0] {
                let v = cap_sg_integral(sg_axis, lambda, axis, sa + ss * ds, ca + sk * dk);
                worst = worst.max((v - base).abs());
            }
        }
    }
    worst
}

/// f32 arithmetic bound of the shader's cap_sg_integral, relative to what it sums: every node value
/// is `ρ e^{x} poly` with `|x| ≤ X = λ q_min + 14` (q_min = 1 − cos(max(β − α, 0)) at the nearest
/// point of the cap; the window adds λq ≤ 10, the I0e branch κ < 3.75): exp is within
/// (EXP_ULP + 2X) ulp and q within 4 ulp relative (the half-angle form), i.e. 4X ulp of x; the I0e
/// polynomial ~10 ulp, the 10-term sum and the 2π h weights ~12. Where the complement is used the
/// whole-sphere integral (its own bound, math_gpu_sg.rs) is summed too. 2× margin.
fn sg_arith_tol(sg_axis: [f64; 3], lambda: f64, cap_axis: [f64; 3], sa: f64, ca: f64, value: f64) -> f64 {
    let rho_b = dot(madd(sg_axis, -1.0, cap_axis), madd(sg_axis, -1.0, cap_axis)).sqrt();
    let r_cap = (2.0 * sa * sa / (1.0 + ca)).sqrt();
    let complement = (r_cap - rho_b) * lambda.sqrt() > 0.25 && lambda > 10.0;
    let beta = 2.0 * (0.5 * rho_b).min(1.0).asin();
    let alpha = sa.atan2(ca);
    let x = lambda * 2.0 * (0.5 * (beta - alpha).max(0.0)).sin().powi(2) + 14.0;
    let full = sg_integral(lambda.max(0.0), 1.0);
    let e = (-2.0 * lambda).exp();
    let full_rel = if lambda < 1e-3 {
        8.0 * EPS + lambda.powi(3)
    } else {
        8.0 * EPS + (EXP_ULP + 4.0 * lambda) * EPS * e / (1.0 - e)
    };
    2.0 * (EXP_ULP + 6.0 * x + 22.0) * EPS * value + if complement { (full_rel + 4.0 * EPS) * full * 2.0 } else { 0.0 }
}

/// Error statistics per output: |err| / scale over all values (scale = the largest the output can
/// be for that light and lobe: π sin²α for the clamped cosine, the on-axis value for the SG), and
/// |err| / |value| over the values at least 1e-3 of the scale; p95 and max of each.
#[derive(Default)]
struct Stats {
    scaled: Vec<f64>,
    rel: Vec<f64>,
}

impl Stats {
    fn push(&mut self, got: f32, want: f64, scale: f64) {
        if scale > 0.0 {
            let err = (got as f64 - want).abs();
            self.scaled.push(err / scale);
            if want >= 1e-3 * scale {
                self.rel.push(err / want);
            }
        }
    }
    fn summary(v: &mut [f64]) -> (f64, f64) {
        v.sort_by(f64::total_cmp);
        let n = v.len();
        (v[(n * 95 / 100).min(n - 1)], v[n - 1])
    }
    fn print(&mut self, name: &str) {
        let (sp, sm) = Self::summary(&mut self.scaled);
        let (rp, rm) = Self::summary(&mut self.rel);
        eprintln!(
            "  {name:<22} |err|/scale p95 {sp:.1e} max {sm:.1e} ({} values); |err|/value p95 {rp:.1e} max {rm:.1e} ({} values ≥ 1e-3 scale)",
            self.scaled.len(),
            self.rel.len()
        );
    }
}

/// The on-axis value of cap_sg_integral (the largest over SG axes for this λ and cap).
fn on_axis(lambda: f64, sa: f64, ca: f64) -> f64 {
    cap_sg_integral([0.0, 0.0, 1.0], lambda, [0.0, 0.0, 1.0], sa, ca)
}

#[test]
fn sphere_light_twin_matches_cpu() {
    let gpu = test_gpu().expect("GPU");
    let cases = cases();
    let input: Vec<f32> = cases.iter().flat_map(|c| c.pack()).collect();
    let out = run_f32_kernel(&gpu, "tests/sphere_light_twin.comp", &input, cases.len() * OUT, cases.len() as u32)
        .expect("kernel");
    assert_all_finite(&out, OUT);
    let mut ck = Checker::default();
    let (mut rel_cc, mut rel_sg, mut rel_lcc, mut rel_lsg) =
        (Stats::default(), Stats::default(), Stats::default(), Stats::default());
    for (ci, c) in cases.iter().enumerate() {
        let o = &out[ci * OUT..(ci + 1) * OUT];
        let (ct, sa, ca, lambda) = (c.cos_theta as f64, c.sin_alpha as f64, c.cos_alpha as f64, c.lambda as f64);
        let (sg_axis, cap_axis) = (f64v(c.sg_axis), f64v(c.cap_axis));

        // Clamped cosine on exact inputs: arithmetic only (48 ulp of the summed terms: each term
        // ~10 roundings, atan reductions a few ulp, 2× margin), plus underflow.
        let w = cap_clamped_cosine(ct, sa, ca);
        let tol = 48.0 * EPS * clamped_cosine_magnitude(ct, sa, ca) + F32_MIN_NORMAL;
        ck.check("clamped cosine", ci, o[0], w, tol);
        rel_cc.push(o[0], w, PI * sa * sa);

        // SG over the cap on exact inputs. The shader derives ρ_β = |a − c| (2 ulp relative) and the
        // edge R − ρ_β (R from sin α, cos α: 3 ulp): the cap axis is effectively rotated by ≤ 4 ulp
        // of (R + ρ_β) towards or away from the SG axis.
        let w = cap_sg_integral(sg_axis, lambda, cap_axis, sa, ca);
        let rho_b = dot(madd(sg_axis, -1.0, cap_axis), madd(sg_axis, -1.0, cap_axis)).sqrt();
        let r_cap = (2.0 * sa * sa / (1.0 + ca)).sqrt();
        let dang = 4.0 * EPS * (r_cap + rho_b);
        let tol = sg_arith_tol(sg_axis, lambda, cap_axis, sa, ca, w)
            + sg_cond(sg_axis, lambda, cap_axis, sa, ca, (dang, 2.0 * EPS * sa, 2.0 * EPS * ca))
            + F32_MIN_NORMAL;
        ck.check("sg over cap", ci, o[1], w, tol);
        rel_sg.push(o[1], w, on_axis(lambda, sa, ca));

        // The cap of the sphere. d = c − p carries ε(|c| + |p|) absolute per component, its length
        // one more ulp: the axis is off by that over |d|, sin α = r/|d| by that relative, and
        // cos α = √((d − r)(d + r))/d by that over 2(d − r) relative (nearly touching spheres).
        let (p, center, r) = (f64v(c.p), f64v(c.center), c.radius as f64);
        let d = madd(center, -1.0, p);
        let dist = dot(d, d).sqrt();
        let e_d = 2.0 * EPS * (dot(center, center).sqrt() + dot(p, p).sqrt() + dist);
        let cap = cap_from_sphere(p, center, r);
        // Only cases clearly inside or outside in f32 too (the surface case p = c + (r, 0, 0) is exact).
        let clear = (dist - r).abs() > 4.0 * e_d || dist == r;
        if clear {
            ck.exact("outside flag", ci, o[2], if cap.is_some() { 1.0 } else { 0.0 });
        }
        let n = f64v(c.n);
        match cap {
            Some(cap) if clear => {
                let tol_axis = 4.0 * EPS + 2.0 * e_d / dist;
                for k in 0..3 {
                    ck.check("cap axis", ci, o[3 + k], cap.axis[k], tol_axis);
                }
                let tol_sa = cap.sin_alpha * (4.0 * EPS + 2.0 * e_d / dist) + F32_MIN_NORMAL;
                ck.check("cap sin alpha", ci, o[6], cap.sin_alpha, tol_sa);
                let tol_ca = cap.cos_alpha * (6.0 * EPS + e_d / (dist - r) + 2.0 * e_d / dist) + F32_MIN_NORMAL;
                ck.check("cap cos alpha", ci, o[7], cap.cos_alpha, tol_ca);

                // The light from (p, n): the clamped cosine at the GPU's rounding of the cap
                // (n·axis off by √3 tol_axis + 3 ulp), plus the arithmetic.
                let want = sphere_light_clamped_cosine(p, n, center, r);
                let ct = dot(n, cap.axis);
                let tol = 48.0 * EPS * clamped_cosine_magnitude(ct, cap.sin_alpha, cap.cos_alpha)
                    + clamped_cosine_cond(ct, cap.sin_alpha, cap.cos_alpha, 1.8 * tol_axis + 3.0 * EPS, tol_sa, tol_ca)
                    + F32_MIN_NORMAL;
                ck.check("light clamped cosine", ci, o[8], want, tol);
                rel_lcc.push(o[8], want, PI * cap.sin_alpha * cap.sin_alpha);

                let want = sphere_light_sg_integral(p, center, r, sg_axis, lambda);
                let rho_b = dot(madd(sg_axis, -1.0, cap.axis), madd(sg_axis, -1.0, cap.axis)).sqrt();
                let r_cap = (2.0 * cap.one_minus_cos_alpha()).sqrt();
                let dang = 1.8 * tol_axis + 4.0 * EPS * (r_cap + rho_b);
                let tol = sg_arith_tol(sg_axis, lambda, cap.axis, cap.sin_alpha, cap.cos_alpha, want)
                    + sg_cond(sg_axis, lambda, cap.axis, cap.sin_alpha, cap.cos_alpha, (dang, tol_sa, tol_ca))
                    + F32_MIN_NORMAL;
                ck.check("light sg over cap", ci, o[9], want, tol);
                rel_lsg.push(o[9], want, on_axis(lambda, cap.sin_alpha, cap.cos_alpha));
            }
            None if clear => {
                // Inside: axis towards the centre (or +y), sin α = 1, cos α = 0; the light is seen
                // everywhere: π, and the whole-sphere SG integral.
                let axis = if dist > 0.0 { d.map(|x| x / dist) } else { [0.0, 1.0, 0.0] };
                for k in 0..3 {
                    ck.check("inside axis", ci, o[3 + k], axis[k], 4.0 * EPS + 2.0 * e_d / dist.max(1e-30));
                }
                ck.exact("inside sin alpha", ci, o[6], 1.0);
                ck.exact("inside cos alpha", ci, o[7], 0.0);
                ck.check("inside clamped cosine", ci, o[8], PI, 2.0 * EPS * PI);
                let full = sg_integral(lambda, 1.0);
                let e = (-2.0 * lambda).exp();
                let rel = if lambda < 1e-3 {
                    8.0 * EPS + lambda.powi(3)
                } else {
                    8.0 * EPS + (EXP_ULP + 4.0 * lambda) * EPS * e / (1.0 - e)
                };
                ck.check("inside sg", ci, o[9], full, (rel + 4.0 * EPS) * full);
            }
            _ => {}
        }
    }
    ck.report("sphere light twin");
    rel_cc.print("clamped cosine");
    rel_sg.print("sg over cap");
    rel_lcc.print("light clamped cosine");
    rel_lsg.print("light sg over cap");
    gpu.shutdown().expect("clean teardown");
}
