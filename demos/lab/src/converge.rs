//! Convergence of the Monte Carlo reference (above the renderer: it drives whole frames): render
//! frames with the renderer's `reference` technique until its own standard error is small enough,
//! absolutely ([`converge`]) or against the error being measured ([`converge_against`]).

use engine::gpu::{Gpu, GpuError, Result};
use engine::passes::shade::reference::{Reference, ReferenceStats, MAX_SAMPLES};
use engine::renderer::Renderer;

/// The renderer's technique as the reference, if it is one.
pub fn reference_mut(renderer: &mut Renderer) -> Option<&mut Reference> {
    renderer.technique_mut().as_any_mut()?.downcast_mut::<Reference>()
}

/// How a [`converge`] run ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConvergeReport {
    pub samples: u32,
    pub frames: u32,
    /// [`ReferenceStats::relative_stderr`] at the end.
    pub relative_stderr: f64,
    /// The stopping rule held (false: `max_samples` was reached first).
    pub converged: bool,
}

/// Render frames with the renderer's reference technique until `done(stats)` holds or
/// `max_samples` samples per item are accumulated; returns the final statistics as well.
pub fn converge_until(
    gpu: &Gpu,
    renderer: &mut Renderer,
    max_samples: u32,
    done: impl FnMut(&ReferenceStats) -> bool,
) -> Result<(ConvergeReport, ReferenceStats)> {
    run(gpu, renderer, max_samples, done, false).map(|(report, stats, _)| (report, stats))
}

/// [`converge_until`] that also keeps the two independent halves of the samples ([`HalfMeans`]: the
/// even frames and the odd frames), from which the noise of any difference of images is estimated
/// ([`combination_noise_sq`]). When the rule holds after an odd number of frames, one more frame is
/// rendered (if `max_samples` allows) so that the halves hold equally many samples.
pub fn converge_until_split(
    gpu: &Gpu,
    renderer: &mut Renderer,
    max_samples: u32,
    done: impl FnMut(&ReferenceStats) -> bool,
) -> Result<(ConvergeReport, ReferenceStats, HalfMeans)> {
    run(gpu, renderer, max_samples, done, true)
}

fn run(
    gpu: &Gpu,
    renderer: &mut Renderer,
    max_samples: u32,
    mut done: impl FnMut(&ReferenceStats) -> bool,
    even_frames: bool,
) -> Result<(ConvergeReport, ReferenceStats, HalfMeans)> {
    let per_vertex = renderer.settings.per_vertex;
    let mut frames: u32 = 0;
    let mut split = HalfSplitter::default();
    let mut rule_held = false;
    loop {
        renderer.render(gpu)?;
        frames += 1;
        let r = reference_mut(renderer)
            .ok_or_else(|| GpuError::Other("converge: the technique is not 'reference'".into()))?;
        let stats = r.stats(gpu, per_vertex)?;
        split.add_frame(&stats.mean, stats.samples);
        rule_held = rule_held || (stats.samples >= 2 && done(&stats));
        let converged = rule_held && (!even_frames || frames.is_multiple_of(2));
        let next = stats.samples as u64 + r.options().samples_per_frame as u64;
        if converged || next > max_samples.min(MAX_SAMPLES) as u64 {
            let report = ConvergeReport {
                samples: stats.samples,
                frames,
                relative_stderr: stats.relative_stderr(),
                converged: rule_held,
            };
            let halves = split.finish(&stats.mean, stats.samples);
            return Ok((report, stats, halves));
        }
    }
}

/// Two independent estimates of an image, each the mean of half of its Monte Carlo samples (half `a`: the
/// samples of the even frames of the convergence, `b`: those of the odd frames), per item RGB.
///
/// The reference's samples are a deterministic function of (item, sample index, seed), so two references
/// converged with the same seed and samples per frame (the sphere-proxy and the triangle reference) use the
/// same random numbers in the same halves: their difference is far less noisy than their independent noises
/// would say, and only the difference itself tells how noisy it is. For a mean `X = (n_a X_a + n_b X_b)/n` of
/// independent samples of variance σ², `E[(X_a − X_b)²] = σ² n/(n_a n_b)` and `Var X = σ²/n`, so
/// `(X_a − X_b)² · n_a n_b/n²` is an unbiased estimate of `Var X` (¼ (X_a − X_b)² for equal halves); the same
/// holds for any linear combination of images whose halves are formed alike ([`combination_noise_sq`]).
#[derive(Clone, Debug, PartialEq)]
pub struct HalfMeans {
    pub a: Vec<[f32; 3]>,
    pub b: Vec<[f32; 3]>,
    /// Samples per item in each half (0 and 0 for an exact, noise-free image).
    pub samples_a: u32,
    pub samples_b: u32,
}

impl HalfMeans {
    /// A noise-free image (a technique's render): both halves are the image itself.
    pub fn exact(image: Vec<[f32; 3]>) -> Self {
        Self { a: image.clone(), b: image, samples_a: 0, samples_b: 0 }
    }

    /// `n_a n_b / n²`: what turns `(X_a − X_b)²` into the variance of the mean (`None` for an exact image).
    pub fn variance_weight(&self) -> Option<f64> {
        let (na, nb) = (self.samples_a as f64, self.samples_b as f64);
        (self.samples_a > 0 && self.samples_b > 0).then(|| na * nb / ((na + nb) * (na + nb)))
    }

    /// The mean of both halves, weighted by their sample counts.
    pub fn mean(&self) -> Vec<[f32; 3]> {
        let (na, nb) = match (self.samples_a, self.samples_b) {
            (0, 0) => (1.0, 0.0),
            (a, b) => (a as f64, b as f64),
        };
        self.a
            .iter()
            .zip(&self.b)
            .map(|(x, y)| std::array::from_fn(|k| ((na * x[k] as f64 + nb * y[k] as f64) / (na + nb)) as f32))
            .collect()
    }
}

/// Estimated noise of `Σ c_i X_i` (images `X_i` with coefficients `c_i`, e.g. `[(1, s), (−1, t)]` for the
/// difference `s − t`): the sum over `mask`ed items and RGB of its variance, `Σ (D_a − D_b)² · w`, where
/// `D_a = Σ c_i X_i,a` and `D_b = Σ c_i X_i,b` are the combination in each half ([`HalfMeans`]) and `w` the
/// mean `n_a n_b/n²` of the noisy terms (¼ when every half holds equally many samples, as
/// [`converge_until_split`] arranges; exact then, otherwise an approximation). Correlated noise of the terms
/// (shared seeds) is thereby accounted for; exact terms add nothing. 0 when every term is exact.
pub fn combination_noise_sq(terms: &[(f64, &HalfMeans)], mask: &[bool]) -> f64 {
    let weights: Vec<f64> = terms.iter().filter_map(|(_, h)| h.variance_weight()).collect();
    if weights.is_empty() {
        return 0.0;
    }
    let w = weights.iter().sum::<f64>() / weights.len() as f64;
    let mut sum = 0.0;
    for (i, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
        for k in 0..3 {
            let d: f64 = terms.iter().map(|(c, h)| c * (h.a[i][k] as f64 - h.b[i][k] as f64)).sum();
            sum += d * d;
        }
    }
    sum * w
}

/// Accumulates the even and odd frames' sample sums from the running means the reference reports after
/// each frame (`n_k M_k − n_{k−1} M_{k−1}` is frame k's sum; in f64, so that the differences of the f32
/// means lose ~n·2⁻²⁴ of the mean per frame, orders of magnitude below the noise of the frame).
#[derive(Default)]
struct HalfSplitter {
    previous: Vec<[f64; 3]>,
    sum_a: Vec<[f64; 3]>,
    samples_before: u32,
    samples_a: u32,
    frame: u32,
}

impl HalfSplitter {
    fn add_frame(&mut self, mean: &[[f32; 3]], samples: u32) {
        let n = samples as f64;
        let now: Vec<[f64; 3]> = mean.iter().map(|m| m.map(|v| v as f64 * n)).collect();
        if self.previous.len() != now.len() || samples < self.samples_before {
            // First frame (or a restart of the accumulation): everything so far is this frame's.
            self.previous = vec![[0.0; 3]; now.len()];
            self.sum_a = vec![[0.0; 3]; now.len()];
            self.samples_before = 0;
            self.samples_a = 0;
            self.frame = 0;
        }
        if self.frame.is_multiple_of(2) {
            for ((a, cur), prev) in self.sum_a.iter_mut().zip(&now).zip(&self.previous) {
                for k in 0..3 {
                    a[k] += cur[k] - prev[k];
                }
            }
            self.samples_a += samples - self.samples_before;
        }
        self.previous = now;
        self.samples_before = samples;
        self.frame += 1;
    }

    /// Half `b` is everything that is not in half `a`, so the weighted halves give back `mean` exactly.
    fn finish(self, mean: &[[f32; 3]], samples: u32) -> HalfMeans {
        let (na, nb) = (self.samples_a, samples.saturating_sub(self.samples_a));
        let half = |s: f64, count: u32| if count > 0 { (s / count as f64) as f32 } else { 0.0 };
        let total = |m: &[f32; 3], k: usize| m[k] as f64 * samples as f64;
        let a = self.sum_a.iter().map(|s| std::array::from_fn(|k| half(s[k], na))).collect();
        if nb == 0 {
            // One frame has no second half: its noise cannot be told from the image, and the image counts
            // as exact in [`combination_noise_sq`] (samples 0, 0). Runs of the report take ≥ 2 frames.
            let a: Vec<[f32; 3]> = a;
            return HalfMeans { b: a.clone(), a, samples_a: 0, samples_b: 0 };
        }
        let b =
            mean.iter().zip(&self.sum_a).map(|(m, s)| std::array::from_fn(|k| half(total(m, k) - s[k], nb))).collect();
        HalfMeans { a, b, samples_a: na, samples_b: nb }
    }
}

/// Accumulate until the reference's relative standard error is at most `target_rel_stderr`.
pub fn converge(
    gpu: &Gpu,
    renderer: &mut Renderer,
    target_rel_stderr: f64,
    max_samples: u32,
) -> Result<(ConvergeReport, ReferenceStats)> {
    converge_until(gpu, renderer, max_samples, |s| s.relative_stderr() <= target_rel_stderr)
}

/// Accumulate until the reference's relative standard error is at most `fraction` of the relative
/// RMSE of `measured` (one RGB value per item, e.g. a technique's image) against the reference:
/// the reference is then good enough to measure that error.
pub fn converge_against(
    gpu: &Gpu,
    renderer: &mut Renderer,
    measured: &[[f32; 3]],
    fraction: f64,
    max_samples: u32,
) -> Result<(ConvergeReport, ReferenceStats)> {
    converge_until(gpu, renderer, max_samples, |s| {
        let err = crate::metrics::relative_rmse_items(measured, &s.mean, &s.covered);
        s.relative_stderr() <= fraction * err
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tiny deterministic normal generator (xorshift64* and Box–Muller), so the test needs no crate.
    struct Normal(u64);
    impl Normal {
        fn uniform(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            ((self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        }
        fn sample(&mut self) -> f64 {
            let (u, v) = (self.uniform(), self.uniform());
            (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
        }
    }

    /// Feed frames of per-item samples through the splitter as the convergence loop does: running f32 means
    /// after each frame (as the reference's Welford accumulators report them).
    fn converge_synthetic(samples: &[Vec<[f64; 3]>], per_frame: usize) -> (Vec<[f32; 3]>, HalfMeans) {
        let items = samples[0].len();
        let mut sums = vec![[0.0f64; 3]; items];
        let mut split = HalfSplitter::default();
        let mut mean = Vec::new();
        for (j, frame) in samples.chunks(per_frame).enumerate() {
            for s in frame {
                for (acc, x) in sums.iter_mut().zip(s) {
                    for k in 0..3 {
                        acc[k] += x[k];
                    }
                }
            }
            let n = ((j + 1) * per_frame) as f64;
            mean = sums.iter().map(|a| a.map(|v| (v / n) as f32)).collect();
            split.add_frame(&mean, n as u32);
        }
        let n = samples.len() as u32;
        (mean.clone(), split.finish(&mean, n))
    }

    /// Two "references" share their random numbers (noise e, σ_e = 30 % of the signal, common to both) and
    /// differ by a small independent noise f (σ_f = 3 %) and a true proxy difference. The noise of their
    /// difference is Σ σ_f²/n, which the half-split estimate recovers, while √(σ_s² + σ_t²) (the per-image
    /// noises added as if independent) is ~14× too large and drives the debiased error far below the truth.
    #[test]
    fn difference_noise_of_correlated_references() {
        let (items, n, per_frame) = (3000usize, 64usize, 8usize);
        let mut g = Normal(0x9e37_79b9_7f4a_7c15);
        let truth_s: Vec<[f64; 3]> = (0..items).map(|i| [1.0 + (i % 7) as f64 * 0.1, 0.5, 0.8]).collect();
        // True proxy difference: 5 % of the signal on every third item.
        let truth_t: Vec<[f64; 3]> =
            truth_s.iter().enumerate().map(|(i, s)| s.map(|v| if i % 3 == 0 { v * 0.95 } else { v })).collect();
        let (sigma_e, sigma_f) = (0.3, 0.03);
        let (mut s_samples, mut t_samples) = (Vec::new(), Vec::new());
        for _ in 0..n {
            let (mut s, mut t) = (Vec::with_capacity(items), Vec::with_capacity(items));
            for i in 0..items {
                let mut si = [0.0; 3];
                let mut ti = [0.0; 3];
                for k in 0..3 {
                    let e = sigma_e * truth_s[i][k] * g.sample();
                    let f = sigma_f * truth_s[i][k] * g.sample();
                    si[k] = truth_s[i][k] + e;
                    ti[k] = truth_t[i][k] + e + f;
                }
                s.push(si);
                t.push(ti);
            }
            s_samples.push(s);
            t_samples.push(t);
        }
        let (s_mean, s_half) = converge_synthetic(&s_samples, per_frame);
        let (t_mean, t_half) = converge_synthetic(&t_samples, per_frame);
        assert_eq!((s_half.samples_a, s_half.samples_b), (32, 32));
        // The halves give back the mean.
        for (m, h) in s_mean.iter().zip(s_half.mean()) {
            for k in 0..3 {
                assert!((m[k] - h[k]).abs() <= 1e-5 * m[k].abs().max(1.0), "{m:?} vs {h:?}");
            }
        }
        let mask = vec![true; items];
        let true_noise_sq: f64 = truth_s.iter().flat_map(|s| s.map(|v| (sigma_f * v).powi(2) / n as f64)).sum();
        let estimate = combination_noise_sq(&[(1.0, &s_half), (-1.0, &t_half)], &mask);
        // 9000 degrees of freedom: the estimate is within a few % (1.5 % standard deviation).
        assert!((estimate / true_noise_sq - 1.0).abs() < 0.06, "estimate {estimate} vs true {true_noise_sq}");
        // The per-image noises added as if independent (what the report did before).
        let naive = combination_noise_sq(&[(1.0, &s_half)], &mask) + combination_noise_sq(&[(1.0, &t_half)], &mask);
        assert!(naive > 100.0 * true_noise_sq, "naive {naive} vs true {true_noise_sq}");

        // The debiased error of the difference: √(RMSE² − noise²) against the true difference.
        let sq = |a: &[[f32; 3]], b: &[[f64; 3]]| -> f64 {
            a.iter().zip(b).flat_map(|(x, y)| (0..3).map(move |k| (x[k] as f64 - y[k]).powi(2))).sum()
        };
        let t_as_f64: Vec<[f64; 3]> = t_mean.iter().map(|t| t.map(|v| v as f64)).collect();
        let measured_sq = sq(&s_mean, &t_as_f64);
        let true_sq: f64 =
            truth_s.iter().zip(&truth_t).flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).powi(2))).sum();
        let debiased = (measured_sq - estimate).max(0.0).sqrt();
        let over = (measured_sq - naive).max(0.0).sqrt();
        assert!((debiased / true_sq.sqrt() - 1.0).abs() < 0.02, "debiased {debiased} vs {}", true_sq.sqrt());
        assert!(over < 0.5 * true_sq.sqrt(), "the naive correction should over-correct here: {over}");
        // An exact image (a technique's render) adds nothing; a combination of exact images has no noise.
        let exact = HalfMeans::exact(t_mean.clone());
        assert_eq!(combination_noise_sq(&[(1.0, &exact), (-1.0, &exact)], &mask), 0.0);
        let vs_exact = combination_noise_sq(&[(1.0, &exact), (-1.0, &s_half)], &mask);
        assert_eq!(vs_exact, combination_noise_sq(&[(1.0, &s_half)], &mask));
        // ≈ Σ Var(S̄) = Σ (σ_e² + 0) s²/n.
        let s_noise: f64 = truth_s.iter().flat_map(|s| s.map(|v| (sigma_e * v).powi(2) / n as f64)).sum();
        assert!((vs_exact / s_noise - 1.0).abs() < 0.06, "{vs_exact} vs {s_noise}");
    }

    /// Unequal halves (an odd frame count) are weighted by n_a n_b / n²; one frame has no second half.
    #[test]
    fn half_split_weights() {
        let mut g = Normal(7);
        let samples: Vec<Vec<[f64; 3]>> =
            (0..24).map(|_| (0..4000).map(|_| [g.sample(), g.sample(), g.sample()]).collect()).collect();
        let (_, h) = converge_synthetic(&samples, 8);
        assert_eq!((h.samples_a, h.samples_b), (16, 8));
        assert!((h.variance_weight().unwrap() - 16.0 * 8.0 / 576.0).abs() < 1e-12);
        let est = combination_noise_sq(&[(1.0, &h)], &vec![true; 4000]);
        let truth = 12000.0 / 24.0;
        assert!((est / truth - 1.0).abs() < 0.06, "{est} vs {truth}");
        let (m, one) = converge_synthetic(&samples[..8], 8);
        assert_eq!(one.variance_weight(), None);
        assert_eq!(one.a, m);
        assert_eq!(combination_noise_sq(&[(1.0, &one)], &vec![true; 4000]), 0.0);
    }
}
