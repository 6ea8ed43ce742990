//! Shared helpers of the integration tests in tests/tests/, and their analytic scenes ([`fixtures`]).

pub mod fixtures;

use engine::gpu::testing::TestGpu;
use engine::gpu::Gpu;
use engine::renderer::{RenderSettings, Renderer};
use engine::scene::Scene;
use glam::DVec3;
use std::path::Path;

/// A GPU with the validation layer required: any validation error or leak fails `shutdown`, and
/// fails the test on drop when it forgets `shutdown` ([`TestGpu`]).
pub fn gpu() -> TestGpu {
    engine::gpu::testing::test_gpu().expect("a Vulkan device with the validation layer (run `cargo xtask test`)")
}

/// What an image test does with its reference image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReferenceMode {
    /// Compare the render with the reference (every normal run).
    Compare,
    /// Write the render as the new reference, then fail: see [`blessed`].
    Bless,
}

/// An environment flag is on when set to anything but "", "0" or "false" (any case): CI systems set
/// `CI=true` (GitHub, GitLab) or `CI=1`; `.ci/run` runs under `CI=true`.
fn flag_on(value: Option<&str>) -> bool {
    value.is_some_and(|v| !v.is_empty() && v != "0" && !v.eq_ignore_ascii_case("false"))
}

/// The mode from the values of `ENGINE_BLESS` and `CI`. Blessing under CI is refused: a CI run that
/// rewrote its references would compare nothing and could not fail.
pub fn reference_mode_from(bless: Option<&str>, ci: Option<&str>) -> Result<ReferenceMode, String> {
    match (flag_on(bless), flag_on(ci)) {
        (false, _) => Ok(ReferenceMode::Compare),
        (true, false) => Ok(ReferenceMode::Bless),
        (true, true) => Err(format!(
            "ENGINE_BLESS={} is refused under CI (CI={}): references are blessed on a developer's machine \
             (`cargo xtask bless`) and committed; CI only compares",
            bless.unwrap_or_default(),
            ci.unwrap_or_default()
        )),
    }
}

/// [`reference_mode_from`] on this process's environment; panics (fails the test) when refused.
pub fn reference_mode() -> ReferenceMode {
    let var = |k: &str| std::env::var(k).ok();
    reference_mode_from(var("ENGINE_BLESS").as_deref(), var("CI").as_deref()).unwrap_or_else(|e| panic!("{e}"))
}

/// Ends a blessing image test: the reference at `path` was written and nothing was compared, so the
/// test fails rather than report a pass it did not earn. `cargo xtask bless` runs the image tests again
/// without `ENGINE_BLESS` afterwards; that run is the test.
pub fn blessed(path: &Path) -> ! {
    panic!(
        "blessed {}: the reference was written and NOT compared (ENGINE_BLESS is set), so this run is not a \
         test; run again without ENGINE_BLESS to check it (`cargo xtask bless` does)",
        path.display()
    )
}

/// Render `scene` once and return (linear RGBA32F, tone-mapped RGBA8).
pub fn render(gpu: &Gpu, scene: &Scene, settings: RenderSettings) -> (Vec<f32>, Vec<u8>) {
    let mut r = Renderer::new(gpu, scene, settings).expect("renderer");
    r.render(gpu).expect("frame");
    let hdr = r.read_radiance(gpu).expect("readback");
    let ldr = r.read_ldr(gpu).expect("readback");
    r.destroy(gpu);
    (hdr, ldr)
}

/// A covered G-buffer pixel: (world position, unit normal, material index); None where nothing was drawn.
pub type Receiver = Option<(DVec3, DVec3, usize)>;

/// Render `scene` once and read back the radiance and the G-buffer's receivers (per pixel).
pub fn render_with_gbuffer(gpu: &Gpu, scene: &Scene, settings: RenderSettings) -> (Vec<f32>, Vec<Receiver>) {
    let (hdr, g, _) = render_with_bvh(gpu, scene, settings);
    (hdr, g)
}

/// The blocker BVH a frame's shaders read, read back: its first 2n − 1 nodes and the n world spheres.
pub struct ReadBvh {
    pub nodes: Vec<engine::blockers::bvh::GpuBvhNode>,
    pub spheres: Vec<engine::blockers::Sphere>,
}

/// [`render_with_gbuffer`], and the blocker BVH the shaders read (so a twin cuts exactly the GPU's tree).
pub fn render_with_bvh(gpu: &Gpu, scene: &Scene, settings: RenderSettings) -> (Vec<f32>, Vec<Receiver>, ReadBvh) {
    let pixels = (settings.width * settings.height) as usize;
    let mut r = Renderer::new(gpu, scene, settings).expect("renderer");
    r.render(gpu).expect("frame");
    let hdr = r.read_radiance(gpu).expect("radiance");
    let pos = gpu.read_image_rgba32f(&r.gbuffer.position).expect("positions");
    let nrm = gpu.read_image_rgba32f(&r.gbuffer.normal).expect("normals");
    let n = r.scene.blockers.sphere_count as usize;
    let mut spheres = gpu.read_buffer::<[f32; 4]>(&r.scene.blockers.spheres).expect("spheres");
    spheres.truncate(n);
    let mut nodes = gpu.read_buffer::<engine::blockers::bvh::GpuBvhNode>(&r.scene.blockers.bvh_nodes).expect("nodes");
    nodes.truncate((2 * n).saturating_sub(1));
    r.destroy(gpu);
    let spheres = spheres.iter().map(|a| engine::blockers::Sphere::from_array(a.map(f64::from))).collect();
    let g = (0..pixels)
        .map(|i| {
            let (p, n) = (&pos[4 * i..4 * i + 4], &nrm[4 * i..4 * i + 4]);
            (p[3] >= 0.5).then(|| {
                let p3 = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
                (p3, DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64).normalize(), (p[3] - 0.5) as usize)
            })
        })
        .collect();
    (hdr, g, ReadBvh { nodes, spheres })
}

/// RGB of pixel `i` of a linear RGBA32F image, as f64.
pub fn rgb(hdr: &[f32], i: usize) -> [f64; 3] {
    [hdr[4 * i] as f64, hdr[4 * i + 1] as f64, hdr[4 * i + 2] as f64]
}

/// Every value of the image is finite.
pub fn assert_finite(hdr: &[f32], what: &str) {
    assert!(hdr.iter().all(|v| v.is_finite()), "{what}: non-finite pixel value");
}

/// Relative RMSE over pixels where `mask` holds: sqrt(Σ|a−b|²) / sqrt(Σ|b|²) on RGB.
pub fn relative_rmse(a: &[f32], b: &[f32], mask: impl Fn(usize) -> bool) -> f64 {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for i in 0..a.len() / 4 {
        if !mask(i) {
            continue;
        }
        for c in 0..3 {
            let (x, y) = (a[4 * i + c] as f64, b[4 * i + c] as f64);
            num += (x - y) * (x - y);
            den += y * y;
        }
    }
    (num / den.max(f64::MIN_POSITIVE)).sqrt()
}

/// ∫_cap (n·ω)⁺ dω / π for a sphere (c, r) seen from p on a plane with normal +Y when the cap is
/// wholly above the horizon: h r² / d³. None when the cap crosses the horizon.
pub fn cap_cosine_fraction(p: DVec3, c: DVec3, r: f64) -> Option<f64> {
    let d = c - p;
    let dist = d.length();
    let (alpha, beta) = ((r / dist).asin(), (d.y / dist).acos());
    (alpha + beta <= std::f64::consts::FRAC_PI_2).then(|| d.y * r * r / (dist * dist * dist))
}

/// Write `bytes` to `<temp>/<folder>-<pid>/<name>` and return the path (bad-input tests).
pub fn temp_file(folder: &str, name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("{folder}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp folder");
    let p = dir.join(name);
    std::fs::write(&p, bytes).expect("temp file");
    p
}

/// The error names the file and says `what` (case-insensitive).
pub fn assert_err_names(err: impl std::fmt::Display, path: &std::path::Path, what: &str) {
    let s = err.to_string();
    assert!(s.contains(&path.display().to_string()), "error does not name the file: {s}");
    assert!(s.to_lowercase().contains(&what.to_lowercase()), "error does not say '{what}': {s}");
}

/// The K = 10 SG fit of `env` that `isg` uses (its refinement rounds), rounded to f32 as the GPU reads it:
/// the lobes of the f64 twin comparisons.
pub fn isg_lobes_as_the_gpu_reads_them(env: &engine::math::envmap::LatLongMap) -> Vec<engine::math::sg::SgRgb> {
    let (fitted, _) = engine::passes::shade::isg::fit_environment(env, 10, engine::passes::shade::isg::REFINE_ROUNDS);
    fitted
        .iter()
        .map(|l| {
            let mut l = *l;
            l.axis = l.axis.map(|x| x as f32 as f64);
            l.lambda = l.lambda as f32 as f64;
            l.mu = l.mu.map(|x| x as f32 as f64);
            l
        })
        .collect()
}

/// Scene-file options whose sphere fit runs in a fraction of a second (`spheres` per mesh, a coarse grid, few
/// iterations), caching under `cache`: for tests that load user models and do not measure the fit.
pub fn small_fit_options(spheres: usize, cache: &Path) -> scenes::user::UserOptions {
    scenes::user::UserOptions {
        spheres: Some(spheres),
        cache: Some(cache.to_path_buf()),
        fit: Some(engine::blockers::fit::FitSettings {
            grid_resolution: 10,
            lookup_resolution: 16,
            volume_samples: 32,
            max_iterations: 6,
            max_teleports: 1,
            ..Default::default()
        }),
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::{blessed, reference_mode_from, relative_rmse, ReferenceMode};

    // ENGINE_BLESS blesses only off CI; any CI value that means "on" refuses it.
    #[test]
    fn blessing_is_refused_under_ci() {
        use ReferenceMode::*;
        assert_eq!(reference_mode_from(None, None), Ok(Compare));
        assert_eq!(reference_mode_from(None, Some("true")), Ok(Compare));
        assert_eq!(reference_mode_from(Some("1"), None), Ok(Bless));
        assert_eq!(reference_mode_from(Some("1"), Some("false")), Ok(Bless));
        assert_eq!(reference_mode_from(Some("1"), Some("0")), Ok(Bless));
        assert_eq!(reference_mode_from(Some("1"), Some("")), Ok(Bless));
        assert_eq!(reference_mode_from(Some("0"), Some("true")), Ok(Compare));
        assert_eq!(reference_mode_from(Some(""), None), Ok(Compare));
        assert_eq!(reference_mode_from(Some("false"), None), Ok(Compare));
        for ci in ["true", "1", "TRUE", "yes"] {
            let err = reference_mode_from(Some("1"), Some(ci)).unwrap_err();
            assert!(err.contains("refused under CI") && err.contains(&format!("CI={ci}")), "{err}");
        }
    }

    // A blessing run never reports success.
    #[test]
    #[should_panic(expected = "NOT compared")]
    fn a_blessed_test_fails() {
        blessed(std::path::Path::new("references/x.png"));
    }

    // The metric itself, on pairs with known answers.
    #[test]
    fn relative_rmse_known_answers() {
        let b = vec![1.0, 1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 1.0];
        assert_eq!(relative_rmse(&b, &b, |_| true), 0.0);
        let a: Vec<f32> = b.iter().map(|x| x * 1.1).collect();
        assert!((relative_rmse(&a, &b, |_| true) - 0.1).abs() < 1e-6);
        // Masked-out pixels do not count.
        let mut c = b.clone();
        c[4] = 100.0;
        assert_eq!(relative_rmse(&c, &b, |i| i == 0), 0.0);
    }
}
