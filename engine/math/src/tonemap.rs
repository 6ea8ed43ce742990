//! Linear radiance to a display value: exposure, the ACES filmic fit (Narkowicz 2015,
//! `x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14)` clamped to [0, 1]) and the sRGB encoding. f64 twin of
//! `shaders-glsl/common/tonemap.glsl` (the tonemap pass).
//!
//! The fit reaches 1 at x ≈ 7.25 and stays there, but in f32 its x² overflows from x ≈ 1.8·10¹⁹ and inf / inf
//! is NaN, which the shader's clamp turned into black: a light of radiance 10³⁸ rendered black. Exposed radiance
//! above [`TONEMAP_WHITE`] (+∞ included) is therefore white before the fit; NaN is black.

/// Exposed radiance at and above which the display value is white (the fit is 1 from ≈ 7.25 on).
pub const TONEMAP_WHITE: f64 = 16.0;

/// The ACES filmic fit of one channel, in [0, 1].
pub fn aces(x: f64) -> f64 {
    ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
}

/// The sRGB transfer function (IEC 61966-2-1) of a linear value in [0, 1].
pub fn srgb_encode(c: f64) -> f64 {
    if c > 0.0031308 {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    } else {
        12.92 * c
    }
}

/// `radiance` × `exposure` as a display value in [0, 1] per channel: NaN → 0, anything at or above
/// [`TONEMAP_WHITE`] (+∞ too) → 1, never black for a bright input.
pub fn tonemap(radiance: [f64; 3], exposure: f64) -> [f64; 3] {
    radiance.map(|r| {
        let c = r * exposure;
        let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, TONEMAP_WHITE) };
        srgb_encode(aces(c))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bright_is_white_and_nan_black() {
        // White within rounding: 1.055 · 1 − 0.055 is 1 − 2⁻⁵³ or 1 depending on how the compiler fuses it.
        for x in [7.3, 16.0, 1e19, 1e36, f64::MAX, f64::INFINITY] {
            assert!(tonemap([x; 3], 1.0).iter().all(|v| (v - 1.0).abs() < 1e-12), "{x}");
        }
        assert_eq!(tonemap([f64::NAN, -1.0, f64::NEG_INFINITY], 1.0), [0.0; 3]);
        assert_eq!(tonemap([0.0; 3], 1.0), [0.0; 3]);
        // Monotonic: brighter is never darker.
        let mut last = 0.0;
        for k in 0..2000 {
            let v = tonemap([1e-6 * 1.02f64.powi(k); 3], 1.0)[0];
            assert!(v >= last, "{k}: {v} < {last}");
            last = v;
        }
    }
}
