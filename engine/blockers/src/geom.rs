//! Sphere primitives shared by fitting, the BVH and the hierarchy (f64 references).
//!
//! The GPU twins of [`cone_intersects_sphere`], [`subtended_half_angle`] and [`merge_spheres`] are in
//! `shaders-glsl/common/spheres.glsl`.

use glam::DVec3;
use std::f64::consts::PI;

/// The largest magnitude of a sphere's centre coordinates and radius: the GPU holds spheres in f32 and its
/// kernels square distances and radii, so 1e18 (squared 1e36, summed over three axes still far below
/// f32::MAX ≈ 3.4e38) is the bound, not f32::MAX itself (1e38 squared is infinite).
pub const MAX_SPHERE_COORDINATE: f64 = 1e18;

/// A sphere `(center, radius)`. A radius of zero is a valid degenerate sphere (a point): it blocks
/// nothing but is kept so that indices stay stable. Negative or non-finite values are rejected by
/// [`Sphere::validate`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub center: DVec3,
    pub radius: f64,
}

impl Sphere {
    pub fn new(center: DVec3, radius: f64) -> Self {
        Self { center, radius }
    }

    /// Whether the ray o + t w (t > 0, w unit) meets the sphere (an origin inside it always does).
    pub fn ray_hits(&self, o: DVec3, w: DVec3) -> bool {
        let oc = o - self.center;
        let b = oc.dot(w);
        let disc = b * b - (oc.length_squared() - self.radius * self.radius);
        disc >= 0.0 && -b + disc.sqrt() > 0.0
    }

    /// `[cx, cy, cz, r]`, the file and GPU order.
    pub fn to_array(self) -> [f64; 4] {
        [self.center.x, self.center.y, self.center.z, self.radius]
    }

    pub fn from_array(a: [f64; 4]) -> Self {
        Self::new(DVec3::new(a[0], a[1], a[2]), a[3])
    }

    /// Checks the centre is finite and the radius finite and non-negative, and that every coordinate and the
    /// radius lie within ±[`MAX_SPHERE_COORDINATE`] (a value finite in f64 can be infinite once the GPU holds it
    /// in f32: a radius of 1e39 was accepted here and the sphere silently vanished on the GPU).
    pub fn validate(&self, index: usize) -> Result<(), crate::BlockerError> {
        let invalid = |reason: String| Err(crate::BlockerError::InvalidSphere { index, reason });
        if !self.center.is_finite() {
            return invalid(format!("centre {:?} is not finite", self.center));
        }
        if !self.radius.is_finite() || self.radius < 0.0 {
            return invalid(format!("radius {} is negative or not finite", self.radius));
        }
        for (name, v) in [("centre x", self.center.x), ("centre y", self.center.y), ("centre z", self.center.z)]
            .into_iter()
            .chain([("radius", self.radius)])
        {
            if v.abs() > MAX_SPHERE_COORDINATE {
                return invalid(format!(
                    "{name} {v:e} is beyond ±{MAX_SPHERE_COORDINATE:e}, the range the GPU's f32 arithmetic holds \
                     (squared distances must stay below f32::MAX ≈ 3.4e38)"
                ));
            }
        }
        Ok(())
    }

    pub fn contains_point(&self, p: DVec3) -> bool {
        self.center.distance(p) <= self.radius
    }

    /// Whether `other` lies inside `self`, with an absolute slack `eps`.
    pub fn contains_sphere(&self, other: &Sphere, eps: f64) -> bool {
        self.center.distance(other.center) + other.radius <= self.radius + eps
    }
}

/// Input check of a refit (BVH or hierarchy): the same number of spheres as at build, each valid.
pub(crate) fn validate_refit(spheres: &[Sphere], built: usize) -> Result<(), crate::BlockerError> {
    if spheres.len() != built {
        return Err(crate::BlockerError::InvalidSphere {
            index: spheres.len(),
            reason: format!("refit with {} spheres, built with {built}", spheres.len()),
        });
    }
    spheres.iter().enumerate().try_for_each(|(i, s)| s.validate(i))
}

/// The angle between two (not necessarily unit) vectors, via atan2: accurate near 0 and π, where
/// `acos(dot)` loses half the digits (pbrt's `AngleBetween`).
pub fn angle_between(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// Half-angle of the cone of directions from `p` that hit `s` (SHEXP Eq. 34: `asin(r / d)`).
/// Written `atan2(r, sqrt((d − r)(d + r)))`, which keeps its digits as `r/d → 1` where `asin` has
/// infinite slope. A point inside or on the sphere sees it in every direction: π.
pub fn subtended_half_angle(p: DVec3, s: &Sphere) -> f64 {
    let d = p.distance(s.center);
    if d <= s.radius {
        return PI;
    }
    s.radius.atan2(((d - s.radius) * (d + s.radius)).sqrt())
}

/// A one-sided infinite cone: the rays from `apex` within `half_angle` of the unit `axis`
/// (ISG §5, Fig. 5: the cone of the limiting angle Γ around an SG lobe axis).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    pub apex: DVec3,
    pub axis: DVec3,
    pub half_angle: f64,
}

impl Cone {
    /// A cone with `axis` normalized. A zero or non-finite axis falls back to +Y so that no query
    /// returns NaN; the half-angle is clamped to [0, π].
    pub fn new(apex: DVec3, axis: DVec3, half_angle: f64) -> Self {
        let axis = axis.try_normalize().unwrap_or(DVec3::Y);
        let half_angle = if half_angle.is_nan() { 0.0 } else { half_angle.clamp(0.0, PI) };
        Self { apex, axis, half_angle }
    }
}

/// Whether any point of `s` lies inside `cone`. Exact: seen from the apex, the sphere covers the cap
/// of directions of half-angle ψ = [`subtended_half_angle`] around the direction β to its centre,
/// and a cap meets the cone of half-angle α iff β ≤ α + ψ. An apex inside the sphere always hits.
pub fn cone_intersects_sphere(cone: &Cone, s: &Sphere) -> bool {
    let v = s.center - cone.apex;
    let d = v.length();
    if d <= s.radius {
        return true;
    }
    let psi = subtended_half_angle(cone.apex, s);
    angle_between(cone.axis, v) <= cone.half_angle + psi
}

/// SHEXP Eq. 36: node `s` subtends an angle less than `theta_max` from every point of the receiver
/// sphere, `r_i < sin(θ_max) (‖P_i − p_R‖ − r_R)`. Meaningful for θ_max ≤ π/2.
pub fn subtends_less_than(receiver: &Sphere, s: &Sphere, theta_max: f64) -> bool {
    s.radius < theta_max.sin() * (receiver.center.distance(s.center) - receiver.radius)
}

/// The smallest sphere containing both `a` and `b` (exact; SHEXP §6.3's "sphere pair bound").
/// The radius is finally raised to the measured `‖c − c_i‖ + r_i` of both inputs so that rounding
/// never leaves a child poking out of its parent.
pub fn merge_spheres(a: &Sphere, b: &Sphere) -> Sphere {
    let d = a.center.distance(b.center);
    if d + b.radius <= a.radius {
        return *a;
    }
    if d + a.radius <= b.radius {
        return *b;
    }
    // Here d > |r_a − r_b| ≥ 0, so d > 0.
    let r = 0.5 * (d + a.radius + b.radius);
    let t = ((r - a.radius) / d).clamp(0.0, 1.0);
    let c = a.center + (b.center - a.center) * t;
    let r = r.max(c.distance(a.center) + a.radius).max(c.distance(b.center) + b.radius);
    Sphere::new(c, r)
}

/// Radius of the smallest sphere centred at `c` that contains every sphere in `spheres`.
pub fn enclosing_radius(c: DVec3, spheres: &[Sphere]) -> f64 {
    spheres.iter().map(|s| c.distance(s.center) + s.radius).fold(0.0, f64::max)
}

/// A near-minimal bounding sphere of `spheres` (SHEXP §6.3: centre initialized at the mean of the
/// centres, then moved to minimize the bounding radius; we use Nelder–Mead where the paper uses
/// Powell: both are derivative-free, and the radius is a convex function of the centre). The result
/// is compared with the successive pair-merge bound and the smaller is kept; it always bounds.
/// Returns `None` for an empty slice.
pub fn bounding_sphere_of_spheres(spheres: &[Sphere]) -> Option<Sphere> {
    let first = spheres.first()?;
    let merged = spheres[1..].iter().fold(*first, |acc, s| merge_spheres(&acc, s));
    if spheres.len() == 1 {
        return Some(merged);
    }
    let mean = spheres.iter().map(|s| s.center).sum::<DVec3>() / spheres.len() as f64;
    let step = 0.25 * merged.radius.max(1e-300);
    let (c, _) = nelder_mead3(|c| enclosing_radius(c, spheres), mean, step, 200);
    let r = enclosing_radius(c, spheres);
    Some(if r < merged.radius { Sphere::new(c, r) } else { merged })
}

/// Deterministic Nelder–Mead minimization of `f` over R³ from `x0` with initial simplex edge `step`,
/// at most `max_evals` evaluations. Returns the best point and value. Non-finite values count as +∞.
pub fn nelder_mead3(f: impl Fn(DVec3) -> f64, x0: DVec3, step: f64, max_evals: usize) -> (DVec3, f64) {
    let eval = |x: DVec3| {
        let v = f(x);
        if v.is_finite() {
            v
        } else {
            f64::INFINITY
        }
    };
    let mut simplex = [x0, x0 + DVec3::X * step, x0 + DVec3::Y * step, x0 + DVec3::Z * step];
    let mut values = simplex.map(eval);
    let mut evals = 4;
    while evals < max_evals {
        // Sort ascending (4 elements: insertion sort keeps it deterministic and cheap).
        for i in 1..4 {
            let mut j = i;
            while j > 0 && values[j] < values[j - 1] {
                values.swap(j, j - 1);
                simplex.swap(j, j - 1);
                j -= 1;
            }
        }
        let spread = (values[3] - values[0]).abs();
        let size = (1..4).map(|i| simplex[i].distance(simplex[0])).fold(0.0, f64::max);
        if spread <= 1e-14 * values[0].abs().max(1e-300) && size <= 1e-9 * step {
            break;
        }
        let centroid = (simplex[0] + simplex[1] + simplex[2]) / 3.0;
        let worst = simplex[3];
        let xr = centroid + (centroid - worst);
        let fr = eval(xr);
        evals += 1;
        if fr < values[0] {
            let xe = centroid + 2.0 * (centroid - worst);
            let fe = eval(xe);
            evals += 1;
            if fe < fr {
                simplex[3] = xe;
                values[3] = fe;
            } else {
                simplex[3] = xr;
                values[3] = fr;
            }
        } else if fr < values[2] {
            simplex[3] = xr;
            values[3] = fr;
        } else {
            let xc =
                if fr < values[3] { centroid + 0.5 * (xr - centroid) } else { centroid + 0.5 * (worst - centroid) };
            let fc = eval(xc);
            evals += 1;
            if fc < values[3].min(fr) {
                simplex[3] = xc;
                values[3] = fc;
            } else {
                // Shrink towards the best vertex.
                for i in 1..4 {
                    simplex[i] = simplex[0] + 0.5 * (simplex[i] - simplex[0]);
                    values[i] = eval(simplex[i]);
                }
                evals += 3;
            }
        }
    }
    let best = (0..4).fold(0, |b, i| if values[i] < values[b] { i } else { b });
    (simplex[best], values[best])
}

#[cfg(test)]
mod tests {
    use super::*;
    use engine_math::rng::Pcg32;

    fn rand_vec(rng: &mut Pcg32, s: f64) -> DVec3 {
        DVec3::new(rng.uniform(-s, s), rng.uniform(-s, s), rng.uniform(-s, s))
    }

    #[test]
    fn subtended_angle_matches_solid_angle_quadrature() {
        // Independent check: the cap of half-angle ψ has solid angle 2π(1 − cos ψ); count directions
        // hitting the sphere by quadrature of a ray–sphere indicator over the unit sphere.
        let s = Sphere::new(DVec3::new(0.3, -0.2, 0.5), 0.7);
        for &p in &[DVec3::new(3.0, 1.0, -2.0), DVec3::new(0.3, 1.3, 0.5), DVec3::new(-1.0, 0.0, 0.0)] {
            let psi = subtended_half_angle(p, &s);
            let hits = |dir: [f64; 3]| {
                let d = DVec3::from_array(dir);
                let oc = s.center - p;
                let t = oc.dot(d);
                let closest2 = oc.length_squared() - t * t;
                if t > 0.0 && closest2 <= s.radius * s.radius {
                    1.0
                } else {
                    0.0
                }
            };
            let omega = engine_math::quadrature::integrate_sphere(hits, 8, 64, 1024);
            let exact = 2.0 * PI * (1.0 - psi.cos());
            // The indicator is discontinuous, so the product rule converges only like 1/n at the
            // cap's edge: 512 θ nodes and 1024 φ points give about 1e-2 absolute in steradians.
            assert!((omega - exact).abs() < 2e-2, "p={p:?} quad {omega} closed {exact}");
        }
        // Inside and on the surface: every direction.
        assert_eq!(subtended_half_angle(s.center, &s), PI);
        // Extreme: r/d → 1 from above stays finite and near π/2.
        let p = s.center + DVec3::X * (s.radius * (1.0 + 1e-15));
        let a = subtended_half_angle(p, &s);
        assert!(a.is_finite() && (a - PI / 2.0).abs() < 1e-6, "{a}");
        // A zero-radius sphere subtends nothing.
        assert_eq!(subtended_half_angle(DVec3::ONE, &Sphere::new(DVec3::ZERO, 0.0)), 0.0);
    }

    #[test]
    fn cone_test_matches_dense_surface_sampling() {
        // Independent check: a sphere meets the cone iff one of its points (surface points suffice,
        // the cone being connected and the apex outside) is within the half-angle of the axis.
        let mut rng = Pcg32::new(11, 3);
        let mut checked = 0;
        for _ in 0..300 {
            let cone = Cone::new(rand_vec(&mut rng, 1.0), rand_vec(&mut rng, 1.0), rng.uniform(0.0, 1.5));
            let s = Sphere::new(rand_vec(&mut rng, 3.0), rng.uniform(0.0, 1.0));
            let fast = cone_intersects_sphere(&cone, &s);
            let mut best = f64::INFINITY;
            for _ in 0..4000 {
                let q = s.center + DVec3::from_array(rng.unit_vector()) * s.radius;
                best = best.min(angle_between(cone.axis, q - cone.apex) - cone.half_angle);
            }
            let inside = s.contains_point(cone.apex);
            // Random surface sampling finds the nearest point only to within ~2e-2 rad for 4000
            // samples: skip cases whose margin is below that (they are tested by the exact cases below).
            if !inside && best.abs() < 2e-2 {
                continue;
            }
            checked += 1;
            assert_eq!(fast, inside || best <= 0.0, "cone {cone:?} sphere {s:?} margin {best}");
        }
        assert!(checked > 250, "too few decisive cases: {checked}");
        // Exact cases: tangent from outside along the axis direction.
        let cone = Cone::new(DVec3::ZERO, DVec3::Z, 0.3);
        let d = 5.0;
        let beta = 0.3 + (1.0f64 / d).asin();
        let c = DVec3::new(beta.sin(), 0.0, beta.cos()) * d;
        assert!(cone_intersects_sphere(&cone, &Sphere::new(c, 1.0 + 1e-9)));
        assert!(!cone_intersects_sphere(&cone, &Sphere::new(c, 1.0 - 1e-9)));
        // Behind the apex, wide cone beyond π/2.
        let back = Sphere::new(DVec3::new(0.0, 0.0, -3.0), 0.5);
        assert!(!cone_intersects_sphere(&cone, &back));
        assert!(cone_intersects_sphere(&Cone::new(DVec3::ZERO, DVec3::Z, PI), &back));
        // Degenerate axis and NaN angle: no NaN, documented fallback.
        let degenerate = Cone::new(DVec3::ZERO, DVec3::ZERO, f64::NAN);
        assert_eq!(degenerate.axis, DVec3::Y);
        assert!(cone_intersects_sphere(&degenerate, &Sphere::new(DVec3::Y * 2.0, 0.1)));
    }

    #[test]
    fn merge_is_minimal_and_bounding() {
        let mut rng = Pcg32::new(5, 1);
        for _ in 0..2000 {
            let a = Sphere::new(rand_vec(&mut rng, 2.0), rng.uniform(0.0, 1.5));
            let b = Sphere::new(rand_vec(&mut rng, 2.0), rng.uniform(0.0, 1.5));
            let m = merge_spheres(&a, &b);
            // Containment with rounding slack: 1e-12 relative to the scene size (~4).
            assert!(m.contains_sphere(&a, 1e-12) && m.contains_sphere(&b, 1e-12));
            // Minimality: any bounding sphere has diameter ≥ the farthest extent along the centre
            // line, which is (d + r_a + r_b) unless one contains the other.
            let d = a.center.distance(b.center);
            let lower = (0.5 * (d + a.radius + b.radius)).max(a.radius).max(b.radius);
            assert!((m.radius - lower).abs() < 1e-12 * (1.0 + lower), "{} vs {}", m.radius, lower);
        }
        // Coincident centres and zero radii.
        let p = Sphere::new(DVec3::ONE, 0.0);
        assert_eq!(merge_spheres(&p, &p), p);
        let m = merge_spheres(&Sphere::new(DVec3::ZERO, 0.0), &Sphere::new(DVec3::X * 2.0, 0.0));
        assert!((m.radius - 1.0).abs() < 1e-15 && (m.center - DVec3::X).length() < 1e-15);
    }

    #[test]
    fn bounding_sphere_of_spheres_bounds_and_is_tight() {
        let mut rng = Pcg32::new(9, 2);
        for _ in 0..50 {
            let n = 1 + (rng.next_u32() % 8) as usize;
            let spheres: Vec<_> = (0..n).map(|_| Sphere::new(rand_vec(&mut rng, 1.0), rng.uniform(0.0, 0.5))).collect();
            let b = bounding_sphere_of_spheres(&spheres).unwrap();
            for s in &spheres {
                assert!(b.contains_sphere(s, 1e-12));
            }
            // Lower bound: half the largest pairwise extent D/2. By Jung's theorem the minimal ball
            // of a set of diameter D in 3-D has radius ≤ √(3/8) D, i.e. at most √(3/2) ≈ 1.2247 times
            // the lower bound (the extents of balls behave like point sets of their far points).
            let mut lower: f64 = 0.0;
            for a in &spheres {
                for c in &spheres {
                    lower = lower.max(0.5 * (a.center.distance(c.center) + a.radius + c.radius));
                }
            }
            assert!(b.radius <= lower * 1.2248 + 1e-12, "{} vs {}", b.radius, lower);
        }
        assert!(bounding_sphere_of_spheres(&[]).is_none());
    }

    #[test]
    fn nelder_mead_finds_quadratic_minimum() {
        let target = DVec3::new(0.3, -1.2, 2.0);
        let (x, v) = nelder_mead3(|x| (x - target).length_squared() * 3.0 + 1.0, DVec3::ZERO, 1.0, 400);
        // 400 evaluations on a 3-D quadratic converge to ~1e-8 in position.
        assert!((x - target).length() < 1e-6 && (v - 1.0).abs() < 1e-10, "{x:?} {v}");
    }
}

/// The self-shadowing replacement rules of SHEXP §6.2 (Fig. 5) for a blocker sphere `s` seen from a
/// receiver at `p` with unit outward normal `n` (tangent plane T_p):
/// - `p` inside `s`: eliminated if the centre is behind T_p (or on it), else its radius is reduced
///   until it is tangent to T_p (the same centre);
/// - `p` outside `s`: eliminated if entirely behind T_p; if it straddles T_p, replaced by the sphere
///   whose diameter joins the point of `s` farthest in front of T_p (q0) and its projection onto T_p
///   (q1); unaltered if entirely in front.
///
/// The paper's gradual radius scale α (for continuity as `p` leaves `s`) is not applied here: it is
/// [`blocker_for_receiver_alpha`], which `shexp:alpha_scale=on` uses.
/// Twin: `blocker_for_receiver` in shaders-glsl/common/spheres.glsl.
pub fn blocker_for_receiver(p: DVec3, n: DVec3, s: &Sphere) -> Option<Sphere> {
    let h = (s.center - p).dot(n);
    if s.center.distance(p) <= s.radius {
        return (h > 0.0).then(|| Sphere::new(s.center, h.min(s.radius)));
    }
    if h <= -s.radius {
        return None;
    }
    if h >= s.radius {
        return Some(*s);
    }
    let t = h + s.radius; // height of q0 above T_p, in (0, 2r)
    Some(Sphere::new(s.center + n * (s.radius - 0.5 * t), 0.5 * t))
}

/// [`blocker_for_receiver`] with the paper's radius scale α (SHEXP §6.2), which removes the jump as `p`
/// leaves `s`: for `p` outside a sphere that straddles T_p, the blocker is the sphere tangent to T_p at q1
/// (the foot of the centre on T_p, where S' touches it) of radius r_α = (1 − α) max(h, 0) + α (h + r)/2,
/// h the centre's height above T_p, α = clamp((‖p − q1‖ − d)/d, 0, 1) and d = √(r² − h²) the radius of the
/// circle where `s` meets T_p. On that circle (p on the sphere) α = 0 and the blocker is what the inside
/// rule gives there (the sphere shrunk about its centre until tangent, or nothing when the centre is behind);
/// from ‖p − q1‖ = 2d on it is S', the paper's replacement. The paper prints α = max(1, (‖p − q1‖ − d)/d),
/// which is never below 1 and so could not remove the jump: this is our reading (the clamp to [0, 1] and
/// the blend from the inside rule's radius). Every other case is [`blocker_for_receiver`]'s.
/// Twin: `blocker_for_receiver_alpha` in shaders-glsl/common/spheres.glsl.
pub fn blocker_for_receiver_alpha(p: DVec3, n: DVec3, s: &Sphere) -> Option<Sphere> {
    let h = (s.center - p).dot(n);
    if s.center.distance(p) <= s.radius || h <= -s.radius || h >= s.radius {
        return blocker_for_receiver(p, n, s);
    }
    let q1 = s.center - n * h;
    let d = (s.radius * s.radius - h * h).max(0.0).sqrt();
    let alpha = if d > 0.0 { ((p.distance(q1) - d) / d).clamp(0.0, 1.0) } else { 1.0 };
    let r = (1.0 - alpha) * h.max(0.0) + alpha * 0.5 * (h + s.radius);
    (r > 0.0).then(|| Sphere::new(q1 + n * r, r))
}

#[cfg(test)]
mod receiver_rule_tests {
    use super::*;

    #[test]
    fn ray_hits_sphere() {
        let s = Sphere::new(DVec3::new(0.0, 2.0, 0.0), 0.5);
        assert!(s.ray_hits(DVec3::ZERO, DVec3::Y));
        assert!(!s.ray_hits(DVec3::ZERO, -DVec3::Y), "behind the origin");
        assert!(!s.ray_hits(DVec3::ZERO, DVec3::new(0.3, 1.0, 0.0).normalize()), "misses (0.29 rad > 0.25)");
        assert!(s.ray_hits(DVec3::new(0.0, 2.0, 0.0), DVec3::X), "from inside");
    }

    #[test]
    fn the_alpha_scale_joins_the_inside_and_outside_rules() {
        let n = DVec3::Y;
        for h in [-0.3, -0.05, 0.0, 0.2, 0.45] {
            let s = Sphere::new(DVec3::new(0.0, h, 0.0), 0.5);
            let d = (0.25 - h * h).sqrt();
            // Just inside and just outside the sphere, on its circle in T_p (p's own plane: y = 0).
            let inside = |x: f64| blocker_for_receiver(DVec3::new(x, 0.0, 0.0), n, &s);
            let outside = |x: f64| blocker_for_receiver_alpha(DVec3::new(x, 0.0, 0.0), n, &s);
            let (a, b) = (inside(d - 1e-9), outside(d + 1e-9));
            match (a, b) {
                (None, None) => assert!(h <= 0.0),
                (None, Some(b)) => assert!(h <= 0.0 && b.radius < 1e-6, "h {h}: {b:?}"),
                (Some(a), Some(b)) => {
                    assert!(
                        a.center.distance(b.center) < 1e-6 && (a.radius - b.radius).abs() < 1e-6,
                        "h {h}: {a:?} {b:?}"
                    )
                }
                (Some(a), None) => panic!("h {h}: inside {a:?}, nothing outside"),
            }
            // Without α the two rules differ there: the jump the scale removes.
            let plain = blocker_for_receiver(DVec3::new(d + 1e-9, 0.0, 0.0), n, &s).expect("straddles");
            assert!((plain.radius - a.map_or(0.0, |a| a.radius)).abs() > 0.02, "h {h}");
            // From 2d on, S' itself; every case other than straddling is unchanged.
            let far = DVec3::new(2.0 * d + 1e-9, 0.0, 0.0);
            let (x, y) = (blocker_for_receiver_alpha(far, n, &s).unwrap(), blocker_for_receiver(far, n, &s).unwrap());
            assert!(x.center.distance(y.center) < 1e-12 && (x.radius - y.radius).abs() < 1e-12, "h {h}: {x:?} {y:?}");
            // The radius grows monotonically from the circle to 2d.
            let radii: Vec<f64> =
                (0..=20).map(|k| outside(d * (1.0 + k as f64 / 20.0)).map_or(0.0, |b| b.radius)).collect();
            assert!(radii.windows(2).all(|w| w[1] >= w[0] - 1e-12), "h {h}: {radii:?}");
        }
        for (c, p) in [(DVec3::new(0.0, 0.8, 0.0), DVec3::new(3.0, 0.0, 0.0)), (DVec3::new(0.0, -0.8, 0.0), DVec3::X)] {
            let s = Sphere::new(c, 0.5);
            assert_eq!(blocker_for_receiver_alpha(p, n, &s), blocker_for_receiver(p, n, &s), "not straddling");
        }
    }

    #[test]
    fn shexp_self_shadow_rules() {
        let (p, n) = (DVec3::ZERO, DVec3::Y);
        // Entirely in front: unaltered.
        let s = Sphere::new(DVec3::new(0.0, 3.0, 0.0), 1.0);
        assert_eq!(blocker_for_receiver(p, n, &s), Some(s));
        // Entirely behind: eliminated.
        assert_eq!(blocker_for_receiver(p, n, &Sphere::new(DVec3::new(5.0, -2.0, 0.0), 1.0)), None);
        // Receiver inside, centre behind: eliminated; centre in front: tangent to the plane.
        assert_eq!(blocker_for_receiver(p, n, &Sphere::new(DVec3::new(0.0, -0.5, 0.0), 1.0)), None);
        let t = blocker_for_receiver(p, n, &Sphere::new(DVec3::new(0.2, 0.5, 0.0), 1.0)).unwrap();
        assert_eq!(t, Sphere::new(DVec3::new(0.2, 0.5, 0.0), 0.5));
        // Outside and straddling: the sphere on the diameter q0-q1, tangent to T_p, in front of it.
        let s = Sphere::new(DVec3::new(3.0, 0.5, 0.0), 1.0);
        let r = blocker_for_receiver(p, n, &s).unwrap();
        assert!((r.radius - 0.75).abs() < 1e-12 && (r.center - DVec3::new(3.0, 0.75, 0.0)).length() < 1e-12);
        assert!((r.center.y - r.radius).abs() < 1e-12, "tangent to T_p");
        assert!((r.center.y + r.radius - 1.5).abs() < 1e-12, "reaches q0");
    }
}
