//! Error and flicker over a clip: N consecutive frames of a technique against references of the same frames
//! (`compare --clip N`, docs/measuring.md "Error in motion").
//!
//! For frames k = 0 … N−1 with technique images T_k (exact) and references R_k (Monte Carlo, each kept as two
//! half-sample means, [`HalfMeans`]), over the pixels every frame covers:
//! - **error per frame**: the relative RMSE of T_k against R_k net of R_k's noise, as `compare` reports a still;
//!   then its mean and maximum over the clip;
//! - **change**: the RMS of the frame-to-frame change ΔT_k = T_{k+1} − T_k relative to the RMS of the references
//!   (`100 √(Σ_k Σ |ΔT_k|²) / √(Σ_k Σ |R_{k+1}|²)`), and the same of the references, ΔR_k, net of their noise;
//! - **flicker**: the RMS of ΔT_k − ΔR_k, the change the technique makes that the truth does not, relative and net
//!   of noise in the same way. A technique that is wrong by the same amount in every frame has no flicker; one
//!   that pops where the truth moves smoothly has.
//!
//! The noise taken out of a change is that of the combination R_{k+1} − R_k (and of T_{k+1} − T_k − R_{k+1} + R_k),
//! estimated from the references' halves by [`combination_noise_sq`]: every reference is converged with the same
//! seed, so consecutive references share random numbers and their difference is much less noisy than each;
//! the halves see that correlation, as they do for the sphere-proxy against the triangle reference.
//!
//! A reference-free check beside it: how the change grows with the time step. Over the same frames, the RMS of
//! T_{k+2} − T_k against that of T_{k+1} − T_k: smooth motion doubles it (a change proportional to the step);
//! pops and noise give about √2 (a pop lands in two two-frame steps and in one one-frame step).

use crate::converge::{combination_noise_sq, HalfMeans};
use crate::metrics::sqrt_ratio;

/// One frame of a clip: the technique's linear RGB (exact) and the reference's halves.
pub struct ClipFrame<'a> {
    pub technique: &'a [[f32; 3]],
    pub reference: &'a HalfMeans,
    pub covered: &'a [bool],
}

/// What [`clip_stats`] measures over a clip (percentages; see the module's text).
#[derive(Clone, Debug, PartialEq)]
pub struct ClipStats {
    /// Relative RMSE % of each frame against its reference, net of the reference's noise.
    pub error_per_frame: Vec<f64>,
    pub error_mean: f64,
    pub error_max: f64,
    /// RMS of the technique's frame-to-frame change, % of the references' RMS.
    pub change: f64,
    /// The same of the references, net of their noise.
    pub reference_change: f64,
    /// RMS of (technique's change − reference's change), net of noise, % of the references' RMS.
    pub flicker: f64,
    /// RMS of two-frame changes over RMS of one-frame changes, of the technique (≈ 2 smooth, ≈ √2 noisy pops).
    pub step_scaling: f64,
    /// The same of the references (net of noise).
    pub reference_step_scaling: f64,
    /// Pixels covered in every frame.
    pub pixels: usize,
}

fn sum_sq(a: &[[f32; 3]], b: Option<&[[f32; 3]]>, mask: &[bool]) -> f64 {
    let mut s = 0.0;
    for (i, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
        for k in 0..3 {
            let d = a[i][k] as f64 - b.map_or(0.0, |b| b[i][k] as f64);
            s += d * d;
        }
    }
    s
}

/// Σ |Σ_j c_j X_j|² over the mask, for exact images X_j.
fn combination_sq(terms: &[(f64, &[[f32; 3]])], mask: &[bool]) -> f64 {
    let mut s = 0.0;
    for (i, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
        for k in 0..3 {
            let d: f64 = terms.iter().map(|(c, x)| c * x[i][k] as f64).sum();
            s += d * d;
        }
    }
    s
}

/// The clip's statistics; `None` for fewer than 3 frames (a two-step change needs three), frames of unequal
/// sizes, or no pixel covered in every frame.
pub fn clip_stats(frames: &[ClipFrame]) -> Option<ClipStats> {
    let n = frames.len();
    let len = frames.first()?.technique.len();
    if n < 3 || frames.iter().any(|f| f.technique.len() != len || f.covered.len() != len || f.reference.a.len() != len)
    {
        return None;
    }
    let mask: Vec<bool> = (0..len).map(|i| frames.iter().all(|f| f.covered[i])).collect();
    let pixels = mask.iter().filter(|m| **m).count();
    if pixels == 0 {
        return None;
    }
    let means: Vec<Vec<[f32; 3]>> = frames.iter().map(|f| f.reference.mean()).collect();
    let mut error_per_frame = Vec::with_capacity(n);
    for (f, r) in frames.iter().zip(&means) {
        let err = sum_sq(f.technique, Some(r), &mask);
        let noise = combination_noise_sq(&[(-1.0, f.reference)], &mask);
        error_per_frame.push(100.0 * sqrt_ratio((err - noise).max(0.0), sum_sq(r, None, &mask)));
    }
    // Steps of one and two frames: Σ|ΔT|², Σ|ΔR|² − noise, Σ|ΔT − ΔR|² − noise, and the norm Σ|R|² over the
    // frames each step ends on.
    let steps = |step: usize| {
        let (mut dt, mut dr, mut flick, mut norm) = (0.0, 0.0, 0.0, 0.0);
        for k in 0..n - step {
            let (a, b) = (&frames[k], &frames[k + step]);
            let exact = [(1.0, b.technique), (-1.0, a.technique)];
            dt += combination_sq(&exact, &mask);
            let ref_terms = [(1.0, b.reference), (-1.0, a.reference)];
            let ref_noise = combination_noise_sq(&ref_terms, &mask);
            dr += combination_sq(&[(1.0, means[k + step].as_slice()), (-1.0, means[k].as_slice())], &mask) - ref_noise;
            let both = [
                (1.0, b.technique),
                (-1.0, a.technique),
                (-1.0, means[k + step].as_slice()),
                (1.0, means[k].as_slice()),
            ];
            // The exact terms add no noise: the noise of ΔT − ΔR is that of ΔR.
            flick += combination_sq(&both, &mask) - ref_noise;
            norm += sum_sq(&means[k + step], None, &mask);
        }
        (dt, dr.max(0.0), flick.max(0.0), norm)
    };
    let (dt1, dr1, flick1, norm1) = steps(1);
    let (dt2, dr2, _, _) = steps(2);
    // Mean square per step, so that the n−1 one-frame and n−2 two-frame steps compare.
    let per = |x: f64, count: usize| x / count as f64;
    let scaling = |two: f64, one: f64| sqrt_ratio(per(two, n - 2), per(one, n - 1));
    Some(ClipStats {
        error_mean: error_per_frame.iter().sum::<f64>() / n as f64,
        error_max: error_per_frame.iter().copied().fold(0.0, f64::max),
        error_per_frame,
        change: 100.0 * sqrt_ratio(dt1, norm1),
        reference_change: 100.0 * sqrt_ratio(dr1, norm1),
        flicker: 100.0 * sqrt_ratio(flick1, norm1),
        step_scaling: scaling(dt2, dt1),
        reference_step_scaling: scaling(dr2, dr1),
        pixels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reference of `image` with noise ±`amp` split evenly between its halves (pixel-alternating sign, so
    /// that each half is off by `amp` and the mean is exact).
    fn noisy(image: &[[f32; 3]], amp: f32, flip: bool) -> HalfMeans {
        let s = if flip { -amp } else { amp };
        let a = image.iter().enumerate().map(|(i, p)| p.map(|v| v + if i % 2 == 0 { s } else { -s })).collect();
        let b = image.iter().enumerate().map(|(i, p)| p.map(|v| v - if i % 2 == 0 { s } else { -s })).collect();
        HalfMeans { a, b, samples_a: 8, samples_b: 8 }
    }

    fn frames_of(tech: &[Vec<[f32; 3]>], refs: &[HalfMeans], mask: &[bool]) -> Option<ClipStats> {
        let frames: Vec<ClipFrame> =
            tech.iter().zip(refs).map(|(t, r)| ClipFrame { technique: t, reference: r, covered: mask }).collect();
        clip_stats(&frames)
    }

    /// A ramp moving linearly over 6 frames: image k is base + k·slope.
    fn ramp(k: usize, offset: f32) -> Vec<[f32; 3]> {
        (0..16).map(|i| [1.0 + 0.01 * k as f32 * (i as f32 + 1.0) + offset, 1.0, 1.0]).collect()
    }

    #[test]
    fn a_constant_bias_has_error_but_no_flicker_and_smooth_motion_doubles_with_the_step() {
        let mask = vec![true; 16];
        let refs: Vec<HalfMeans> = (0..6).map(|k| noisy(&ramp(k, 0.0), 0.0, false)).collect();
        let tech: Vec<Vec<[f32; 3]>> = (0..6).map(|k| ramp(k, 0.1)).collect();
        let s = frames_of(&tech, &refs, &mask).unwrap();
        assert!(s.error_mean > 5.0 && (s.error_max - s.error_mean).abs() < 0.5, "{s:?}");
        assert!(s.flicker < 1e-3, "{s:?}");
        assert!((s.change - s.reference_change).abs() < 1e-3, "{s:?}");
        assert!((s.step_scaling - 2.0).abs() < 1e-3 && (s.reference_step_scaling - 2.0).abs() < 1e-3, "{s:?}");
    }

    #[test]
    fn a_pop_is_flicker_and_reference_noise_is_taken_out() {
        let mask = vec![true; 16];
        // Noisy references of a still image: their changes are noise alone, and come out ≈ 0 net of it.
        let still = ramp(0, 0.0);
        let refs: Vec<HalfMeans> = (0..6).map(|k| noisy(&still, 0.005, k % 2 == 1)).collect();
        let mut tech: Vec<Vec<[f32; 3]>> = (0..6).map(|_| still.clone()).collect();
        let s = frames_of(&tech, &refs, &mask).unwrap();
        assert!(s.flicker < 1e-3 && s.reference_change < 1e-3 && s.change == 0.0, "{s:?}");
        // The technique pops by 0.2 on frame 3 and stays: a change the truth does not make.
        for t in tech.iter_mut().skip(3) {
            for p in t.iter_mut() {
                p[0] += 0.2;
            }
        }
        let s = frames_of(&tech, &refs, &mask).unwrap();
        assert!(s.flicker > 5.0 && s.change > 5.0, "{s:?}");
        // One pop over 6 frames: √(2·5/4) = 1.58 (√2 in a long clip), where smooth motion gives 2.
        assert!((s.step_scaling - 2.5f64.sqrt()).abs() < 1e-6, "{s:?}");
        assert!(s.error_max > 1.5 * s.error_mean, "the pop's frames carry the error: {s:?}");
    }

    #[test]
    fn too_short_or_uncovered_clips_are_refused() {
        let mask = vec![true; 16];
        let refs: Vec<HalfMeans> = (0..2).map(|k| noisy(&ramp(k, 0.0), 0.0, false)).collect();
        let tech: Vec<Vec<[f32; 3]>> = (0..2).map(|k| ramp(k, 0.0)).collect();
        assert!(frames_of(&tech, &refs, &mask).is_none());
        let refs: Vec<HalfMeans> = (0..4).map(|k| noisy(&ramp(k, 0.0), 0.0, false)).collect();
        let tech: Vec<Vec<[f32; 3]>> = (0..4).map(|k| ramp(k, 0.0)).collect();
        assert!(frames_of(&tech, &refs, &[false; 16]).is_none());
    }
}
