//! Cosine lobes `c(v) = s·max(a·v, 0)^e` (Meunier et al. 2009, Eq. 4): integrals, the single-lobe
//! product approximation and its tables, the spherical-cap exponent, and the lobe forms of BRDFs
//! (Phong, modified Phong, Lafortune) and of spherical lights. `shaders-glsl/common/lobes.glsl` is
//! the GLSL twin of the GPU-relevant parts.
//!
//! # The coordinate trick everything rests on
//! For unit axes on one great circle, take `v = (cos y sin x, sin y, cos y cos x)` in a frame where
//! the circle is `y = 0` and an axis at longitude `x_i` is `(sin x_i, 0, cos x_i)`. Then
//! `a_i·v = cos y · cos(x − x_i)` and `dω = cos y dx dy`, so any product of lobes whose axes share a
//! great circle (two lobes always do; a lobe and a normal too) separates:
//!
//! `∫ Π max(a_i·v, 0)^{e_i} dω = W(Σ e_i + 1) · ∫ Π max(cos(x − x_i), 0)^{e_i} dx`,
//!
//! with the Wallis integral `W(n) = ∫_{−π/2}^{π/2} cos^n y dy = √π Γ((n+1)/2) / Γ(n/2 + 1)`.
//! Hemisphere integrals, lobe × clamped cosine, the paper's L2 product fit (Eq. 19) and its error
//! are therefore 1D integrals. They are computed in log space relative to the peak (no `pow(x, e)`
//! with x near 1, no underflow of sharp far-apart products) by tanh–sinh quadrature, which also
//! absorbs the `(π/2 − x)^e` endpoint singularities of small exponents. This is what makes the
//! tables take seconds instead of the paper's four hours.
//!
//! # Conventions
//! - `e = 0` means the limit `e → 0⁺`: the hemisphere indicator `[a·v > 0]`, so `∫ = 2π/(e+1)` holds
//!   for all `e ≥ 0`. The paper's `c_unit = 1` (Eq. 40, "max(n·v, 0)^0 = 1" over the whole sphere) is
//!   not a lobe in this convention: it is the identity of the product and the caller keeps it apart.
//! - Exponents are tabulated on `[0, 1e5]` (the paper's range). Lookups clamp to it.
//!
//! # Files
//! - `integrals`: the lobe, its evaluation and exact integrals (hemisphere, clamped cosine);
//! - `hemisphere`: the hemisphere (integration) table;
//! - `product`: the single-lobe product fit and the product table;
//! - `cap`: the spherical-cap exponent and the cap table;
//! - `forms`: Phong, modified Phong, Lafortune and spherical-light lobes;
//! - `measure`: error measurements of the fits and tables;
//! - here: the table constants, vector helpers and the table coordinates shared by all tables.
//!
//! Every public item is re-exported here (`engine_math::lobes::X`).

mod cap;
mod forms;
mod hemisphere;
mod integrals;
mod measure;
mod product;
#[cfg(test)]
mod testing;

pub use cap::*;
pub use forms::*;
pub use hemisphere::*;
pub use integrals::*;
pub use measure::*;
pub use product::*;

use std::f64::consts::PI;

/// Largest exponent the tables cover (paper Sec. 4.1: "e1 and e2 are sampled in [0, 100000]").
pub const MAX_EXPONENT: f64 = 1e5;
/// Number of sample intervals of the exponent axis: [0,1], [1,10], ..., [1e4,1e5] (paper Sec. 4.1).
pub const EXPONENT_DECADES: usize = 6;
/// Product table: samples per decade of each exponent (paper Sec. 4.1).
pub const PRODUCT_SAMPLES_PER_DECADE: usize = 16;
/// Product table: samples of α over [0, π], endpoints included (the paper does not give its count;
/// 49 keeps the product table at 3.6 MiB and the α interpolation error is measured).
pub const PRODUCT_ALPHA_SAMPLES: usize = 49;
/// Hemisphere (integration) table: samples per decade of e (paper Sec. 4.2).
pub const HEMISPHERE_SAMPLES_PER_DECADE: usize = 128;
/// Hemisphere table: samples of the normal-angle coordinate y ∈ [−1, 1] (see [`hemisphere_coord_y`]).
pub const HEMISPHERE_Y_SAMPLES: usize = 129;
/// Spherical-cap exponent table: entries over α_cap ∈ [0, π/2] (paper Sec. 5.2: 1000 values).
pub const CAP_SAMPLES: usize = 1000;

// ---------------------------------------------------------------------------------------------
// Small vector helpers (f64, no dependency on glam's f32 types).

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
fn length(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}
fn scale3(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn add3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn normalize(a: [f64; 3]) -> [f64; 3] {
    scale3(a, 1.0 / length(a))
}

/// Angle between two unit vectors via atan2 (accurate near 0 and π, unlike acos of the dot).
pub fn angle_between(a: [f64; 3], b: [f64; 3]) -> f64 {
    length(cross(a, b)).atan2(dot(a, b))
}

/// Any unit vector orthogonal to the unit vector `a`.
fn any_orthogonal(a: [f64; 3]) -> [f64; 3] {
    let helper = if a[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
    normalize(cross(a, helper))
}

// ---------------------------------------------------------------------------------------------
// Table coordinates shared by the CPU lookups and lobes.glsl.

/// The exponent samples of a table with `per_decade` samples per decade: `per_decade` linearly spaced
/// samples in each of [0,1), [1,10), ..., [1e4,1e5), then 1e5 itself; `6·per_decade + 1` in all.
/// e = 0 is the first sample; the lowest decade is sampled as densely (linearly) as the others.
pub fn exponent_samples(per_decade: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(EXPONENT_DECADES * per_decade + 1);
    for d in 0..EXPONENT_DECADES {
        let (lo, hi) = if d == 0 { (0.0, 1.0) } else { (10f64.powi(d as i32 - 1), 10f64.powi(d as i32)) };
        for j in 0..per_decade {
            out.push(lo + (hi - lo) * j as f64 / per_decade as f64);
        }
    }
    out.push(MAX_EXPONENT);
    out
}

/// Fractional index of exponent `e` in [`exponent_samples`] (clamped to the table).
pub fn exponent_coord(e: f64, per_decade: usize) -> f64 {
    let pd = per_decade as f64;
    let last = (EXPONENT_DECADES * per_decade) as f64;
    if e.is_nan() || e <= 0.0 {
        return 0.0;
    }
    if e < 1.0 {
        return e * pd;
    }
    if e >= MAX_EXPONENT {
        return last;
    }
    // Decade [10^d, 10^(d+1)), d = 0..4; guard log10 rounding at exact powers of ten.
    let mut d = e.log10().floor().clamp(0.0, 4.0);
    if e < 10f64.powf(d) {
        d -= 1.0;
    } else if d < 4.0 && e >= 10f64.powf(d + 1.0) {
        d += 1.0;
    }
    let lo = 10f64.powf(d);
    (pd * (d + 1.0) + pd * (e - lo) / (9.0 * lo)).min(last)
}

/// Hemisphere table column: `y = (2/π) atan2(√(e+1) cos β, sin β) ∈ [−1, 1]`.
/// The fraction of a lobe above a plane is a sigmoid in `√e · cot β` (width 1/√e around β = π/2);
/// this coordinate keeps that sigmoid at the same place in the table for every e.
pub fn hemisphere_coord_y(exponent: f64, cos_beta: f64) -> f64 {
    let c = cos_beta.clamp(-1.0, 1.0);
    let s = ((1.0 - c) * (1.0 + c)).sqrt();
    (2.0 / PI) * ((exponent + 1.0).sqrt() * c).atan2(s)
}

/// Inverse of [`hemisphere_coord_y`]: cos β for a given e and y.
pub fn hemisphere_cos_beta(exponent: f64, y: f64) -> f64 {
    let psi = 0.5 * PI * y.clamp(-1.0, 1.0);
    let (sp, cp) = psi.sin_cos();
    sp / (sp * sp + (exponent + 1.0) * cp * cp).sqrt()
}

/// Linear interpolation weights on a table axis of `n` samples: (i0, i1, frac) for a fractional
/// index clamped to [0, n−1].
fn axis_lerp(coord: f64, n: usize) -> (usize, usize, f64) {
    let c = coord.clamp(0.0, (n - 1) as f64);
    let i0 = (c.floor() as usize).min(n - 1);
    let i1 = (i0 + 1).min(n - 1);
    (i0, i1, c - i0 as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exponent_axis_round_trip() {
        for pd in [16, 128] {
            let es = exponent_samples(pd);
            assert_eq!(es.len(), 6 * pd + 1);
            assert_eq!(es[0], 0.0);
            assert_eq!(*es.last().unwrap(), 1e5);
            for (i, &e) in es.iter().enumerate() {
                assert!((exponent_coord(e, pd) - i as f64).abs() < 1e-9, "pd {pd} i {i} e {e}");
            }
            assert!(es.windows(2).all(|w| w[1] > w[0]));
        }
        assert_eq!(exponent_coord(2e5, 16), 96.0);
        assert_eq!(exponent_coord(-1.0, 16), 0.0);
        for &e in &[0.0, 0.3, 4.0, 1e3, 1e5] {
            for &c in &[-1.0, -0.3, 0.0, 0.01, 1.0] {
                let y = hemisphere_coord_y(e, c);
                assert!((hemisphere_cos_beta(e, y) - c).abs() < 1e-12);
            }
        }
    }
}
