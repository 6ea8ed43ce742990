//! f64 twin of the thin-shell patch marking (shaders-glsl/common/isg_thin.glsl) and of the thin
//! triangles' self-shadowing rule (shaders-glsl/common/thin.glsl), used by
//! `super::cpu::occlusion_with_thin`.
//!
//! A triangle (world space) seen from receiver p is projected onto the unit sphere around p and
//! rasterized into the lobe's patch grid: a patch is occluded when its centre direction ω lies in the
//! spherical triangle, i.e. the ray p + tω hits the triangle for some t > 0 (three sign tests against
//! the edge planes through p). Both scan only the rows of the triangle's padded bounding cap; this twin
//! tests every candidate centre's signs, the GPU solves each edge's sign test per row in closed form
//! (an arc of columns), which agrees up to centres within f32 rounding of an edge.
//!
//! The clusters and their cone culling on the GPU are conservative (a culled cluster has no direction
//! in the grid), so the twin takes the triangles as a flat list.

use super::grid::Grid;
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI};

/// A triangle whose plane passes within this many longest-edge lengths of the receiver is ignored.
pub const PLANE_EPS: f64 = 1e-3;
/// Angular padding (radians) of the bounding box (`ISG_THIN_PAD`).
pub const PAD: f64 = 2e-3;

/// The self-shadowing rule (`thin_blocks_receiver`): `None` when the triangle (receiver-relative
/// vertices) is degenerate (thinner than 1e-6 of its longest edge) or its plane passes within
/// [`PLANE_EPS`] × its longest edge of the receiver (its own triangle, coplanar neighbours, edge-on
/// triangles); otherwise the sign of det(a, b, c).
pub fn blocks_receiver(a: DVec3, b: DVec3, c: DVec3) -> Option<f64> {
    let (e1, e2) = (b - a, c - a);
    let nrm = e1.cross(e2);
    let len2 = e1.length_squared().max(e2.length_squared()).max((c - b).length_squared());
    let area2 = nrm.length();
    if area2.is_nan() || area2 <= 1e-6 * len2 {
        return None;
    }
    let det = nrm.dot(a);
    if det.is_nan() || det.abs() <= PLANE_EPS * len2.sqrt() * area2 {
        return None;
    }
    Some(if det > 0.0 { 1.0 } else { -1.0 })
}

/// Whether the centre of patch (i, j) is inside the triangle with local edge normals `e`.
fn inside(g: &Grid, i: usize, j: usize, e: &[DVec3; 3]) -> bool {
    let (t, f) = (g.lo + (i as f64 + 0.5) * g.delta, g.lo + (j as f64 + 0.5) * g.delta);
    let w = DVec3::new(t.sin() * f.cos(), t.cos(), t.sin() * f.sin());
    e.iter().all(|e| e.dot(w) >= 0.0)
}

/// Rasterizes one triangle (receiver-relative vertices) into `mask` (row-major `mask[i][j]`); `n` is
/// the receiver's unit normal. Returns whether it was considered (passed the rule, not wholly below
/// the tangent plane, and reached the grid's rows).
pub fn mark_triangle(mask: &mut [Vec<bool>], g: &Grid, n: DVec3, a: DVec3, b: DVec3, c: DVec3) -> bool {
    let Some(orient) = blocks_receiver(a, b, c) else { return false };
    if a.dot(n) <= 0.0 && b.dot(n) <= 0.0 && c.dot(n) <= 0.0 {
        return false;
    }
    let local = |v: DVec3| DVec3::new(v.dot(g.x), v.dot(g.y), v.dot(g.z));
    let e = [local(orient * a.cross(b - a)), local(orient * b.cross(c - b)), local(orient * c.cross(a - c))];
    let (ua, ub, uc) = (a.normalize(), b.normalize(), c.normalize());
    let s = ua + ub + uc;
    let sl = s.length();
    let last = g.side as f64 - 1.0;
    let (mut i_lo, mut i_hi) = (0i64, g.side as i64 - 1);
    let mut columns: Option<(f64, f64)> = None;
    if sl > 1e-6 {
        let u = s / sl;
        let cos_psi = u.dot(ua).min(u.dot(ub)).min(u.dot(uc));
        let psi = cos_psi.clamp(-1.0, 1.0).acos() + PAD;
        if psi < FRAC_PI_2 {
            let (ux, uy, uz) = (u.dot(g.x), u.dot(g.y), u.dot(g.z));
            let rho = (ux * ux + uz * uz).sqrt();
            let theta_c = rho.atan2(uy);
            i_lo = ((theta_c - psi - g.lo) / g.delta - 0.5).ceil().clamp(0.0, last + 1.0) as i64;
            i_hi = ((theta_c + psi - g.lo) / g.delta - 0.5).floor().clamp(-1.0, last) as i64;
            if psi < theta_c && psi < PI - theta_c && rho > 0.0 {
                columns = Some((uz.atan2(ux), (psi.sin() / rho).clamp(0.0, 1.0).asin() + PAD));
            }
        }
    }
    if i_lo > i_hi {
        return false;
    }
    for (i, row) in mask.iter_mut().enumerate().take(i_hi as usize + 1).skip(i_lo as usize) {
        match columns {
            None => {
                for (j, m) in row.iter_mut().enumerate() {
                    *m |= inside(g, i, j, &e);
                }
            }
            Some((phi_c, half)) => {
                for k in -1..=1 {
                    let cc = phi_c + 2.0 * PI * k as f64;
                    let j_lo = ((cc - half - g.lo) / g.delta - 0.5).ceil().clamp(0.0, last + 1.0) as usize;
                    let j_hi = ((cc + half - g.lo) / g.delta - 0.5).floor().clamp(-1.0, last) as i64;
                    for (j, m) in row.iter_mut().enumerate().take((j_hi + 1) as usize).skip(j_lo) {
                        *m |= inside(g, i, j, &e);
                    }
                }
            }
        }
    }
    true
}

/// Marks the patches of grid `g` occluded by the thin `triangles` (world space) seen from p (unit
/// normal n). Returns whether any triangle reached the grid.
pub fn mark_thin(mask: &mut [Vec<bool>], g: &Grid, p: DVec3, n: DVec3, triangles: &[[DVec3; 3]]) -> bool {
    let mut marked = false;
    for t in triangles {
        marked |= mark_triangle(mask, g, n, t[0] - p, t[1] - p, t[2] - p);
    }
    marked
}

/// Form factor from a point to a parallel rectangle [x0, x1] × [z0, z1] at height h above it (the
/// point at the origin, normal +Y): the fraction of the cosine-weighted hemisphere, ∫ (n·ω)⁺ dω / π,
/// the rectangle covers. Sum of the corner rectangles' closed form (Howell's catalogue C-11),
/// F(X, Y) = 1/(2π) [X/√(1+X²) atan(Y/√(1+X²)) + Y/√(1+Y²) atan(X/√(1+Y²))], signed.
pub fn parallel_rectangle_form_factor(x0: f64, x1: f64, z0: f64, z1: f64, h: f64) -> f64 {
    let corner = |x: f64, z: f64| {
        let (a, b) = (x / h, z / h);
        let (sa, sb) = ((1.0 + a * a).sqrt(), (1.0 + b * b).sqrt());
        (a / sa * (b / sa).atan() + b / sb * (a / sb).atan()) / (2.0 * PI)
    };
    corner(x1, z1) - corner(x0, z1) - corner(x1, z0) + corner(x0, z0)
}

#[cfg(test)]
mod tests {
    use super::super::grid::grid;
    use super::super::IsgOptions;
    use super::*;

    /// A square at height y, n × n quads, two triangles each.
    fn grid_square(y: f64, half: f64, n: usize) -> Vec<[DVec3; 3]> {
        let s = |i: usize| -half + 2.0 * half * i as f64 / n as f64;
        let q = |i: usize, j: usize| DVec3::new(s(i), y, s(j));
        let mut out = Vec::new();
        for i in 0..n {
            for j in 0..n {
                out.push([q(i, j), q(i + 1, j), q(i + 1, j + 1)]);
                out.push([q(i, j), q(i + 1, j + 1), q(i, j + 1)]);
            }
        }
        out
    }

    fn count(mask: &[Vec<bool>]) -> usize {
        mask.iter().flatten().filter(|b| **b).count()
    }

    /// The marked patches of a square straight above equal the patches whose centre ray hits it
    /// (checked by ray casting every patch centre), for broad and sharp lobes.
    #[test]
    fn marks_exactly_the_patches_whose_centre_hits() {
        let o = IsgOptions { side: 32, ..IsgOptions::default() };
        for (lambda, axis, n) in [
            (1.0, DVec3::Y, 1),
            (30.0, DVec3::new(0.2, 1.0, 0.1).normalize(), 1),
            (400.0, DVec3::Y, 1),
            (1.0, DVec3::Y, 12),
            (2.0, DVec3::new(0.7, 0.5, -0.2).normalize(), 12),
            (30.0, DVec3::new(0.2, 1.0, 0.1).normalize(), 12),
            (400.0, DVec3::new(0.05, 1.0, -0.02).normalize(), 40),
        ] {
            let tris = grid_square(1.0, 0.4, n);
            let g = grid(axis, lambda, &o);
            let mut mask = vec![vec![false; g.side]; g.side];
            assert!(mark_thin(&mut mask, &g, DVec3::ZERO, DVec3::Y, &tris));
            for (i, row) in mask.iter().enumerate() {
                for (j, &m) in row.iter().enumerate() {
                    let (t, f) = (g.lo + (i as f64 + 0.5) * g.delta, g.lo + (j as f64 + 0.5) * g.delta);
                    let w = g.x * (t.sin() * f.cos()) + g.y * t.cos() + g.z * (t.sin() * f.sin());
                    let hit = w.y > 0.0 && {
                        let t = 1.0 / w.y;
                        (w.x * t).abs() <= 0.4 && (w.z * t).abs() <= 0.4
                    };
                    assert_eq!(m, hit, "λ {lambda}: patch ({i}, {j})");
                }
            }
            assert!(count(&mask) > 0, "λ {lambda}: nothing marked");
        }
    }

    /// Random small triangles around a receiver (near its horizon, near the poles of the grid's
    /// parameterization, straddling): the bounding-box restriction loses nothing against testing every patch.
    #[test]
    fn bounding_box_loses_no_patch() {
        let o = IsgOptions { side: 16, ..IsgOptions::default() };
        let mut rng = engine_math::rng::Pcg32::new(3, 9);
        let mut u = || rng.next_f64() * 2.0 - 1.0;
        for case in 0..400 {
            let n = DVec3::new(0.3 * u(), 1.0, 0.3 * u()).normalize();
            let axis = (n + DVec3::new(0.5 * u(), 0.5 * u(), 0.5 * u())).normalize();
            let lambda = [0.5, 3.0, 30.0][case % 3];
            let g = grid(axis, lambda, &o);
            let c = DVec3::new(u(), 0.3 * u(), u()) * 0.3;
            let s = 0.05 + 0.1 * (u() + 1.0);
            let t = [c, c + DVec3::new(u(), u(), u()) * s, c + DVec3::new(u(), u(), u()) * s];
            let mut mask = vec![vec![false; g.side]; g.side];
            mark_triangle(&mut mask, &g, n, t[0], t[1], t[2]);
            let mut brute = vec![vec![false; g.side]; g.side];
            if let Some(orient) = blocks_receiver(t[0], t[1], t[2]) {
                if t.iter().any(|v| v.dot(n) > 0.0) {
                    let local = |v: DVec3| DVec3::new(v.dot(g.x), v.dot(g.y), v.dot(g.z));
                    let e = [
                        local(orient * t[0].cross(t[1] - t[0])),
                        local(orient * t[1].cross(t[2] - t[1])),
                        local(orient * t[2].cross(t[0] - t[2])),
                    ];
                    for (i, row) in brute.iter_mut().enumerate() {
                        for (j, b) in row.iter_mut().enumerate() {
                            *b = inside(&g, i, j, &e);
                        }
                    }
                }
            }
            assert_eq!(mask, brute, "case {case}");
        }
    }

    #[test]
    fn form_factor_limits() {
        // An infinite sheet covers the whole hemisphere; a square straight above: the corner formula
        // at X = Y = 1 is (1/π)(1/√2) atan(1/√2) = 0.138532 per quadrant.
        assert!((parallel_rectangle_form_factor(-1e6, 1e6, -1e6, 1e6, 1.0) - 1.0).abs() < 1e-5);
        let f = parallel_rectangle_form_factor(-1.0, 1.0, -1.0, 1.0, 1.0);
        assert!((f - 4.0 * 0.138_532).abs() < 1e-5, "{f}");
        // Symmetric in the rectangle's position; zero width gives zero.
        let a = parallel_rectangle_form_factor(0.2, 0.9, -0.3, 0.4, 0.7);
        let b = parallel_rectangle_form_factor(-0.9, -0.2, -0.4, 0.3, 0.7);
        assert!((a - b).abs() < 1e-12);
        assert_eq!(parallel_rectangle_form_factor(0.5, 0.5, -1.0, 1.0, 1.0), 0.0);
    }
}
