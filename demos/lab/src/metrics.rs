//! Error metrics of an image against a reference (docs/design.md §4): relative RMSE in % over covered
//! pixels (the papers' "RMS error"), maximum error, FLIP mean (`nv-flip`, on tone-mapped sRGB), and
//! error heat-map images. Images are linear RGBA32F, row-major from the top-left, as
//! `Renderer::read_radiance` returns them; the alpha channel is ignored.

use std::path::Path;

/// Relative RMSE in percent over the pixels where `mask` holds:
/// `100 · sqrt(Σ |t − r|²) / sqrt(Σ |r|²)` over RGB. A black reference region gives 0 if the test
/// matches it and infinity otherwise.
pub fn relative_rmse_percent(test: &[f32], reference: &[f32], mask: &[bool]) -> f64 {
    let (num, den) = squared_sums(test.chunks_exact(4).map(rgb), reference.chunks_exact(4).map(rgb), mask);
    100.0 * sqrt_ratio(num, den)
}

/// Relative RMSE as a fraction, over per-item RGB values (pixels or vertices) where `mask` holds.
pub fn relative_rmse_items(test: &[[f32; 3]], reference: &[[f32; 3]], mask: &[bool]) -> f64 {
    let (num, den) = squared_sums(test.iter().copied(), reference.iter().copied(), mask);
    sqrt_ratio(num, den)
}

fn rgb(p: &[f32]) -> [f32; 3] {
    [p[0], p[1], p[2]]
}

fn squared_sums(t: impl Iterator<Item = [f32; 3]>, r: impl Iterator<Item = [f32; 3]>, mask: &[bool]) -> (f64, f64) {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for ((a, b), m) in t.zip(r).zip(mask) {
        if !*m {
            continue;
        }
        for k in 0..3 {
            let (x, y) = (a[k] as f64, b[k] as f64);
            num += (x - y) * (x - y);
            den += y * y;
        }
    }
    (num, den)
}

pub use engine::math::linalg::sqrt_ratio;

/// The largest per-channel absolute error over covered pixels, where it occurs, and the
/// reference value there (so callers can also report it relative to the signal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaxError {
    pub abs: f64,
    pub pixel: usize,
    pub reference: f64,
}

pub fn max_error(test: &[f32], reference: &[f32], mask: &[bool]) -> MaxError {
    let mut best = MaxError { abs: 0.0, pixel: 0, reference: 0.0 };
    for (i, ((a, b), m)) in test.chunks_exact(4).zip(reference.chunks_exact(4)).zip(mask).enumerate() {
        if !*m {
            continue;
        }
        for k in 0..3 {
            let e = (a[k] as f64 - b[k] as f64).abs();
            // NaN counts as the worst error.
            if e > best.abs || (e.is_nan() && !best.abs.is_nan()) {
                best = MaxError { abs: e, pixel: i, reference: b[k] as f64 };
            }
        }
    }
    best
}

/// FLIP error per pixel (LDR FLIP at the default 67 pixels per degree) between two tone-mapped
/// sRGB RGBA8 images (`Renderer::read_ldr`).
pub fn flip_map(test_ldr: &[u8], reference_ldr: &[u8], width: u32, height: u32) -> Vec<f32> {
    let rgb8 = |x: &[u8]| -> Vec<u8> { x.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect() };
    let t = nv_flip::FlipImageRgb8::with_data(width, height, &rgb8(test_ldr));
    let r = nv_flip::FlipImageRgb8::with_data(width, height, &rgb8(reference_ldr));
    nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE).to_vec()
}

/// Mean FLIP over the pixels where `mask` holds (all pixels with `None`).
pub fn flip_mean(test_ldr: &[u8], reference_ldr: &[u8], width: u32, height: u32, mask: Option<&[bool]>) -> f64 {
    let e = flip_map(test_ldr, reference_ldr, width, height);
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (i, v) in e.iter().enumerate() {
        if mask.is_none_or(|m| m.get(i).copied().unwrap_or(false)) {
            sum += *v as f64;
            n += 1;
        }
    }
    if n == 0 {
        0.0
    } else {
        sum / n as f64
    }
}

/// Heat map of the per-pixel error, RGBA8 through the magma colour map: the RGB-norm absolute
/// error |t − r| divided by `scale` (0 → black end, ≥ scale → bright end). Uncovered pixels are
/// drawn mid-grey so they do not read as "no error".
pub fn error_heatmap(test: &[f32], reference: &[f32], mask: &[bool], width: u32, height: u32, scale: f32) -> Vec<u8> {
    let n = (width * height) as usize;
    let values: Vec<f32> = (0..n)
        .map(|i| {
            let a = &test[4 * i..4 * i + 3];
            let b = &reference[4 * i..4 * i + 3];
            let e = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f32>().sqrt();
            let v = e / scale;
            if v.is_finite() {
                v.clamp(0.0, 1.0)
            } else {
                1.0
            }
        })
        .collect();
    let rgb =
        nv_flip::FlipImageFloat::with_data(width, height, &values).apply_color_lut(&nv_flip::magma_lut()).to_vec();
    rgb.chunks_exact(3)
        .enumerate()
        .flat_map(
            |(i, p)| if mask.get(i).copied().unwrap_or(false) { [p[0], p[1], p[2], 255] } else { [128, 128, 128, 255] },
        )
        .collect()
}

/// Write [`error_heatmap`] as a PNG.
pub fn write_error_heatmap(
    path: &Path,
    test: &[f32],
    reference: &[f32],
    mask: &[bool],
    width: u32,
    height: u32,
    scale: f32,
) -> Result<(), engine::output::OutputError> {
    engine::output::write_png(path, width, height, &error_heatmap(test, reference, mask, width, height, scale))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(values: &[[f32; 3]]) -> Vec<f32> {
        values.iter().flat_map(|v| [v[0], v[1], v[2], 1.0]).collect()
    }

    #[test]
    fn relative_rmse_known_answers() {
        let r = image(&[[1.0, 1.0, 1.0], [2.0, 2.0, 2.0]]);
        let all = [true, true];
        assert_eq!(relative_rmse_percent(&r, &r, &all), 0.0);
        // Uniform +10 % → exactly 10 %.
        let t: Vec<f32> = r.iter().map(|x| x * 1.1).collect();
        assert!((relative_rmse_percent(&t, &r, &all) - 10.0).abs() < 1e-4);
        // Error on one pixel only: sqrt(3·1²)/sqrt(3·1 + 3·4) = 1/sqrt(5).
        let t = image(&[[2.0, 2.0, 2.0], [2.0, 2.0, 2.0]]);
        assert!((relative_rmse_percent(&t, &r, &all) - 100.0 / 5f64.sqrt()).abs() < 1e-9);
        // Masked-out pixels do not count, and alpha is ignored.
        let mut t = r.clone();
        t[4] = 100.0;
        t[3] = 7.0;
        assert_eq!(relative_rmse_percent(&t, &r, &[true, false]), 0.0);
        // Black reference: 0 when matched, infinite otherwise.
        let z = image(&[[0.0; 3]]);
        assert_eq!(relative_rmse_percent(&z, &z, &[true]), 0.0);
        assert_eq!(relative_rmse_percent(&image(&[[1.0, 0.0, 0.0]]), &z, &[true]), f64::INFINITY);
        // The item form agrees with the image form.
        let items = |x: &[f32]| x.chunks_exact(4).map(|p| [p[0], p[1], p[2]]).collect::<Vec<_>>();
        let t = image(&[[1.5, 0.5, 1.0], [2.0, 1.0, 3.0]]);
        let a = relative_rmse_items(&items(&t), &items(&r), &all);
        assert!((100.0 * a - relative_rmse_percent(&t, &r, &all)).abs() < 1e-9);
    }

    #[test]
    fn max_error_known_answers() {
        let r = image(&[[1.0, 1.0, 1.0], [2.0, 2.0, 2.0], [0.0, 0.0, 0.0]]);
        let t = image(&[[1.0, 1.5, 1.0], [2.0, 2.0, 1.25], [9.0, 0.0, 0.0]]);
        let m = max_error(&t, &r, &[true, true, false]);
        assert_eq!(m, MaxError { abs: 0.75, pixel: 1, reference: 2.0 });
        assert_eq!(max_error(&t, &r, &[true, true, true]).abs, 9.0);
        let nan = image(&[[f32::NAN, 1.0, 1.0]]);
        assert!(max_error(&nan, &image(&[[1.0; 3]]), &[true]).abs.is_nan());
    }

    #[test]
    fn flip_known_answers() {
        let (w, h) = (32u32, 32u32);
        let grey: Vec<u8> = (0..w * h).flat_map(|_| [128, 128, 128, 255]).collect();
        assert_eq!(flip_mean(&grey, &grey, w, h, None), 0.0);
        // Black against white is FLIP's maximal difference (1 everywhere).
        let black: Vec<u8> = (0..w * h).flat_map(|_| [0, 0, 0, 255]).collect();
        let white: Vec<u8> = (0..w * h).flat_map(|_| [255, 255, 255, 255]).collect();
        let bw = flip_mean(&black, &white, w, h, None);
        assert!(bw > 0.9, "{bw}");
        // A small change is a small error, and it grows with the change.
        let slightly: Vec<u8> = grey.iter().enumerate().map(|(i, v)| if i % 4 == 3 { 255 } else { v + 8 }).collect();
        let more: Vec<u8> = grey.iter().enumerate().map(|(i, v)| if i % 4 == 3 { 255 } else { v + 40 }).collect();
        let (a, b) = (flip_mean(&slightly, &grey, w, h, None), flip_mean(&more, &grey, w, h, None));
        assert!(a > 0.0 && a < b && b < bw, "{a} {b} {bw}");
        // The mask selects pixels: white over the left half only, measured on either half.
        let half: Vec<u8> = (0..w * h).flat_map(|i| if i % w < w / 2 { [255; 4] } else { [0, 0, 0, 255] }).collect();
        let left: Vec<bool> = (0..w * h).map(|i| i % w < 8).collect();
        let right: Vec<bool> = (0..w * h).map(|i| i % w >= w - 8).collect();
        assert!(flip_mean(&half, &black, w, h, Some(&left)) > 0.9);
        assert_eq!(flip_mean(&half, &black, w, h, Some(&right)), 0.0);
    }

    #[test]
    fn heatmap_colours() {
        let r = image(&[[1.0; 3], [1.0; 3], [1.0; 3]]);
        let t = image(&[[1.0; 3], [2.0, 1.0, 1.0], [f32::NAN, 1.0, 1.0]]);
        let hm = error_heatmap(&t, &r, &[true, true, true], 3, 1, 1.0);
        let lut = nv_flip::magma_lut().to_vec();
        let last = lut.len() - 3;
        assert_eq!(&hm[0..3], &lut[0..3], "no error → the dark end");
        assert_eq!(&hm[4..7], &lut[last..], "error = scale → the bright end");
        assert_eq!(&hm[8..11], &lut[last..], "NaN → the bright end");
        let masked = error_heatmap(&t, &r, &[true, false, true], 3, 1, 1.0);
        assert_eq!(&masked[4..8], &[128, 128, 128, 255]);
    }
}
