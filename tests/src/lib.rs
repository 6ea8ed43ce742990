//! Shared helpers of the integration tests in tests/tests/, and their analytic scenes ([`fixtures`]).

pub mod fixtures;

use engine::gpu::Gpu;
use engine::renderer::{RenderSettings, Renderer};
use engine::scene::Scene;
use glam::DVec3;

/// A GPU with the validation layer required (any validation error fails `shutdown`).
pub fn gpu() -> Gpu {
    engine::gpu::testing::test_gpu().expect("a Vulkan device with the validation layer (run `cargo xtask test`)")
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
    let pixels = (settings.width * settings.height) as usize;
    let mut r = Renderer::new(gpu, scene, settings).expect("renderer");
    r.render(gpu).expect("frame");
    let hdr = r.read_radiance(gpu).expect("radiance");
    let pos = gpu.read_image_rgba32f(&r.gbuffer.position).expect("positions");
    let nrm = gpu.read_image_rgba32f(&r.gbuffer.normal).expect("normals");
    r.destroy(gpu);
    let g = (0..pixels)
        .map(|i| {
            let (p, n) = (&pos[4 * i..4 * i + 4], &nrm[4 * i..4 * i + 4]);
            (p[3] >= 0.5).then(|| {
                let p3 = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
                (p3, DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64).normalize(), (p[3] - 0.5) as usize)
            })
        })
        .collect();
    (hdr, g)
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

#[cfg(test)]
mod tests {
    use super::relative_rmse;

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
