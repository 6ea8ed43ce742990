//! Convergence of the Monte Carlo reference (above the renderer: it drives whole frames): render
//! frames with the renderer's `reference` technique until its own standard error is small enough,
//! absolutely ([`converge`]) or against the error being measured ([`converge_against`]).

use crate::gpu::{Gpu, GpuError, Result};
use crate::passes::shade::reference::{Reference, ReferenceStats, MAX_SAMPLES};
use crate::renderer::Renderer;

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
    mut done: impl FnMut(&ReferenceStats) -> bool,
) -> Result<(ConvergeReport, ReferenceStats)> {
    let per_vertex = renderer.settings.per_vertex;
    let mut frames = 0;
    loop {
        renderer.render(gpu)?;
        frames += 1;
        let r = reference_mut(renderer)
            .ok_or_else(|| GpuError::Other("converge: the technique is not 'reference'".into()))?;
        let stats = r.stats(gpu, per_vertex)?;
        let converged = stats.samples >= 2 && done(&stats);
        let next = stats.samples as u64 + r.options().samples_per_frame as u64;
        if converged || next > max_samples.min(MAX_SAMPLES) as u64 {
            let report =
                ConvergeReport { samples: stats.samples, frames, relative_stderr: stats.relative_stderr(), converged };
            return Ok((report, stats));
        }
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
