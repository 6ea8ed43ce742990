//! The shading frame of a two-sided surface point: which side the viewer sees, and a shading normal
//! that faces the viewer. f64 twin of `shaders-glsl/common/shading.glsl` (`shading_normals`), which
//! the G-buffer pass and both per-vertex targets apply where the `ShadePoint` is built, so every
//! technique and the reference shade with the same normal.
//!
//! # Why
//! An interpolated (smooth) vertex normal `n_s` differs from the triangle's geometric normal `n_g`.
//! Near silhouettes the viewer can see the geometric front (`n_g·v > 0`) while `n_s·v < 0`. Flipping
//! `n_s` towards the viewer there (what the G-buffer did) turns it *into* the mesh: the reference
//! then samples the hemisphere inside a closed mesh and returns exactly 0 (measured: all 9 such
//! pixels of the diffuse bunny against Mitsuba 3, issue 15 item 5).
//!
//! # What (production practice)
//! 1. The side is the geometric normal's: `n_g` is turned towards the viewer, and `n_s` is turned to
//!    `n_g`'s side (a two-sided mesh seen from behind shows its back with both normals flipped).
//!    Rays leave from that side: the reference offsets its ray origins along the returned `n_g`, as
//!    pbrt-v4 (`OffsetRayOrigin`) and Mitsuba 3 (`spawn_ray`) offset along the geometric normal
//!    (they to each ray's side; here, reflection only, always the viewer's, so a direction below the
//!    triangle's plane meets the surface itself rather than leaking through it).
//! 2. Local shading normal adaptation (Keller et al. 2017, "The Iray Light Transport Simulation and
//!    Rendering System", arXiv:1705.01263, §A.3; Cycles' `ensure_valid_reflection` is the same idea):
//!    if the mirror direction of `v` about `n_s` does not leave the geometric surface by at least
//!    `τ = min(0.9 n_g·v, 0.01)`, or `n_s` faces away from the viewer, the mirror direction `r` is
//!    lifted along `n_g` until `n_g·r = τ`, and the new shading normal is the half vector of `v` and
//!    the lifted `r̂` (the normal that mirrors `v` into `r̂`). When `n_s·v ≤ 0` there is no mirror
//!    direction; `r = −v` is used (the limit at `n_s·v = 0`, so the map is continuous there), which
//!    bends `n_s` to the half vector of `v` and the horizon direction opposite it — close to `n_g`.
//!
//! The adapted normal then satisfies `n·v > 0` and `n·n_g > 0` whenever `n_g·v > 0` (`v + r̂` is a sum
//! of two unit vectors above the geometric plane), and it is `n_s` itself wherever `n_s` was valid,
//! so away from silhouettes nothing changes. `τ ≤ 0.9 n_g·v` keeps the lifted reflection no steeper
//! than needed at grazing views (the bend is the smallest one that makes the reflection valid).
//!
//! With `n_s = n_g` (a per-vertex target has no face: the vertex normal is both) the map is the
//! identity apart from the side choice.

use crate::brdf::{dot, madd, scale};
pub use crate::sg::Vec3;

fn length(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}

/// The margin by which the adapted mirror direction leaves the geometric surface, `τ(n_g·v)`.
pub fn reflection_margin(gv: f64) -> f64 {
    (0.9 * gv).min(0.01)
}

/// `n_s` adapted so that it faces the viewer (Keller et al. 2017, §A.3; see the module doc).
/// `n_s`, `n_g`, `v` unit; `n_g` on the viewer's side (`n_g·v ≥ 0`) and `n_s` on `n_g`'s side.
/// Returns `n_g` in the degenerate edge-on case (`n_g·v = 0` with `n_s·v ≤ 0`).
pub fn adapt_shading_normal(n_s: Vec3, n_g: Vec3, v: Vec3) -> Vec3 {
    adapt_shading_normal_detail(n_s, n_g, v).normal
}

/// [`adapt_shading_normal`] with the lengths it divides by, which the twin tests need: an f32
/// evaluation's rounding (a few EPS absolute on unit-scale vectors) is amplified by
/// `1 / (lifted · half)` there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adapted {
    pub normal: Vec3,
    /// `|r + (τ − n_g·r) n_g|` (1 when `n_s` is kept).
    pub lifted: f64,
    /// `|v + r̂|` = `2 n·v` of the adapted normal (1 when `n_s` is kept).
    pub half: f64,
}

/// See [`Adapted`].
pub fn adapt_shading_normal_detail(n_s: Vec3, n_g: Vec3, v: Vec3) -> Adapted {
    let kept = |normal| Adapted { normal, lifted: 1.0, half: 1.0 };
    let gv = dot(n_g, v);
    let tau = reflection_margin(gv);
    let nv = dot(n_s, v);
    let r = if nv > 0.0 { madd(scale(v, -1.0), 2.0 * nv, n_s) } else { scale(v, -1.0) };
    let rg = dot(r, n_g);
    if nv > 0.0 && rg >= tau {
        return kept(n_s);
    }
    let lifted = madd(r, tau - rg, n_g);
    let len = length(lifted);
    if len <= 0.0 {
        return kept(n_g);
    }
    let h = madd(v, 1.0 / len, lifted);
    let hl = length(h);
    if hl > 0.0 {
        Adapted { normal: scale(h, 1.0 / hl), lifted: len, half: hl }
    } else {
        kept(n_g)
    }
}

/// The shading frame of a two-sided point seen along unit `v` (towards the viewer): from the unit
/// interpolated normal `n_s` and the unit geometric normal `n_g`, each of either orientation,
/// returns `(shading normal, geometric normal)`, both on the viewer's side (module doc, steps 1–2).
pub fn shading_normals(n_s: Vec3, n_g: Vec3, v: Vec3) -> (Vec3, Vec3) {
    let g = if dot(n_g, v) < 0.0 { scale(n_g, -1.0) } else { n_g };
    let s = if dot(n_s, g) < 0.0 { scale(n_s, -1.0) } else { n_s };
    (adapt_shading_normal(s, g, v), g)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    fn normalize(a: Vec3) -> Vec3 {
        scale(a, 1.0 / length(a))
    }

    fn reflect_about(v: Vec3, n: Vec3) -> Vec3 {
        madd(scale(v, -1.0), 2.0 * dot(n, v), n)
    }

    /// Random (n_s, n_g, v) in every relation: n_s close to n_g (a smooth mesh), anywhere in n_g's
    /// hemisphere, v grazing or steep.
    fn cases(count: usize) -> Vec<(Vec3, Vec3, Vec3)> {
        let mut rng = Pcg32::new(15, 5);
        (0..count)
            .map(|i| {
                let n_g = rng.unit_vector();
                let v = rng.unit_vector();
                let n_s = if i % 2 == 0 { normalize(madd(n_g, 0.4, rng.unit_vector())) } else { rng.unit_vector() };
                (n_s, n_g, v)
            })
            .collect()
    }

    #[test]
    fn adapted_normal_faces_the_viewer_and_reflects_above_the_surface() {
        for (k, (n_s, n_g, v)) in cases(20000).into_iter().enumerate() {
            let (s, g) = shading_normals(n_s, n_g, v);
            let gv = dot(g, v);
            assert!(gv >= 0.0, "case {k}: the geometric normal faces the viewer");
            assert!((length(s) - 1.0).abs() < 1e-12, "case {k}: unit");
            if gv < 1e-9 {
                continue; // edge-on: no side is seen
            }
            assert!(dot(s, v) > 0.0, "case {k}: n·v = {}", dot(s, v));
            assert!(dot(s, g) > 0.0, "case {k}: n·n_g = {}", dot(s, g));
            // The mirror direction leaves the geometric surface by the margin.
            let r = reflect_about(v, s);
            let tau = reflection_margin(gv);
            let bound = tau / (1.0 + tau * tau).sqrt();
            assert!(dot(r, g) >= bound * (1.0 - 1e-9) - 1e-12, "case {k}: r·n_g = {}", dot(r, g));
        }
    }

    #[test]
    fn valid_normals_are_unchanged() {
        let mut changed = 0;
        for (n_s, n_g, v) in cases(20000) {
            let (s, g) = shading_normals(n_s, n_g, v);
            let s_side = if dot(n_s, g) < 0.0 { scale(n_s, -1.0) } else { n_s };
            let valid = dot(s_side, v) > 0.0 && dot(reflect_about(v, s_side), g) >= reflection_margin(dot(g, v));
            if valid {
                assert_eq!(s, s_side, "a valid shading normal is kept exactly");
            } else {
                changed += 1;
            }
        }
        assert!(changed > 1000, "the cases exercise the adaptation ({changed})");
    }

    /// Continuous across the adaptation boundary (`n_g·r = τ`) and across `n_s·v = 0`: the bend is
    /// the smallest one, not a jump to another normal.
    #[test]
    fn continuous_at_both_boundaries() {
        let n_g = [0.0, 1.0, 0.0];
        let e = 0.3f64; // view elevation
        let v = [0.0, e.sin(), e.cos()];
        let n_at = |beta: f64| [0.0, beta.cos(), -beta.sin()]; // tilted away from the viewer by β
        let f = |beta: f64| adapt_shading_normal(n_at(beta), n_g, v);
        // n_s·v = sin(e − β) crosses 0 at β = e and n_g·r crosses τ before it: scan β finely for jumps.
        let mut prev = f(0.0);
        let steps = 200000;
        for i in 1..=steps {
            let beta = 1.2 * i as f64 / steps as f64;
            let cur = f(beta);
            let d = length(madd(cur, -1.0, prev));
            assert!(d < 1e-3, "jump {d} at β = {beta}");
            prev = cur;
        }
        // β > e: n_s faces away; the adapted normal is the half vector of v and the lifted −v.
        let s = f(0.8);
        let lifted = normalize([0.0, reflection_margin(e.sin()), -e.cos()]);
        let want = normalize(madd(v, 1.0, lifted));
        assert!(length(madd(s, -1.0, want)) < 1e-12, "{s:?} vs {want:?}");
    }

    #[test]
    fn back_side_flips_both() {
        // A plane seen from below: both normals turn to the viewer, and a smooth n_s is kept.
        let n_g = [0.0, 1.0, 0.0];
        let n_s = normalize([0.1, 1.0, 0.0]);
        let v = normalize([0.0, -1.0, 0.5]);
        let (s, g) = shading_normals(n_s, n_g, v);
        assert_eq!(g, [0.0, -1.0, 0.0]);
        assert_eq!(s, scale(n_s, -1.0));
    }

    #[test]
    fn edge_on_is_finite() {
        let n_g = [0.0, 1.0, 0.0];
        let v = [0.0, 0.0, 1.0];
        for n_s in [[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], normalize([0.0, 1.0, -1.0]), [1.0, 0.0, 0.0]] {
            let (s, _) = shading_normals(n_s, n_g, v);
            assert!(s.iter().all(|x| x.is_finite()));
            assert!((length(s) - 1.0).abs() < 1e-12);
        }
    }
}
