//! The speed-against-error report (`cargo xtask report`): a sweep of scenes × technique specs × shading rates,
//! defined in one config file (tools/report/sweep.json), each measured for GPU time (median of ≥ 5 frames,
//! timestamp queries) and error against the converged Monte Carlo reference; plus the error decomposition of
//! docs/design.md §4 (SHEXP Fig. 7) on every scene with blocker spheres: proxy error (sphere-proxy reference against
//! the triangle reference), technique error (technique against the sphere-proxy reference) and representation
//! error (technique on the scene without blockers against the unoccluded reference); and the error split by
//! region (each object's pixels, exactly from the G-buffer) and by lighting (the environment's upper and lower
//! hemisphere rendered separately, with upper + lower = whole checked against the noise).
//!
//! Every "minus noise" figure removes the noise of the difference itself, estimated from the two independent
//! half-sample means each reference keeps (`crate::converge::combination_noise_sq`): the references share their
//! random numbers, so their difference is far less noisy than their own noises added.
//!
//! Writes into the output folder: `results.csv` (one row per measurement, columns in [`CSV_HEADER`]),
//! `regions.csv` (error by region and lighting, [`REGIONS_HEADER`]), `pareto.svg` (all scenes) and
//! `pareto-<scene>.svg` (GPU ms against relative RMSE vs the triangle reference, one series per technique and
//! shading rate), `decomposition-<scene>.svg` (proxy, technique and representation error against GPU ms),
//! `README.md` (tables, decomposition, thumbnails) and `img/*.png` (renders, reference renders, error heat maps).
//!
//! The module is split by what each part does, lowest first: [`sweep`] (the definition), [`results`] (what was
//! measured), [`run`] (measuring), [`write`] (the CSV files, plots and plain README) and [`page`] (the results page
//! of a sweep with a site). [`run()`] below runs them in that order; no part imports a later one. [`jobs`], last,
//! runs a sweep as one shell command per point on existing engines (GNU parallel, Slurm, xargs: docs/sweeps.md)
//! and merges the finished points through the same writers.

pub mod jobs;
pub mod page;
pub mod results;
pub mod run;
pub mod sweep;
pub mod write;

pub use results::*;
pub use sweep::*;
pub use write::{write_csv, write_regions_csv};

use anyhow::{Context, Result};
use engine::gpu::Gpu;
use std::path::Path;

/// Run the sweep and write its files into `out`: the CSV files and plots, then the results page (a sweep with a
/// site) or a plain README. `command` is the command line the page quotes.
pub fn run(gpu: &Gpu, sweep: &Sweep, out: &Path, command: &str) -> Result<Results> {
    let t0 = std::time::Instant::now();
    let results = run::measure(gpu, sweep, out)?;
    write_outputs(out, sweep, &results, &gpu.info.name, command)?;
    eprintln!("in {:.0} s", t0.elapsed().as_secs_f64());
    Ok(results)
}

/// Write the files of a measured sweep into `out`: the CSV files and plots, then the results page (a sweep with a
/// site) or a plain README (naming `device`). The single-process run and the merge of a sweep run as jobs
/// ([`jobs::merge`]) both write through here.
pub fn write_outputs(out: &Path, sweep: &Sweep, results: &Results, device: &str, command: &str) -> Result<()> {
    let write_images = sweep.site.is_none();
    write_csv(&out.join("results.csv"), &results.rows)?;
    write_regions_csv(&out.join("regions.csv"), &results.regions)?;
    write::write_plots(out, &results.rows)?;
    match &sweep.site {
        Some(site) => page::write(out, sweep, site, results, device, command)?,
        None => {
            let readme = write::readme(device, sweep, results);
            std::fs::write(out.join("README.md"), readme)
                .with_context(|| format!("writing {}/README.md", out.display()))?;
        }
    }
    eprintln!(
        "wrote {}/results.csv, regions.csv, pareto*.svg, decomposition*.svg, README.md{}",
        out.display(),
        if write_images { " and img/" } else { ", index.html and the summary" },
    );
    Ok(())
}
