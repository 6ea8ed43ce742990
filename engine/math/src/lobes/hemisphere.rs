//! The hemisphere (integration) table (paper Sec. 4.2): the fractions of a lobe above a plane,
//! tabulated over the exponent and the normal-angle coordinate `y` (`hemisphere_coord_y`).

use super::{
    axis_lerp, clamped_cosine_integral, exponent_coord, exponent_samples, hemisphere_coord_y, hemisphere_cos_beta,
    hemisphere_integral, sphere_integral, EXPONENT_DECADES, HEMISPHERE_SAMPLES_PER_DECADE, HEMISPHERE_Y_SAMPLES,
};
use std::f64::consts::PI;

/// Fractions of a lobe above a plane, tabulated over (e, y) (paper Sec. 4.2, extended to the
/// hemisphere around an arbitrary normal, which is what rendering integrates over, Eq. 22–23).
///
/// Dimensions: `exponent_samples(128)` (769) × `HEMISPHERE_Y_SAMPLES` (129) entries of
/// `[f_h, f_b]`, row-major in e, y_j = −1 + 2j/128 ([`hemisphere_coord_y`]):
/// - `f_h = hemisphere_integral(e, cos β) / (2π/(e+1))` ∈ [0, 1];
/// - `f_b = clamped_cosine_integral(e, −|cos β|) / (2π/(e+2))`: the part of the lobe below the
///   plane, weighted by |n·v|. Then `clamped_cosine_integral = (max(cos β, 0) + f_b)·2π/(e+2)`.
///   (Tabulating the whole clamped-cosine fraction would not work: away from β = π/2 it varies
///   like cos β, which the y axis compresses into its last samples for large e; the below-plane
///   part varies only in the 1/√e-wide band the y axis is made for.)
///
/// 793 KiB in f32.
#[derive(Clone, Debug, PartialEq)]
pub struct HemisphereTable {
    pub per_decade: usize,
    pub y_samples: usize,
    pub data: Vec<[f32; 2]>,
}

/// Deterministic generator of the hemisphere table (~1e5 1D quadratures: well under a second in release).
pub fn hemisphere_table() -> HemisphereTable {
    hemisphere_table_sized(HEMISPHERE_SAMPLES_PER_DECADE, HEMISPHERE_Y_SAMPLES)
}

/// [`hemisphere_table`] with other dimensions (tests use small ones).
pub fn hemisphere_table_sized(per_decade: usize, y_samples: usize) -> HemisphereTable {
    let es = exponent_samples(per_decade);
    let mut data = Vec::with_capacity(es.len() * y_samples);
    for &e in &es {
        for iy in 0..y_samples {
            let y = -1.0 + 2.0 * iy as f64 / (y_samples - 1) as f64;
            let c = hemisphere_cos_beta(e, y);
            let fh = hemisphere_integral(e, c) / sphere_integral(e);
            let fb = clamped_cosine_integral(e, -c.abs()) / (2.0 * PI / (e + 2.0));
            data.push([fh as f32, fb as f32]);
        }
    }
    HemisphereTable { per_decade, y_samples, data }
}

impl HemisphereTable {
    fn fractions(&self, exponent: f64, cos_beta: f64) -> [f64; 2] {
        let n_e = EXPONENT_DECADES * self.per_decade + 1;
        let (e0, e1, fe) = axis_lerp(exponent_coord(exponent, self.per_decade), n_e);
        let yc = (hemisphere_coord_y(exponent, cos_beta) + 1.0) * 0.5 * (self.y_samples - 1) as f64;
        let (y0, y1, fy) = axis_lerp(yc, self.y_samples);
        let at = |ie: usize, iy: usize, k: usize| self.data[ie * self.y_samples + iy][k] as f64;
        let mut out = [0.0; 2];
        for (k, o) in out.iter_mut().enumerate() {
            let a = at(e0, y0, k) * (1.0 - fy) + at(e0, y1, k) * fy;
            let b = at(e1, y0, k) * (1.0 - fy) + at(e1, y1, k) * fy;
            *o = a * (1.0 - fe) + b * fe;
        }
        out
    }

    /// Table approximation of [`hemisphere_integral`] (bilinear, then times 2π/(e+1)).
    pub fn hemisphere_integral(&self, exponent: f64, cos_beta: f64) -> f64 {
        self.fractions(exponent, cos_beta)[0] * sphere_integral(exponent)
    }

    /// Table approximation of [`clamped_cosine_integral`].
    pub fn clamped_cosine_integral(&self, exponent: f64, cos_beta: f64) -> f64 {
        (cos_beta.clamp(0.0, 1.0) + self.fractions(exponent, cos_beta)[1]) * 2.0 * PI / (exponent + 2.0)
    }

    pub fn size_bytes(&self) -> usize {
        self.data.len() * std::mem::size_of::<[f32; 2]>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lobes::measure_hemisphere_table;

    #[test]
    fn hemisphere_table_interpolates() {
        let t = hemisphere_table_sized(8, 33);
        assert_eq!(t.data.len(), 49 * 33);
        // At nodes the lookup returns the stored f32 fractions: exact to f32 rounding (6e-8).
        let es = exponent_samples(8);
        for &e in &[es[3], es[20], es[48]] {
            for iy in [0, 7, 16, 30] {
                let c = hemisphere_cos_beta(e, -1.0 + 2.0 * iy as f64 / 32.0);
                assert!((t.hemisphere_integral(e, c) - hemisphere_integral(e, c)).abs() < 2e-7 * sphere_integral(e));
                let k = clamped_cosine_integral(e, c);
                assert!((t.clamped_cosine_integral(e, c) - k).abs() < 2e-7 * 2.0 * PI / (e + 2.0));
            }
        }
        // Off the nodes, even this coarse table is within 1 % of the lobe's integral: the y axis keeps
        // the 1/√e-wide transition at the same place for every e.
        let worst = measure_hemisphere_table(&t, 300, 5);
        assert!(worst[0] < 1e-2 && worst[1] < 1e-2, "{worst:?}");
    }
}
