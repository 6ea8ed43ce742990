//! f64 twin of the per-point ISG integral (shaders-glsl/common/isg_visibility.glsl and
//! shaders-glsl/shade/isg/shade.glsl). Blockers are a flat list of spheres: this equals the GPU
//! traversal with `node_threshold = 0` (every node opened down to its leaves; leaves are culled by
//! the same exact cone test).

use super::options::{Evaluator, IsgOptions};
use engine_blockers::geom::{blocker_for_receiver, cone_intersects_sphere, subtended_half_angle, Cone, Sphere};
use engine_blockers::BlockerPlane;
use engine_math::isg::{isg_normalization, isg_paper, IsgLut};
use engine_math::sg::{sg_product_log, Sg, SgRgb, COSINE_SG_LAMBDA, COSINE_SG_MU};
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI};

pub use super::grid::{basis, grid, limiting_angle, Grid};

/// Bits of row i's patches whose centre lies in the cap {ω : ω·u ≥ cos ψ}, u given in the grid's
/// coordinates ([`cap_coords`]). Twin of `isg_cap_row_bits`.
pub fn cap_row_bits(g: &Grid, i: usize, (rho, uy, phi_c): (f64, f64, f64), cos_psi: f64) -> u32 {
    let full = if g.side >= 32 { u32::MAX } else { (1u32 << g.side) - 1 };
    let last = (g.side - 1) as f64;
    let th = g.lo + (i as f64 + 0.5) * g.delta;
    let denom = th.sin() * rho;
    let rhs = cos_psi - th.cos() * uy;
    if denom < 1e-7 {
        return if rhs <= 0.0 { full } else { 0 };
    }
    let q = rhs / denom;
    if q <= -1.0 {
        return full;
    }
    if q > 1.0 {
        return 0;
    }
    let w = q.acos();
    let mut bits = 0u32;
    for k in -1..=1 {
        let c = phi_c + 2.0 * PI * k as f64;
        let j_lo = ((c - w - g.lo) / g.delta - 0.5).ceil().clamp(0.0, last + 1.0) as i64;
        let j_hi = ((c + w - g.lo) / g.delta - 0.5).floor().clamp(-1.0, last) as i64;
        for j in j_lo..=j_hi {
            bits |= 1 << j;
        }
    }
    bits
}

/// The grid coordinates of unit u: (ρ = |(u·x, u·z)|, u·y, φ_c = atan2(u·z, u·x)) and θ_c.
pub fn cap_coords(g: &Grid, u: DVec3) -> ((f64, f64, f64), f64) {
    let (ux, uy, uz) = (u.dot(g.x), u.dot(g.y), u.dot(g.z));
    let rho = (ux * ux + uz * uz).sqrt();
    ((rho, uy, if rho > 0.0 { uz.atan2(ux) } else { 0.0 }), rho.atan2(uy))
}

fn or_bits(row: &mut [bool], bits: u32) {
    for (j, b) in row.iter_mut().enumerate() {
        *b |= bits >> j & 1 != 0;
    }
}

/// Marks (row-major `mask[i][j]`) the patches whose centre lies within `psi` of unit `u`.
pub fn mark_cap(mask: &mut [Vec<bool>], g: &Grid, u: DVec3, psi: f64) {
    if psi >= PI {
        mask.iter_mut().for_each(|r| r.iter_mut().for_each(|b| *b = true));
        return;
    }
    let (coords, theta_c) = cap_coords(g, u);
    let last = (g.side - 1) as f64;
    let i_lo = ((theta_c - psi - g.lo) / g.delta - 0.5).ceil().clamp(0.0, last + 1.0) as i64;
    let i_hi = ((theta_c + psi - g.lo) / g.delta - 0.5).floor().clamp(-1.0, last) as i64;
    for i in i_lo..=i_hi {
        or_bits(&mut mask[i as usize], cap_row_bits(g, i as usize, coords, psi.cos()));
    }
}

/// Marks the patches whose centre direction from receiver p is blocked by a plane (twin of
/// `isg_planes_mark`, shaders-glsl/common/isg_planes.glsl): a half-space's cap of half-angle π/2
/// around −m, a rectangle's four edge caps intersected row by row. Whether any plane could block
/// a patch of the grid.
pub fn mark_planes(mask: &mut [Vec<bool>], g: &Grid, p: DVec3, planes: &[BlockerPlane]) -> bool {
    let mut marked = false;
    for pl in planes.iter().filter(|pl| pl.blocks_receiver(p)) {
        let Some(edges) = pl.edge_normals(p) else {
            let down = -pl.normal;
            if engine_blockers::geom::angle_between(g.z, down) <= g.cone + FRAC_PI_2 {
                mark_cap(mask, g, down, FRAC_PI_2);
                marked = true;
            }
            continue;
        };
        let (c, u, v) = pl.rect.expect("a plane with edges is a rectangle");
        if !cone_intersects_sphere(&Cone::new(p, g.z, g.cone), &Sphere::new(c, (u + v).length())) {
            continue;
        }
        let coords = edges.map(|e| cap_coords(g, e).0);
        for (i, row) in mask.iter_mut().enumerate() {
            let bits = coords.iter().fold(u32::MAX, |b, &c| b & cap_row_bits(g, i, c, 0.0));
            or_bits(row, bits);
        }
        marked = true;
    }
    marked
}

/// Ŝ at a corner with the chosen evaluator.
fn corner(theta: f64, phi: f64, lambda: f64, e: Evaluator, lut: &IsgLut) -> f64 {
    match e {
        Evaluator::Table => lut.eval(theta, phi, lambda),
        Evaluator::Paper => isg_paper(theta, phi, lambda),
    }
}

/// Sum of Ŝ over the marked patches (four corners per run of a row).
pub fn occluded_sum(mask: &[Vec<bool>], g: &Grid, lambda: f64, e: Evaluator, lut: &IsgLut) -> f64 {
    let mut sum = 0.0;
    for (i, row) in mask.iter().enumerate() {
        let t0 = g.lo + i as f64 * g.delta;
        let t1 = t0 + g.delta;
        let mut j = 0;
        while j < g.side {
            if !row[j] {
                j += 1;
                continue;
            }
            let j0 = j;
            while j < g.side && row[j] {
                j += 1;
            }
            let (p0, p1) = (g.lo + j0 as f64 * g.delta, g.lo + j as f64 * g.delta);
            sum += corner(t1, p1, lambda, e, lut) - corner(t0, p1, lambda, e, lut) - corner(t1, p0, lambda, e, lut)
                + corner(t0, p0, lambda, e, lut);
        }
    }
    sum.max(0.0)
}

/// The blockers a receiver sees: spheres, thin-shell triangles (world space) and planes.
#[derive(Clone, Copy, Debug, Default)]
pub struct Occluders<'a> {
    pub spheres: &'a [Sphere],
    pub thin: &'a [[DVec3; 3]],
    pub planes: &'a [BlockerPlane],
}

impl<'a> Occluders<'a> {
    pub fn spheres(spheres: &'a [Sphere]) -> Self {
        Self { spheres, ..Self::default() }
    }
    pub fn is_empty(&self) -> bool {
        self.spheres.is_empty() && self.thin.is_empty() && self.planes.is_empty()
    }
}

/// Marks grid `g`'s patches occluded, seen from receiver p (unit normal n), by the spheres in the
/// grid's cone (after the self-shadowing rule), the thin triangles and the planes; whether any was
/// marked.
pub fn mark_blockers(mask: &mut [Vec<bool>], g: &Grid, p: DVec3, n: DVec3, occ: &Occluders) -> bool {
    let cone = Cone::new(p, g.z, g.cone);
    let mut marked = false;
    for s in occ.spheres {
        if !cone_intersects_sphere(&cone, s) {
            continue;
        }
        let Some(b) = blocker_for_receiver(p, n, s) else { continue };
        if b.radius <= 0.0 {
            continue;
        }
        let d = b.center - p;
        let dist = d.length();
        if dist <= 0.0 {
            continue;
        }
        mark_cap(mask, g, d / dist, subtended_half_angle(p, &b));
        marked = true;
    }
    marked |= super::thin::mark_thin(mask, g, p, n, occ.thin);
    mark_planes(mask, g, p, occ.planes) | marked
}

/// Occluded parts of the lobe (axis, λ) at receiver p with unit normal n, in Ŝ units: (by the
/// receiver's tangent plane alone — V = 0 below it —, by the plane and the spheres together).
pub fn occlusion(
    p: DVec3,
    n: DVec3,
    axis: DVec3,
    lambda: f64,
    o: &IsgOptions,
    spheres: &[Sphere],
    lut: &IsgLut,
) -> (f64, f64) {
    occlusion_by(p, n, axis, lambda, o, &Occluders::spheres(spheres), lut)
}

/// [`occlusion`] with thin-shell triangles (world space) among the blockers ([`super::thin`]).
#[allow(clippy::too_many_arguments)]
pub fn occlusion_with_thin(
    p: DVec3,
    n: DVec3,
    axis: DVec3,
    lambda: f64,
    o: &IsgOptions,
    spheres: &[Sphere],
    thin: &[[DVec3; 3]],
    lut: &IsgLut,
) -> (f64, f64) {
    occlusion_by(p, n, axis, lambda, o, &Occluders { spheres, thin, planes: &[] }, lut)
}

/// [`occlusion`] with any [`Occluders`].
pub fn occlusion_by(
    p: DVec3,
    n: DVec3,
    axis: DVec3,
    lambda: f64,
    o: &IsgOptions,
    occ: &Occluders,
    lut: &IsgLut,
) -> (f64, f64) {
    let g = grid(axis, lambda, o);
    let mut mask = vec![vec![false; g.side]; g.side];
    let mut horizon = 0.0;
    if engine_blockers::geom::angle_between(axis, -n) <= g.cone + FRAC_PI_2 {
        mark_cap(&mut mask, &g, -n, FRAC_PI_2);
        horizon = occluded_sum(&mask, &g, lambda, o.evaluator, lut);
    }
    let marked = mark_blockers(&mut mask, &g, p, n, occ);
    (horizon, if marked { occluded_sum(&mask, &g, lambda, o.evaluator, lut) } else { horizon })
}

/// ∫_patch (n·ω) dω of patch (i, j) of the hemisphere grid around n, exactly:
/// ½[θ − sin θ cos θ]_{θ0}^{θ1} (cos φ0 − cos φ1) (twin of `isg_row_sin2` × the φ factor in shade.glsl).
fn patch_cosine_weight(g: &Grid, i: usize, j: usize) -> f64 {
    let (t0, t1) = (g.lo + i as f64 * g.delta, g.lo + (i + 1) as f64 * g.delta);
    let p0 = g.lo + j as f64 * g.delta;
    0.5 * ((t1 - t1.sin() * t1.cos()) - (t0 - t0.sin() * t0.cos())) * (p0.cos() - (p0 + g.delta).cos())
}

/// Diffuse mode `map`: the occluded patches of the P × P grid over the hemisphere above n, each as
/// (centre direction, cosine-weighted solid angle ∫_patch (n·ω) dω). The shader subtracts
/// Σ L̄(centre) · weight from E(n), L̄ the environment prefiltered to the patch width.
pub fn map_occluded_patches(p: DVec3, n: DVec3, o: &IsgOptions, spheres: &[Sphere]) -> Vec<(DVec3, f64)> {
    map_occluded_patches_with_thin(p, n, o, spheres, &[])
}

/// [`map_occluded_patches`] with thin-shell triangles (world space) among the blockers
/// ([`super::thin`]), marked into the same hemisphere grid.
pub fn map_occluded_patches_with_thin(
    p: DVec3,
    n: DVec3,
    o: &IsgOptions,
    spheres: &[Sphere],
    thin: &[[DVec3; 3]],
) -> Vec<(DVec3, f64)> {
    map_occluded_patches_by(p, n, o, &Occluders { spheres, thin, planes: &[] })
}

/// [`map_occluded_patches`] with any [`Occluders`].
pub fn map_occluded_patches_by(p: DVec3, n: DVec3, o: &IsgOptions, occ: &Occluders) -> Vec<(DVec3, f64)> {
    let g = grid(n, 0.0, o);
    let mut mask = vec![vec![false; g.side]; g.side];
    mark_blockers(&mut mask, &g, p, n, occ);
    let mut out = Vec::new();
    for (i, row) in mask.iter().enumerate() {
        let th = g.lo + (i as f64 + 0.5) * g.delta;
        for (j, _) in row.iter().enumerate().filter(|(_, &m)| m) {
            let ph = g.lo + (j as f64 + 0.5) * g.delta;
            let dir = g.x * (th.sin() * ph.cos()) + g.y * th.cos() + g.z * (th.sin() * ph.sin());
            out.push((dir, patch_cosine_weight(&g, i, j)));
        }
    }
    out
}

/// A light whose cap is narrower than this half-angle is seen on a grid of its own ([`small_light_visibility`]).
pub const LIGHT_OWN_GRID: f64 = 0.25 * PI;
/// Patches per side of a light's own grid.
pub const LIGHT_SIDE: usize = 8;

/// Visibility of a spherical light (cap: unit `axis`, half-angle from `sin_alpha`/`cos_alpha`; `None`:
/// the receiver is inside the light, which fills every direction), twin of `isg_lights` in
/// shaders-glsl/shade/isg/shade.glsl. The hemisphere grid above n is marked with the blockers; a light
/// narrower than [`LIGHT_OWN_GRID`] is 1 when no occluded patch lies within its cap grown by a patch diagonal,
/// else seen on its own grid ([`small_light_visibility`]); a wider one in the hemisphere grid: 1 − Σ_occluded C_p / Σ C_p over the
/// patches whose centres lie in the cap; a cap that holds no patch centre takes the patch that holds its axis
/// (1 when the axis is below the grid).
pub fn light_visibility(p: DVec3, n: DVec3, o: &IsgOptions, occ: &Occluders, cap: Option<(DVec3, f64, f64)>) -> f64 {
    let g = grid(n, 0.0, o);
    let mut occluded = vec![vec![false; g.side]; g.side];
    if !mark_blockers(&mut occluded, &g, p, n, occ) {
        return 1.0;
    }
    if let Some((axis, sin_alpha, cos_alpha)) = cap {
        let alpha = sin_alpha.atan2(cos_alpha);
        if alpha < LIGHT_OWN_GRID {
            // Seen on its own grid unless no occluded patch lies within its cap grown by a patch diagonal.
            let mut grown = vec![vec![false; g.side]; g.side];
            mark_cap(&mut grown, &g, axis, alpha + std::f64::consts::SQRT_2 * g.delta);
            let touched = grown.iter().zip(&occluded).any(|(a, b)| a.iter().zip(b).any(|(x, y)| *x && *y));
            return if touched { small_light_visibility(p, n, occ, axis, alpha) } else { 1.0 };
        }
    }
    let mut in_cap = vec![vec![false; g.side]; g.side];
    let (axis, psi) = match cap {
        Some((axis, sin_alpha, cos_alpha)) => (axis, sin_alpha.atan2(cos_alpha)),
        None => (n, PI),
    };
    mark_cap(&mut in_cap, &g, axis, psi);
    let (mut total, mut hidden) = (0.0, 0.0);
    for i in 0..g.side {
        for j in (0..g.side).filter(|&j| in_cap[i][j]) {
            let w = patch_cosine_weight(&g, i, j);
            total += w;
            if occluded[i][j] {
                hidden += w;
            }
        }
    }
    if total > 0.0 {
        return (1.0 - hidden / total).clamp(0.0, 1.0);
    }
    let (ux, uy, uz) = (axis.dot(g.x), axis.dot(g.y), axis.dot(g.z));
    if uz <= 0.0 {
        return 1.0;
    }
    let theta = (ux * ux + uz * uz).sqrt().atan2(uy);
    let phi = uz.atan2(ux);
    let cell = |a: f64| (((a - g.lo) / g.delta).floor().max(0.0) as usize).min(g.side - 1);
    if occluded[cell(theta)][cell(phi)] {
        0.0
    } else {
        1.0
    }
}

/// Visibility of a light's cap (unit `axis`, half-angle `alpha` < π/2) on a grid of its own (twin of
/// `isg_small_light_visibility`): [`LIGHT_SIDE`]² patches over [π/2 − α, π/2 + α]² around the axis, the
/// blockers marked, 1 − Σ_occluded C_p / Σ C_p over the patches whose centres lie in the cap, C_p the patch's
/// solid angle (cos θ0 − cos θ1) δ times (n·ω)⁺ at its centre.
pub fn small_light_visibility(p: DVec3, n: DVec3, occ: &Occluders, axis: DVec3, alpha: f64) -> f64 {
    let (x, y) = basis(axis);
    let c = alpha.cos();
    let g = Grid {
        x,
        y,
        z: axis,
        lo: FRAC_PI_2 - alpha,
        delta: 2.0 * alpha / LIGHT_SIDE as f64,
        side: LIGHT_SIDE,
        cone: (c * c).clamp(0.0, 1.0).acos(),
    };
    let mut occluded = vec![vec![false; g.side]; g.side];
    mark_blockers(&mut occluded, &g, p, n, occ);
    let mut in_cap = vec![vec![false; g.side]; g.side];
    mark_cap(&mut in_cap, &g, axis, alpha);
    let (mut total, mut hidden) = (0.0, 0.0);
    for i in 0..g.side {
        let t0 = g.lo + i as f64 * g.delta;
        let th = t0 + 0.5 * g.delta;
        let row = (t0.cos() - (t0 + g.delta).cos()) * g.delta;
        for j in (0..g.side).filter(|&j| in_cap[i][j]) {
            let ph = g.lo + (j as f64 + 0.5) * g.delta;
            let dir = g.x * (th.sin() * ph.cos()) + g.y * th.cos() + g.z * (th.sin() * ph.sin());
            let w = row * n.dot(dir).max(0.0);
            total += w;
            if occluded[i][j] {
                hidden += w;
            }
        }
    }
    if total > 0.0 {
        (1.0 - hidden / total).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// Visible integral of the SG (axis, λ) with amplitude exp(log_mu): μ (F(λ) − H(λ) · occluded).
fn visible_integral(log_mu: f64, lambda: f64, occluded: f64) -> f64 {
    let full = 2.0 * PI * sphere_unit(lambda);
    (log_mu.exp() * (full - isg_normalization(lambda) * occluded)).max(0.0)
}

/// (1 − e^{−2λ})/λ.
fn sphere_unit(lambda: f64) -> f64 {
    if lambda < 1e-8 {
        2.0
    } else {
        -(-2.0 * lambda).exp_m1() / lambda
    }
}

/// A shading point: world position, unit normal, unit view direction, material.
pub struct Point {
    pub position: DVec3,
    pub normal: DVec3,
    pub view: DVec3,
    /// Diffuse albedo ρ (the BRDF's diffuse term is ρ/π).
    pub diffuse: [f64; 3],
    /// Specular k_s and Blinn-Phong exponent s (normalized lobe k_s (s+8)/(8π) (n·h)^s).
    pub specular: [f64; 3],
    pub shininess: f64,
}

/// Outgoing radiance (diffuse part and the visibility ratio of the specular lobe) of the
/// technique at one point, with the environment as `lobes`. The specular term also needs the
/// prefiltered environment, so it is returned as the ratio that multiplies it.
pub fn shade_diffuse_and_ratio(
    pt: &Point,
    lobes: &[SgRgb],
    o: &IsgOptions,
    spheres: &[Sphere],
    lut: &IsgLut,
) -> ([f64; 3], f64) {
    shade_diffuse_and_ratio_by(pt, lobes, o, &Occluders::spheres(spheres), lut)
}

/// [`shade_diffuse_and_ratio`] with thin-shell triangles (world space) among the blockers.
pub fn shade_diffuse_and_ratio_with_thin(
    pt: &Point,
    lobes: &[SgRgb],
    o: &IsgOptions,
    spheres: &[Sphere],
    thin: &[[DVec3; 3]],
    lut: &IsgLut,
) -> ([f64; 3], f64) {
    shade_diffuse_and_ratio_by(pt, lobes, o, &Occluders { spheres, thin, planes: &[] }, lut)
}

/// [`shade_diffuse_and_ratio`] with any [`Occluders`].
pub fn shade_diffuse_and_ratio_by(
    pt: &Point,
    lobes: &[SgRgb],
    o: &IsgOptions,
    occ: &Occluders,
    lut: &IsgLut,
) -> ([f64; 3], f64) {
    let n = pt.normal;
    let cosine = Sg::new([n.x, n.y, n.z], COSINE_SG_LAMBDA, COSINE_SG_MU);
    let mut e = [0.0; 3];
    for l in lobes {
        let prod = sg_product_log(&Sg::new(l.axis, l.lambda, 1.0), &cosine);
        let axis = DVec3::from_array(prod.axis);
        let (_, hidden) = occlusion_by(pt.position, n, axis, prod.lambda, o, occ, lut);
        let v = visible_integral(prod.log_mu, prod.lambda, hidden);
        for (ec, mu) in e.iter_mut().zip(l.mu) {
            *ec += mu * v;
        }
    }
    let diffuse = [0, 1, 2].map(|c| pt.diffuse[c] / PI * e[c]);
    let ratio = if pt.specular.iter().all(|&k| k == 0.0) || occ.is_empty() {
        1.0
    } else {
        let ndv = n.dot(pt.view).abs().max(1e-6);
        let r = (2.0 * n.dot(pt.view) * n - pt.view).normalize();
        let lambda = pt.shininess / (4.0 * ndv);
        let prod = sg_product_log(&Sg::new([r.x, r.y, r.z], lambda, 1.0), &cosine);
        let axis = DVec3::from_array(prod.axis);
        let (hor, hidden) = occlusion_by(pt.position, n, axis, prod.lambda, o, occ, lut);
        let full = 2.0 * PI * sphere_unit(prod.lambda);
        let above = full - isg_normalization(prod.lambda) * hor;
        if above > 0.0 {
            ((full - isg_normalization(prod.lambda) * hidden) / above).clamp(0.0, 1.0)
        } else {
            1.0
        }
    };
    (diffuse, ratio)
}

/// Eq. 9 visibility ratio of one unit specular lobe (axis, λ) at (p, n): visible over
/// upper-hemisphere integral of its product with the cosine lobe; 1 without blockers. Twin of
/// `isg_lobe_visibility_ratio` (shaders-glsl/shade/isg/specular.glsl).
pub fn lobe_visibility_ratio(
    p: DVec3,
    n: DVec3,
    axis: DVec3,
    lambda: f64,
    o: &IsgOptions,
    occ: &Occluders,
    lut: &IsgLut,
) -> f64 {
    if occ.is_empty() {
        return 1.0;
    }
    let cosine = Sg::new([n.x, n.y, n.z], COSINE_SG_LAMBDA, COSINE_SG_MU);
    let a = axis.normalize();
    let prod = sg_product_log(&Sg::new([a.x, a.y, a.z], lambda, 1.0), &cosine);
    let (hor, hidden) = occlusion_by(p, n, DVec3::from_array(prod.axis), prod.lambda, o, occ, lut);
    let full = 2.0 * PI * sphere_unit(prod.lambda);
    let above = full - isg_normalization(prod.lambda) * hor;
    if above > 0.0 {
        ((full - isg_normalization(prod.lambda) * hidden) / above).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// The ISG specular term of the lobed BRDFs (Cook-Torrance, Ashikhmin–Shirley): Σ_j w_j ∫ L G_j ·
/// ratio_j, clamped at 0, with `integral(axis, λ)` the lobe's unshadowed lighting integral (the
/// prefiltered maps on the GPU). Twin of `isg_specular_lobes`.
pub fn specular(
    position: DVec3,
    n: DVec3,
    lobes: &[engine_math::brdf::SpecularLobe],
    o: &IsgOptions,
    occ: &Occluders,
    lut: &IsgLut,
    integral: impl Fn([f64; 3], f64) -> [f64; 3],
) -> [f64; 3] {
    let mut sum = [0.0; 3];
    for l in lobes.iter().filter(|l| l.weight.iter().any(|&w| w != 0.0)) {
        let ratio = lobe_visibility_ratio(position, n, DVec3::from_array(l.axis), l.lambda, o, occ, lut);
        let i = integral(l.axis, l.lambda);
        for c in 0..3 {
            sum[c] += l.weight[c] * i[c] * ratio;
        }
    }
    sum.map(|x| x.max(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::passes::shade::isg::options::Diffuse;
    use engine_blockers::geom::Sphere;
    use engine_math::isg::IsgLut;
    use glam::DVec3;
    use std::f64::consts::PI;

    /// A square at height y, two triangles (thin-shell tests).
    fn square(y: f64, half: f64) -> Vec<[DVec3; 3]> {
        let q = |x: f64, z: f64| DVec3::new(x * half, y, z * half);
        vec![[q(-1.0, -1.0), q(1.0, -1.0), q(1.0, 1.0)], [q(-1.0, -1.0), q(1.0, 1.0), q(-1.0, 1.0)]]
    }

    /// Hard cases: the receiver's own and nearly coplanar triangles, degenerate and edge-on triangles,
    /// triangles straddling the tangent plane, below it, around the receiver, huge: finite, between the
    /// horizon's occlusion and the whole grid's, and ignored where the rule says so.
    #[test]
    fn hard_cases_are_finite_and_rule_abiding() {
        let lut = IsgLut::generate_default();
        // 16 × 16: one triangle under the self-shadowing rule cannot reach the corner patches of a finer grid
        // (centres 0.14° above the horizon at P = 32).
        let o = IsgOptions { side: 16, ..IsgOptions::default() };
        let (p, n) = (DVec3::ZERO, DVec3::Y);
        for lambda in [1e-4, 1.0, 100.0, 1e5] {
            let (h, none) = occlusion(p, n, n, lambda, &o, &[], &lut);
            // The receiver's own triangle and coplanar neighbours: nothing beyond the horizon.
            let own = square(0.0, 0.5);
            assert_eq!(occlusion_with_thin(p, n, n, lambda, &o, &[], &own, &lut), (h, none));
            // Tilted by 1e-4 rad through the receiver: still within ε of its plane.
            let tilt = [[DVec3::new(-1.0, -1e-4, 0.0), DVec3::new(1.0, 1e-4, -1.0), DVec3::new(1.0, 1e-4, 1.0)]];
            assert_eq!(occlusion_with_thin(p, n, n, lambda, &o, &[], &tilt, &lut).1, none);
            // Degenerate (zero-area, collinear, repeated vertices) and edge-on triangles.
            let a = DVec3::new(0.0, 1.0, 0.0);
            let degenerate = [
                [a, a, a],
                [a, a + DVec3::X, a + 2.0 * DVec3::X],
                [a, a, a + DVec3::Z],
                // Edge-on: its plane contains the receiver.
                [DVec3::new(0.0, 1.0, 0.0), DVec3::new(0.0, 2.0, 1.0), DVec3::new(0.0, 2.0, -1.0)],
            ];
            assert_eq!(occlusion_with_thin(p, n, n, lambda, &o, &[], &degenerate, &lut).1, none, "λ {lambda}");
            // A sheet straddling the tangent plane, a sheet around the receiver (covers more than a
            // hemisphere from below), one wholly below it, and a huge one: finite, within [horizon, whole].
            let straddle = [[DVec3::new(0.5, -1.0, -1.0), DVec3::new(0.5, 1.0, -1.0), DVec3::new(0.5, 0.0, 1.0)]];
            let around =
                [[DVec3::new(-100.0, 0.5, -100.0), DVec3::new(100.0, 0.5, -100.0), DVec3::new(0.0, 0.5, 200.0)]];
            let below = square(-1.0, 3.0);
            let huge = square(1e-2, 5.0);
            let g = grid(n, lambda, &o);
            let whole = occluded_sum(&vec![vec![true; g.side]; g.side], &g, lambda, o.evaluator, &lut);
            for (what, tris) in
                [("straddle", &straddle[..]), ("around", &around[..]), ("below", &below[..]), ("huge", &huge[..])]
            {
                let (hh, v) = occlusion_with_thin(p, n, n, lambda, &o, &[], tris, &lut);
                assert!(v.is_finite() && v >= hh && v <= whole * (1.0 + 1e-9), "{what} λ {lambda}: {v} of {whole}");
            }
            assert_eq!(occlusion_with_thin(p, n, n, lambda, &o, &[], &below, &lut).1, none, "below the plane");
            let (_, around_v) = occlusion_with_thin(p, n, n, lambda, &o, &[], &around, &lut);
            assert!(
                (around_v - whole).abs() <= 1e-9 * whole,
                "λ {lambda}: a sheet over everything: {around_v} of {whole}"
            );
        }
    }

    /// A narrow light (0.14 rad, as `spheres`' from its ground) mostly hidden by a sphere: its visibility on its
    /// own grid is the cosine-weighted visible fraction of its cap within 0.05 (quadrature; 0.047 at worst measured, a blocker's edge concentric with the light's, 8 × 8 patches). On the hemisphere
    /// grid (P = 32: about six patches in this cap) it came out 0 where about a sixth of the light is seen
    /// (issue 35: black penumbra pixels of `isg` on `spheres`).
    #[test]
    fn a_narrow_light_is_seen_on_its_own_grid() {
        let (p, n) = (DVec3::ZERO, DVec3::Y);
        let alpha: f64 = 0.14;
        let tilted = |t: f64| DVec3::new(t.sin(), t.cos(), 0.0);
        let light = tilted(0.3);
        let o = IsgOptions::default();
        for (offset, psi) in [(0.1f64, 0.16f64), (0.05, 0.15), (0.0, 0.1), (0.12, 0.08)] {
            let b = tilted(0.3 + offset);
            let blocker = Sphere::new(b * 2.0, 2.0 * psi.sin());
            let occ = Occluders::spheres(std::slice::from_ref(&blocker));
            let cap = Some((light, alpha.sin(), alpha.cos()));
            let v = light_visibility(p, n, &o, &occ, cap);
            // Quadrature over the light's cap: ω = cos t a + sin t (cos s e1 + sin s e2), dω = sin t dt ds.
            let (e1, e2) = basis(light);
            let (nt, ns) = (300, 600);
            let (mut total, mut seen) = (0.0, 0.0);
            for i in 0..nt {
                let t = (i as f64 + 0.5) / nt as f64 * alpha;
                for j in 0..ns {
                    let s = (j as f64 + 0.5) / ns as f64 * 2.0 * PI;
                    let w = light * t.cos() + (e1 * s.cos() + e2 * s.sin()) * t.sin();
                    let c = n.dot(w).max(0.0) * t.sin();
                    total += c;
                    if w.dot(b) < psi.cos() {
                        seen += c;
                    }
                }
            }
            let exact = seen / total;
            eprintln!("offset {offset}, ψ {psi}: {v:.4} on the light's grid, {exact:.4} exactly");
            assert!((v - exact).abs() < 0.05, "offset {offset}, ψ {psi}: {v} on the light's grid, {exact} exactly");
        }
    }

    #[test]
    fn limiting_angle_bounds_the_lobe() {
        for lambda in [5.0, 50.0, 1e3, 1e5] {
            let g = limiting_angle(lambda, 0.01);
            assert!(((lambda * (g.cos() - 1.0)).exp() - 0.01).abs() < 1e-9);
        }
        assert_eq!(limiting_angle(1.0, 0.01), std::f64::consts::FRAC_PI_2);
    }

    /// The patch grid's marking of one cap matches its solid angle (ISG of a cap against quadrature).
    #[test]
    fn one_sphere_occlusion_matches_quadrature() {
        let lut = IsgLut::generate_default();
        let o = IsgOptions { side: 32, ..IsgOptions::default() };
        let (p, n) = (DVec3::ZERO, DVec3::Y);
        for (lambda, axis, s) in [
            (20.0, DVec3::Y, Sphere::new(DVec3::new(0.0, 3.0, 0.0), 1.0)),
            (5.0, DVec3::new(0.3, 1.0, 0.1).normalize(), Sphere::new(DVec3::new(1.0, 2.0, 0.5), 0.8)),
            (200.0, DVec3::new(0.0, 1.0, 0.2).normalize(), Sphere::new(DVec3::new(0.0, 4.0, 0.9), 0.4)),
        ] {
            let (hor, all) = occlusion(p, n, axis, lambda, &o, &[s], &lut);
            // The sphere lies wholly above the tangent plane: its patches and the horizon's are disjoint.
            let occ = (all - hor) * engine_math::isg::isg_normalization(lambda);
            // Quadrature of the SG over the cap of directions hitting s.
            let c = (s.center - p).normalize();
            let cos_psi = (1.0 - (s.radius / s.center.length()).powi(2)).sqrt();
            let (bx, by) = basis(c);
            let (nt, nph) = (400, 400);
            let psi = cos_psi.acos();
            let mut exact = 0.0;
            for i in 0..nt {
                let t = (i as f64 + 0.5) / nt as f64 * psi;
                for j in 0..nph {
                    let ph = (j as f64 + 0.5) / nph as f64 * 2.0 * PI;
                    let d = c * t.cos() + (bx * ph.cos() + by * ph.sin()) * t.sin();
                    exact +=
                        (lambda * (d.dot(axis) - 1.0)).exp() * t.sin() * (psi / nt as f64) * (2.0 * PI / nph as f64);
                }
            }
            let rel = (occ - exact).abs() / exact;
            assert!(rel < 0.05, "λ {lambda}: grid {occ} vs quadrature {exact} ({rel})");
        }
    }

    /// Diffuse mode `map`: the patch weights tile the hemisphere's cosine integral (π) exactly, and a
    /// sphere's occluded patches hold its cap's cosine-weighted solid angle π h r²/d³ up to the grid.
    #[test]
    fn map_patches_weigh_the_cosine() {
        let (p, n) = (DVec3::ZERO, DVec3::Y);
        for side in [1, 7, 16, 32] {
            let o = IsgOptions { side, diffuse: Diffuse::Map, ..IsgOptions::default() };
            // A sphere covering the whole hemisphere (receiver inside, centre in front).
            let all = map_occluded_patches(p, n, &o, &[Sphere::new(DVec3::new(0.0, 0.5, 0.0), 1.0)]);
            assert_eq!(all.len(), side * side);
            let sum: f64 = all.iter().map(|(_, w)| w).sum();
            assert!((sum - PI).abs() < 1e-12, "P = {side}: Σ weights {sum}");
            assert!(all.iter().all(|(d, w)| d.dot(n) > 0.0 && *w > 0.0 && (d.length() - 1.0).abs() < 1e-12));
        }
        let o = IsgOptions { side: 32, diffuse: Diffuse::Map, ..IsgOptions::default() };
        for (c, r) in [(DVec3::new(0.0, 2.0, 0.0), 0.8), (DVec3::new(1.0, 1.5, 0.3), 0.6)] {
            let got: f64 = map_occluded_patches(p, n, &o, &[Sphere::new(c, r)]).iter().map(|(_, w)| w).sum();
            let d = c.length();
            let want = PI * c.y * r * r / (d * d * d);
            eprintln!("sphere {c:?} r {r}: {got} vs {want} ({:.2} %)", 100.0 * (got - want) / want);
            assert!((got - want).abs() < 0.08 * want, "sphere {c:?} r {r}: {got} vs {want}");
        }
        assert!(map_occluded_patches(p, n, &o, &[]).is_empty());
        assert!(map_occluded_patches(p, n, &o, &[Sphere::new(DVec3::new(0.0, -2.0, 0.0), 1.0)]).is_empty());
    }

    /// Planes in the hemisphere grid: a half-space below a receiver tilted by β hides π(1 − cos β)/2 of
    /// its cosine-weighted hemisphere (the closed form of seeing the upper hemisphere only); a
    /// rectangle facing a receiver hides π times its form factor, from either side; a receiver on a
    /// plane is not shadowed by it; the f64 marking agrees with brute-force ray tests per patch centre.
    #[test]
    fn planes_mark_their_directions() {
        let o = IsgOptions { side: 32, diffuse: Diffuse::Map, ..IsgOptions::default() };
        let weight = |p: DVec3, n: DVec3, planes: &[BlockerPlane]| -> f64 {
            map_occluded_patches_by(p, n, &o, &Occluders { planes, ..Occluders::default() })
                .iter()
                .map(|(_, w)| w)
                .sum()
        };
        let ground = BlockerPlane::half_space(DVec3::ZERO, DVec3::Y);
        let p = DVec3::new(0.3, 0.5, -0.2);
        for beta in [0.0f64, 0.3, 1.0, 1.5, 2.0, 3.0] {
            let n = DVec3::new(beta.sin(), beta.cos(), 0.0);
            let got = weight(p, n, &[ground]);
            let want = PI * (1.0 - beta.cos()) / 2.0;
            eprintln!("half-space, β {beta}: {got:.5} vs {want:.5}");
            assert!((got - want).abs() < 0.01 * PI, "β {beta}: {got} vs {want}");
        }
        // On the plane (the ground's own receivers) and below it: not shadowed.
        assert_eq!(weight(DVec3::new(1.0, 0.0, 2.0), DVec3::Y, &[ground]), 0.0);
        assert_eq!(weight(DVec3::new(1.0, -1.0, 2.0), -DVec3::Y, &[ground]), 0.0);
        // A 1.2 × 0.8 plate at y = 0, its centre 0.5 below (above) a receiver facing it.
        let plate =
            BlockerPlane::rectangle(DVec3::new(0.1, 0.0, 0.0), DVec3::new(0.6, 0.0, 0.0), DVec3::new(0.0, 0.0, -0.4));
        for (p, n) in [(DVec3::new(0.0, 0.5, 0.0), -DVec3::Y), (DVec3::new(0.0, -0.5, 0.0), DVec3::Y)] {
            let got = weight(p, n, &[plate]);
            let want = PI * super::super::thin::parallel_rectangle_form_factor(-0.5, 0.7, -0.4, 0.4, 0.5);
            eprintln!("plate from {p:?}: {got:.5} vs {want:.5}");
            assert!((got - want).abs() < 0.03 * want, "{p:?}: {got} vs {want}");
        }
        // Every patch centre marked iff its ray hits the plane (away from the boundary).
        for (p, n, pl) in [
            (DVec3::new(0.2, 0.4, 0.1), DVec3::new(0.6, 0.3, -0.2).normalize(), plate),
            (DVec3::new(1.0, -0.3, 0.5), DVec3::new(-0.5, 0.2, 0.0).normalize(), plate),
            (DVec3::new(0.0, 0.7, 0.0), DVec3::new(0.9, -0.1, 0.3).normalize(), ground),
        ] {
            let g = grid(n, 0.0, &o);
            let mut mask = vec![vec![false; g.side]; g.side];
            mark_planes(&mut mask, &g, p, &[pl]);
            let mut checked = 0;
            for (i, row) in mask.iter().enumerate() {
                let th = g.lo + (i as f64 + 0.5) * g.delta;
                for (j, &m) in row.iter().enumerate() {
                    let ph = g.lo + (j as f64 + 0.5) * g.delta;
                    let d = g.x * (th.sin() * ph.cos()) + g.y * th.cos() + g.z * (th.sin() * ph.sin());
                    let near_edge = pl.edge_normals(p).is_some_and(|e| e.iter().any(|e| d.dot(*e).abs() < 1e-9));
                    if !near_edge {
                        assert_eq!(m, pl.blocks_direction(p, d), "{p:?} patch ({i}, {j})");
                        checked += 1;
                    }
                }
            }
            assert!(checked > 1000);
        }
    }

    /// Hard cases of the per-lobe occlusion: finite, in [0, F/H] (the whole lobe), and ordered.
    #[test]
    fn hard_cases() {
        let lut = IsgLut::generate_default();
        let o = IsgOptions::default();
        let (p, n) = (DVec3::ZERO, DVec3::Y);
        let bound =
            |lambda: f64| 2.0 * PI * -(-2.0 * lambda).exp_m1() / lambda / engine_math::isg::isg_normalization(lambda);
        let check = |v: f64, lambda: f64, what: &str| {
            assert!(v.is_finite() && v >= 0.0 && v <= bound(lambda) * (1.0 + 1e-9), "{what}: {v} (λ {lambda})");
            v
        };
        for lambda in [1e-4, 1e-2, 1.0, 100.0, 1e4, 1e5] {
            // Receiver inside a sphere whose centre is in front: a tangent sphere covering the zenith.
            let (horizon, inside) =
                occlusion(p, n, n, lambda, &o, &[Sphere::new(DVec3::new(0.0, 0.3, 0.0), 1.0)], &lut);
            check(inside, lambda, "inside, centre in front");
            assert!(inside > horizon, "inside a sphere in front: some occlusion (λ {lambda})");
            // Receiver inside a sphere whose centre is behind the tangent plane: eliminated.
            let (h, behind) = occlusion(p, n, n, lambda, &o, &[Sphere::new(DVec3::new(0.0, -0.3, 0.0), 1.0)], &lut);
            assert_eq!(behind, h, "centre behind T_p: eliminated (only the tangent plane occludes)");
            // A blocker covering the whole cone: the whole grid is occluded (Ŝ over the grid ≤ 1).
            let cover = occlusion(p, n, n, lambda, &o, &[Sphere::new(DVec3::new(0.0, 1.0, 0.0), 0.999)], &lut).1;
            check(cover, lambda, "covering");
            // Straddling the tangent plane, off to the side; lobe axis below the horizon.
            let straddle = Sphere::new(DVec3::new(1.0, 0.1, 0.0), 0.5);
            check(
                occlusion(p, n, DVec3::new(1.0, -0.2, 0.0).normalize(), lambda, &o, &[straddle], &lut).1,
                lambda,
                "below",
            );
            // Hundreds of overlapping spheres: no more than the whole grid.
            let many: Vec<Sphere> = (0..300)
                .map(|i| {
                    let t = i as f64 * 0.37;
                    Sphere::new(DVec3::new(t.cos() * 0.5, 0.6 + 0.001 * i as f64, t.sin() * 0.5), 0.3)
                })
                .collect();
            let all = check(occlusion(p, n, n, lambda, &o, &many, &lut).1, lambda, "many");
            let one = occlusion(p, n, n, lambda, &o, &many[..1], &lut).1;
            assert!(all >= one, "more blockers occlude no less");
        }
        // Zero-radius and coincident spheres block nothing / the same as one.
        let s = Sphere::new(DVec3::new(0.0, 2.0, 0.0), 0.5);
        let (h, a) = occlusion(p, n, n, 10.0, &o, &[Sphere::new(DVec3::new(0.0, 2.0, 0.0), 0.0)], &lut);
        assert_eq!(a, h, "a zero-radius sphere blocks nothing");
        let once = occlusion(p, n, n, 10.0, &o, &[s], &lut);
        assert_eq!(occlusion(p, n, n, 10.0, &o, &[s, s, s], &lut), once);
    }
}
