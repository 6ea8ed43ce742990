//! What a sweep measured: one [`Row`] per scene × shading × technique, the error by region and lighting, the
//! linearity checks, the references' summaries and the images of the page.

use crate::measure::{Errors, ReferenceImage};
use serde::{Deserialize, Serialize};

/// One measured row of `results.csv`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Row {
    pub scene: String,
    /// `pixel`, `vertex`, or `-` for reference rows.
    pub shading: String,
    /// Technique spec, or `reference/spheres` / `reference/triangles`.
    pub technique: String,
    /// Median GPU ms of the technique's shading passes (for a reference: its GPU time to the samples it took).
    pub shade_ms: f64,
    /// Median GPU ms of the whole frame (references: NaN).
    pub frame_ms: f64,
    pub vs_triangles: Option<Errors>,
    pub vs_spheres: Option<Errors>,
    /// Representation error (docs/design.md §4): the technique on the scene without blockers against the unoccluded
    /// reference (scenes with blocker spheres only).
    pub representation: Option<Errors>,
}

/// Columns of `results.csv`; errors are relative RMSE in %, its value minus the noise of the difference
/// (estimated from the difference itself: [`measure::difference`]), the largest absolute channel error, mean
/// FLIP; then the noise removed (in % of the reference), and the representation error (no blockers against the
/// unoccluded reference); empty where a reference does not exist (no spheres).
pub const CSV_HEADER: &str = "scene,shading,technique,shade_ms,frame_ms,rmse_tri_pct,rmse_tri_debiased_pct,max_err_tri,flip_tri,rmse_sph_pct,rmse_sph_debiased_pct,max_err_sph,flip_sph,noise_tri_pct,noise_sph_pct,rmse_repr_pct,rmse_repr_debiased_pct";

/// Columns of `regions.csv`: one row per scene × image × region × lighting × reference. `rmse_pct` is
/// relative to the reference under the same lighting over the region; `of_whole_pct` the same error relative
/// to the whole-lighting reference over the region (so that the upper and lower parts compare with the whole);
/// `error_share_pct` the region's part of the image's squared error (same lighting and reference);
/// `radiance_share_pct` the image's radiance in the region under this lighting over that under the whole.
pub const REGIONS_HEADER: &str = "scene,shading,image,region,lighting,against,rmse_pct,debiased_pct,noise_pct,of_whole_pct,of_whole_debiased_pct,error_share_pct,radiance_share_pct";

/// One row of `regions.csv` ([`REGIONS_HEADER`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RegionRow {
    pub scene: String,
    pub shading: String,
    pub image: String,
    pub region: String,
    pub lighting: String,
    pub against: String,
    pub rmse: f64,
    pub debiased: f64,
    pub noise: f64,
    pub of_whole: f64,
    pub of_whole_debiased: f64,
    pub error_share: f64,
    pub radiance_share: f64,
}

/// Upper + lower against whole for one image: the relative RMSE of (upper + lower − whole) against the whole,
/// and the noise of that combination estimated from the halves (0 for a technique: its renders are exact).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LinearityCheck {
    pub scene: String,
    pub image: String,
    pub rmse: f64,
    pub noise: f64,
}

impl LinearityCheck {
    /// Upper + lower equals the whole within the noise (1.5× its estimate, or 1e-3 % for exact images).
    pub fn holds(&self) -> bool {
        self.rmse <= 1.5 * self.noise + 1e-3
    }

    /// The verdict in words: a noisy image (a reference) is linear within its noise or not; an exact render
    /// (a technique, whose fit of the lighting need not be linear) is linear or off by its RMSE.
    pub fn verdict(&self) -> String {
        match (self.noise > 0.0, self.holds()) {
            (true, true) => "linear within noise".into(),
            (true, false) => "NOT linear within noise".into(),
            (false, true) => "exact render: linear".into(),
            (false, false) => format!("exact render: not linear in the lighting by {:.3} %", self.rmse),
        }
    }
}

/// The references of one scene.
#[derive(Serialize, Deserialize)]
pub struct SceneReferences {
    pub scene: String,
    pub triangles: ReferenceSummary,
    pub spheres: Option<ReferenceSummary>,
}

/// What the README says about a converged reference.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ReferenceSummary {
    pub spp: u32,
    pub relative_stderr: f64,
    pub converged: bool,
    pub ms_per_sample: f64,
    pub seconds: f64,
}

impl From<&ReferenceImage> for ReferenceSummary {
    fn from(r: &ReferenceImage) -> Self {
        Self {
            spp: r.report.samples,
            relative_stderr: r.report.relative_stderr,
            converged: r.report.converged,
            ms_per_sample: r.ms_per_sample,
            seconds: r.seconds,
        }
    }
}

/// One image of a scene on the results page, PNG-encoded, with its error heat maps.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PageImage {
    /// `spec (shading)` for a technique, `reference (triangles)` / `reference (spheres)` for a reference.
    pub label: String,
    /// The technique spec (`none`, `isg:diffuse=ratio`, …) or `reference/<visibility>`.
    pub spec: String,
    /// `pixel`, `vertex`, or `reference`.
    pub group: String,
    /// The tone-mapped RGBA8 image and its PNG file.
    pub ldr: Vec<u8>,
    pub png: Vec<u8>,
    /// |image − triangle reference| and |image − sphere-proxy reference| ([`measure::heatmap`]).
    pub heat_triangles: Option<Vec<u8>>,
    pub heat_spheres: Option<Vec<u8>>,
}

/// The images of one scene of the sweep.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SceneImages {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub images: Vec<PageImage>,
}

/// Everything a sweep measured (one point of a sweep run as jobs keeps its part in this form: `super::jobs`).
#[derive(Default, Serialize, Deserialize)]
pub struct Results {
    /// Every scene's images (for the results page), in sweep order.
    pub images: Vec<SceneImages>,
    pub rows: Vec<Row>,
    pub references: Vec<SceneReferences>,
    /// Thumbnails per scene: (caption, path relative to the output folder).
    pub thumbnails: Vec<(String, Vec<(String, String)>)>,
    /// The error by region and lighting (`regions.csv`).
    pub regions: Vec<RegionRow>,
    /// Upper + lower = whole, per scene and image (with `split_lighting`).
    pub linearity: Vec<LinearityCheck>,
}
