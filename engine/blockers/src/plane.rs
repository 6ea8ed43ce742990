//! Plane blockers: a scene's large flat receivers (the ground, a table top, a wall) as blocker
//! primitives beside the spheres and thin shells. f64 references; the GPU twin is
//! `shaders-glsl/common/planes.glsl`.
//!
//! Two kinds:
//! - a **half-space**: the solid `m·x < d` below the plane `m·x = d` (unit normal m). A receiver above
//!   it cannot see any direction with `m·ω < 0`; a receiver on the plane or below it (inside the
//!   solid) is not shadowed by it.
//! - a **rectangle**: a two-sided plate `c + s·u + t·v`, `s, t ∈ [−1, 1]` (u, v orthogonal half-extent
//!   vectors). A receiver on either side cannot see the directions whose rays hit the plate; a
//!   receiver on the plate's plane is not shadowed by it.
//!
//! Self-shadowing rule (both kinds): a receiver within `epsilon` (world units) of the plane is not
//! shadowed by it, so the ground never shadows itself.

use glam::DVec3;

/// One plane blocker (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlockerPlane {
    /// Unit normal m.
    pub normal: DVec3,
    /// Offset d of the plane `m·x = d`.
    pub offset: f64,
    /// `Some((centre, half_u, half_v))`: a bounded rectangle; `None`: the half-space `m·x < d`.
    pub rect: Option<(DVec3, DVec3, DVec3)>,
    /// Receivers within this distance of the plane are not shadowed by it.
    pub epsilon: f64,
}

/// Default self-shadowing tolerance relative to the plane's scale (its offset or extent, at least 1).
pub const RELATIVE_EPSILON: f64 = 1e-4;

impl BlockerPlane {
    /// The half-space below the plane through `point` with normal `normal` (normalized here).
    pub fn half_space(point: DVec3, normal: DVec3) -> Self {
        let m = normal.normalize();
        let d = m.dot(point);
        Self { normal: m, offset: d, rect: None, epsilon: RELATIVE_EPSILON * d.abs().max(1.0) }
    }

    /// The rectangle `centre + s·half_u + t·half_v`, |s|, |t| ≤ 1; its normal is `half_u × half_v`.
    pub fn rectangle(centre: DVec3, half_u: DVec3, half_v: DVec3) -> Self {
        let m = half_u.cross(half_v).normalize();
        let scale = centre.length().max(half_u.length()).max(half_v.length()).max(1.0);
        Self {
            normal: m,
            offset: m.dot(centre),
            rect: Some((centre, half_u, half_v)),
            epsilon: RELATIVE_EPSILON * scale,
        }
    }

    /// Checks finiteness, a unit normal, a positive tolerance and, for a rectangle, non-degenerate
    /// orthogonal sides in the plane.
    pub fn validate(&self) -> Result<(), String> {
        let finite = self.normal.is_finite() && self.offset.is_finite() && self.epsilon.is_finite();
        if !finite {
            return Err(format!("plane blocker {self:?} is not finite"));
        }
        if (self.normal.length() - 1.0).abs() > 1e-6 {
            return Err(format!("plane blocker normal {:?} is not a unit vector", self.normal));
        }
        if self.epsilon <= 0.0 {
            return Err(format!("plane blocker tolerance {} must be positive", self.epsilon));
        }
        if let Some((c, u, v)) = self.rect {
            if !(c.is_finite() && u.is_finite() && v.is_finite()) {
                return Err(format!("plane blocker rectangle {c:?} ± {u:?}, {v:?} is not finite"));
            }
            let (lu, lv) = (u.length(), v.length());
            if lu <= 0.0 || lv <= 0.0 {
                return Err(format!("plane blocker rectangle has a zero side ({lu}, {lv})"));
            }
            if u.dot(v).abs() > 1e-6 * lu * lv
                || self.normal.dot(u).abs() > 1e-6 * lu
                || self.normal.dot(v).abs() > 1e-6 * lv
            {
                return Err("plane blocker rectangle sides must be orthogonal and in the plane".into());
            }
            if (self.normal.dot(c) - self.offset).abs() > self.epsilon {
                return Err("plane blocker rectangle centre is not on the plane".into());
            }
        }
        Ok(())
    }

    /// Signed distance of p above the plane (along m).
    pub fn height(&self, p: DVec3) -> f64 {
        self.normal.dot(p) - self.offset
    }

    /// The self-shadowing rule: whether this plane can shadow a receiver at p at all.
    pub fn blocks_receiver(&self, p: DVec3) -> bool {
        let h = self.height(p);
        match self.rect {
            None => h > self.epsilon,
            Some(_) => h.abs() > self.epsilon,
        }
    }

    /// The rectangle's corners in order around its boundary (counter-clockwise about m).
    pub fn corners(&self) -> Option<[DVec3; 4]> {
        self.rect.map(|(c, u, v)| [c - u - v, c + u - v, c + u + v, c - u + v])
    }

    /// Distance along unit `d` from `o` to the blocker, for a receiver at `receiver` (the rule
    /// above), or `None` when the ray misses it within (0, t_max).
    pub fn hit(&self, receiver: DVec3, o: DVec3, d: DVec3, t_max: f64) -> Option<f64> {
        if !self.blocks_receiver(receiver) {
            return None;
        }
        let md = self.normal.dot(d);
        if md == 0.0 {
            return None;
        }
        let t = (self.offset - self.normal.dot(o)) / md;
        if !(t > 0.0 && t < t_max) {
            return None;
        }
        match self.rect {
            // The solid lies below: a ray from above enters it when it goes down.
            None => (md < 0.0).then_some(t),
            Some((c, u, v)) => {
                let q = o + t * d - c;
                let inside = q.dot(u).abs() <= u.length_squared() && q.dot(v).abs() <= v.length_squared();
                inside.then_some(t)
            }
        }
    }

    /// Whether the direction `d` from receiver p is blocked (the ray hits the blocker).
    pub fn blocks_direction(&self, p: DVec3, d: DVec3) -> bool {
        self.hit(p, p, d, f64::INFINITY).is_some()
    }

    /// The cosine-weighted solid angle ∫ (n·ω)⁺ dω of the directions from `p` that the blocker hides, for a
    /// receiver with unit normal `n` (0 when the self-shadowing rule spares `p`): π(1 − n·m)/2 for a
    /// half-space (the lune under the plane); for a rectangle, Lambert's formula ½ |Σ_e Θ_e n·u_e| over the
    /// plate's polygon clipped to the hemisphere of n (Θ_e the angle an edge subtends, u_e the unit normal of
    /// the plane through p and the edge). The edges are great-circle arcs seen from p, so clipping them at
    /// n·x = 0 is linear in the corner vectors and the result is exact. Twin: `plane_projected_solid_angle`
    /// in shaders-glsl/common/planes.glsl.
    pub fn projected_solid_angle(&self, p: DVec3, n: DVec3) -> f64 {
        if !self.blocks_receiver(p) {
            return 0.0;
        }
        let Some(corners) = self.corners() else {
            return 0.5 * std::f64::consts::PI * (1.0 - n.dot(self.normal).clamp(-1.0, 1.0));
        };
        polygon_projected_solid_angle(&corners.map(|c| c - p), n)
    }

    /// The directions from p blocked by a rectangle as an intersection of four half-spaces of
    /// directions: unit `e_k` with `ω` blocked iff `ω·e_k ≥ 0` for every k (the cone from p over a
    /// convex polygon). `None` for a half-space or when p is on the plate's plane.
    pub fn edge_normals(&self, p: DVec3) -> Option<[DVec3; 4]> {
        let corners = self.corners()?;
        if !self.blocks_receiver(p) {
            return None;
        }
        let a = corners.map(|c| c - p);
        // The corners turn counter-clockwise about m, so seen from above (m·p > d) a_k × a_{k+1}
        // points out of the cone (towards +m's side of the edge); from below, into it.
        let s = if self.height(p) > 0.0 { -1.0 } else { 1.0 };
        Some([0, 1, 2, 3].map(|k| (s * a[k].cross(a[(k + 1) % 4])).normalize()))
    }

    /// The bounding rectangle of a flat mesh (world-space positions, triangles `indices`) in the frame
    /// of its first non-degenerate edge, checked to be a rectangle: every vertex within `flat_tol` of
    /// the plane, and the triangles' area equal to the rectangle's within 0.1 %.
    pub fn from_flat_mesh(positions: &[DVec3], indices: &[u32]) -> Result<Self, String> {
        let tri = |k: usize| -> Option<[DVec3; 3]> {
            let ix = indices.get(3 * k..3 * k + 3)?;
            Some(
                [positions.get(ix[0] as usize)?, positions.get(ix[1] as usize)?, positions.get(ix[2] as usize)?]
                    .map(|p| *p),
            )
        };
        let count = indices.len() / 3;
        let mut area = 0.0;
        let mut normal = DVec3::ZERO;
        let mut edge = None;
        for k in 0..count {
            let Some([a, b, c]) = tri(k) else { return Err(format!("triangle {k} uses a vertex out of range")) };
            let n = (b - a).cross(c - a);
            area += 0.5 * n.length();
            normal += n;
            if edge.is_none() && (b - a).length() > 0.0 && n.length() > 0.0 {
                edge = Some(b - a);
            }
        }
        let (Some(edge), true) = (edge, normal.length() > 0.0) else {
            return Err("a plane blocker mesh must have triangles of non-zero area".into());
        };
        if !positions.iter().all(|p| p.is_finite()) {
            return Err("a plane blocker mesh has non-finite positions".into());
        }
        let m = normal.normalize();
        let u_dir = (edge - m * m.dot(edge)).normalize();
        let v_dir = m.cross(u_dir);
        let used: Vec<DVec3> = indices.iter().map(|&i| positions[i as usize]).collect();
        let o = used[0];
        let (mut lo, mut hi) = (glam::DVec2::splat(f64::MAX), glam::DVec2::splat(f64::MIN));
        let mut h_max: f64 = 0.0;
        for p in &used {
            let q = *p - o;
            let uv = glam::DVec2::new(q.dot(u_dir), q.dot(v_dir));
            lo = lo.min(uv);
            hi = hi.max(uv);
            h_max = h_max.max(q.dot(m).abs());
        }
        let ext = hi - lo;
        let scale = ext.max_element().max(1e-30);
        if h_max > 1e-5 * scale {
            return Err(format!("a plane blocker mesh must be flat (a vertex lies {h_max:.3e} off its plane)"));
        }
        let rect_area = ext.x * ext.y;
        if (rect_area - area).abs() > 1e-3 * rect_area {
            return Err(format!(
                "a plane blocker mesh must be a rectangle (its area {area:.4} differs from its bounding \
                 rectangle's {rect_area:.4})"
            ));
        }
        let mid = 0.5 * (lo + hi);
        let centre = o + u_dir * mid.x + v_dir * mid.y;
        let (hu, hv) = (u_dir * (0.5 * ext.x), v_dir * (0.5 * ext.y));
        // Keep the mesh's own orientation (its normal) as the plate's normal.
        let (hu, hv) = if hu.cross(hv).dot(m) >= 0.0 { (hu, hv) } else { (hv, hu) };
        let plane = Self::rectangle(centre, hu, hv);
        plane.validate()?;
        Ok(plane)
    }
}

/// ∫ (n·ω)⁺ dω over the directions through the convex polygon `a` (vertices relative to the viewpoint, in
/// order around it; at most 4): the polygon clipped to n·x ≥ 0, then Lambert's formula ½ |Σ_e Θ_e n·u_e|
/// (see [`BlockerPlane::projected_solid_angle`]).
pub fn polygon_projected_solid_angle(a: &[DVec3; 4], n: DVec3) -> f64 {
    let mut poly: Vec<DVec3> = Vec::with_capacity(5);
    for k in 0..4 {
        let (u, w) = (a[k], a[(k + 1) % 4]);
        let (du, dw) = (n.dot(u), n.dot(w));
        if du >= 0.0 {
            poly.push(u);
        }
        if (du >= 0.0) != (dw >= 0.0) {
            poly.push(u + (w - u) * (du / (du - dw)));
        }
    }
    if poly.len() < 3 {
        return 0.0;
    }
    let mut sum = 0.0;
    for k in 0..poly.len() {
        let (u, w) = (poly[k], poly[(k + 1) % poly.len()]);
        let x = u.cross(w);
        let lx = x.length();
        if lx > 0.0 {
            sum += lx.atan2(u.dot(w)) * n.dot(x) / lx;
        }
    }
    (0.5 * sum.abs()).min(std::f64::consts::PI)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn random_dirs(n: usize) -> Vec<DVec3> {
        let mut rng = 0x1234_5678_u64;
        let mut next = move || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let z = 2.0 * next() - 1.0;
                let phi = 2.0 * std::f64::consts::PI * next();
                let r = (1.0 - z * z).sqrt();
                DVec3::new(r * phi.cos(), z, r * phi.sin())
            })
            .collect()
    }

    #[test]
    fn half_space_blocks_the_lower_hemisphere_only_from_above() {
        let pl = BlockerPlane::half_space(DVec3::new(0.0, 0.5, 0.0), DVec3::Y * 2.0);
        pl.validate().unwrap();
        let above = DVec3::new(0.3, 1.5, -2.0);
        for d in random_dirs(2000) {
            assert_eq!(pl.blocks_direction(above, d), d.y < 0.0, "{d:?}");
            if let Some(t) = pl.hit(above, above, d, 1e30) {
                assert!(((above + t * d).y - 0.5).abs() < 1e-12);
            }
        }
        // On the plane (the ground itself) and below it (inside the solid): never shadowed.
        for p in [DVec3::new(4.0, 0.5, 1.0), DVec3::new(0.0, 0.5 + 1e-5, 0.0), DVec3::new(0.0, -3.0, 0.0)] {
            assert!(random_dirs(100).iter().all(|&d| !pl.blocks_direction(p, d)), "{p:?}");
        }
    }

    /// The rectangle's edge half-spaces select exactly the directions whose rays hit it, from both sides.
    #[test]
    fn rectangle_edges_match_ray_hits() {
        let pl =
            BlockerPlane::rectangle(DVec3::new(0.2, 1.0, 0.0), DVec3::new(1.5, 0.0, 0.0), DVec3::new(0.0, 0.0, -0.7));
        pl.validate().unwrap();
        assert!((pl.normal - DVec3::Y).length() < 1e-12);
        for p in [
            DVec3::new(0.5, 2.0, 0.3),
            DVec3::new(2.0, 1.6, 1.0),
            DVec3::new(0.0, -1.0, 0.1),
            DVec3::new(-4.0, 0.2, 0.0),
        ] {
            let e = pl.edge_normals(p).expect("off the plane");
            let mut hits = 0;
            for d in random_dirs(4000) {
                let by_edges = e.iter().all(|e| d.dot(*e) >= 0.0);
                let by_ray = pl.blocks_direction(p, d);
                let margin = e.iter().map(|e| d.dot(*e).abs()).fold(f64::MAX, f64::min);
                if margin > 1e-9 {
                    assert_eq!(by_edges, by_ray, "p {p:?} d {d:?}");
                }
                hits += by_ray as usize;
            }
            assert!(hits > 10, "p {p:?}: the plate is seen");
        }
        assert!(pl.edge_normals(DVec3::new(9.0, 1.0, 9.0)).is_none(), "on the plate's plane");
    }

    /// The projected solid angle against a midpoint quadrature of (n·ω)⁺ × the ray test over the hemisphere
    /// of n (600 × 600 cells in (cos²θ, φ), where the cosine-weighted measure is uniform): half-spaces and
    /// rectangles seen from near and far, above and below, partly behind the horizon.
    #[test]
    fn projected_solid_angle_matches_quadrature() {
        use std::f64::consts::PI;
        let cases = [
            (BlockerPlane::half_space(DVec3::ZERO, DVec3::Y), DVec3::new(0.0, 0.3, 0.0), DVec3::new(0.6, -0.64, 0.48)),
            (
                BlockerPlane::rectangle(DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0), DVec3::new(0.0, 0.0, 2.0)),
                DVec3::new(0.1, 0.15, -0.1),
                DVec3::new(0.43, -0.41, 0.81).normalize(),
            ),
            (
                BlockerPlane::rectangle(
                    DVec3::new(0.3, 1.5, 0.6),
                    DVec3::new(0.3, 0.0, 0.0),
                    DVec3::new(0.0, 0.0, 0.3),
                ),
                DVec3::ZERO,
                DVec3::new(0.2, 0.9, 0.1).normalize(),
            ),
            (
                BlockerPlane::rectangle(
                    DVec3::new(0.0, 0.0, 1.0),
                    DVec3::new(1.0, 0.0, 0.0),
                    DVec3::new(0.0, 1.0, 0.0),
                ),
                DVec3::new(0.5, 0.2, 0.4),
                DVec3::new(1.0, 0.0, 0.2).normalize(),
            ),
        ];
        for (k, (pl, p, n)) in cases.iter().enumerate() {
            let got = pl.projected_solid_angle(*p, *n);
            let t = n.any_orthonormal_vector();
            let b = n.cross(t);
            let m = 600;
            let mut hits = 0usize;
            for i in 0..m {
                let r2 = (i as f64 + 0.5) / m as f64;
                for j in 0..m {
                    let phi = 2.0 * PI * (j as f64 + 0.5) / m as f64;
                    let w = (t * phi.cos() + b * phi.sin()) * r2.sqrt() + *n * (1.0 - r2).sqrt();
                    hits += usize::from(pl.blocks_direction(*p, w));
                }
            }
            let want = PI * hits as f64 / (m * m) as f64;
            assert!((got - want).abs() < 2e-3, "case {k}: {got} vs quadrature {want}");
            assert!(got > 0.05, "case {k}: the blocker should hide something ({got})");
        }
        let below = BlockerPlane::half_space(DVec3::ZERO, DVec3::Y);
        assert_eq!(below.projected_solid_angle(DVec3::new(0.0, -1.0, 0.0), DVec3::Y), 0.0, "spared by the rule");
    }

    #[test]
    fn flat_mesh_becomes_its_rectangle() {
        // A 2 × 2 grid of quads, 4 × 3, tilted.
        let rot = glam::DQuat::from_rotation_x(0.3);
        let mut positions = Vec::new();
        for j in 0..=2 {
            for i in 0..=2 {
                positions.push(rot * DVec3::new(-2.0 + 2.0 * i as f64, 1.0, -1.5 + 1.5 * j as f64));
            }
        }
        let mut indices = Vec::new();
        for j in 0..2u32 {
            for i in 0..2u32 {
                let a = j * 3 + i;
                indices.extend_from_slice(&[a, a + 3, a + 1, a + 1, a + 3, a + 4]);
            }
        }
        let pl = BlockerPlane::from_flat_mesh(&positions, &indices).unwrap();
        let (c, u, v) = pl.rect.unwrap();
        assert!((c - rot * DVec3::new(0.0, 1.0, 0.0)).length() < 1e-12);
        assert!((4.0 * u.length() * v.length() - 12.0).abs() < 1e-9);
        assert!((pl.normal - rot * DVec3::Y).length() < 1e-12, "the mesh's own normal {:?}", pl.normal);
        // Not flat, not a rectangle, empty: errors.
        let mut bent = positions.clone();
        bent[4].y += 0.1;
        assert!(BlockerPlane::from_flat_mesh(&bent, &indices).unwrap_err().contains("flat"));
        assert!(BlockerPlane::from_flat_mesh(&positions, &indices[..18]).unwrap_err().contains("rectangle"));
        assert!(BlockerPlane::from_flat_mesh(&positions, &[]).is_err());
        assert!(BlockerPlane::from_flat_mesh(&positions, &[0, 1, 99]).is_err());
    }

    #[test]
    fn bad_planes_are_refused() {
        let mut pl = BlockerPlane::half_space(DVec3::ZERO, DVec3::Y);
        pl.normal = DVec3::new(0.0, 2.0, 0.0);
        assert!(pl.validate().is_err());
        assert!(BlockerPlane::half_space(DVec3::ZERO, DVec3::new(f64::NAN, 1.0, 0.0)).validate().is_err());
        assert!(BlockerPlane::rectangle(DVec3::ZERO, DVec3::X, DVec3::X).validate().is_err());
        assert!(BlockerPlane::rectangle(DVec3::ZERO, DVec3::X, DVec3::new(0.5, 0.0, 1.0)).validate().is_err());
    }
}
