//! Prefiltered environment maps: the irradiance map (clamped-cosine convolution) and the
//! SG-prefiltered maps Γ_L(a, λ) of ISG Eq. 10, for a ladder of sharpness values.
//!
//! Both are direct convolutions over a lat-long map (no SH truncation, so suns survive), computed
//! at a working resolution matched to the kernel width, with the kernel's support bounded exactly
//! per row (angular distance test), so each level costs about the same.

use crate::envmap::{latlong_direction, texel_solid_angle, LatLongMap};
use std::f64::consts::PI;

/// Sharpness ladder of the SG-prefiltered levels: λ_k = 4^(k−1), k = 0..9 (0.25 … 16384).
pub const PREFILTER_LEVELS: usize = 9;

pub fn prefilter_lambda(level: usize) -> f64 {
    4f64.powi(level as i32 - 1)
}

/// Integral of a unit-amplitude SG of sharpness λ over the sphere: 2π(1 − e^{−2λ})/λ.
pub fn sg_unit_integral(lambda: f64) -> f64 {
    2.0 * PI * (-(-2.0 * lambda).exp_m1()) / lambda
}

/// Resample `src` to `width` × `height` (power-of-two box downsampling where it divides,
/// bilinear otherwise).
pub fn resample(src: &LatLongMap, width: usize, height: usize) -> LatLongMap {
    if src.width == width && src.height == height {
        return src.clone();
    }
    if src.width.is_multiple_of(width) && src.height.is_multiple_of(height) && src.width / width == src.height / height
    {
        return src.downsample(src.width / width);
    }
    let mut texels = Vec::with_capacity(width * height);
    for row in 0..height {
        for col in 0..width {
            let d = latlong_direction((col as f64 + 0.5) / width as f64, (row as f64 + 0.5) / height as f64);
            texels.push(src.lookup_bilinear(d).map(|x| x as f32));
        }
    }
    LatLongMap { width, height, texels }
}

/// Convolve `src` with a kernel k(cos ψ) whose support is ψ ≤ `support` (radians), normalized by the
/// kernel's discrete sum. Output has src's size.
fn convolve(src: &LatLongMap, support: f64, kernel: impl Fn(f64) -> f64 + Sync) -> LatLongMap {
    let (w, h) = (src.width, src.height);
    let dirs: Vec<[f64; 3]> = (0..h * w).map(|i| src.texel_direction(i % w, i / w)).collect();
    let solid: Vec<f64> = (0..h).map(|r| texel_solid_angle(r, w, h)).collect();
    let cos_support = support.min(PI).cos();
    let rows_out: Vec<Vec<[f32; 3]>> = std::thread::scope(|s| {
        let workers = std::thread::available_parallelism().map_or(1, |n| n.get()).min(8);
        let chunk = h.div_ceil(workers);
        let handles: Vec<_> = (0..workers)
            .map(|t| {
                let (dirs, solid, kernel) = (&dirs, &solid, &kernel);
                s.spawn(move || {
                    let mut out = Vec::new();
                    for row in (t * chunk)..((t + 1) * chunk).min(h) {
                        let theta_o = PI * (row as f64 + 0.5) / h as f64;
                        let mut line = Vec::with_capacity(w);
                        for col in 0..w {
                            let d = dirs[row * w + col];
                            let mut acc = [0.0f64; 3];
                            let mut wsum = 0.0;
                            for r in 0..h {
                                let theta = PI * (r as f64 + 0.5) / h as f64;
                                // Rows entirely outside the support (the polar gap bounds the angle).
                                if (theta - theta_o).abs() > support + PI / h as f64 {
                                    continue;
                                }
                                // φ window from cos ψ = cosθo cosθ + sinθo sinθ cosΔφ ≥ cos(support).
                                let denom = theta_o.sin() * theta.sin();
                                let half = if denom < 1e-12 {
                                    PI
                                } else {
                                    let c = (cos_support - theta_o.cos() * theta.cos()) / denom;
                                    if c <= -1.0 {
                                        PI
                                    } else if c >= 1.0 {
                                        // Only the nearest texels can contribute: keep one.
                                        0.0
                                    } else {
                                        c.acos()
                                    }
                                };
                                let dphi = 2.0 * PI / w as f64;
                                let span = ((half / dphi).ceil() as usize + 1).min(w / 2);
                                let c0 = col as i64;
                                for k in -(span as i64)..=(span as i64) {
                                    if span == w / 2 && k == span as i64 && w % 2 == 0 {
                                        continue; // the full row is covered once
                                    }
                                    let c = (c0 + k).rem_euclid(w as i64) as usize;
                                    let e = dirs[r * w + c];
                                    let cos = d[0] * e[0] + d[1] * e[1] + d[2] * e[2];
                                    if cos < cos_support {
                                        continue;
                                    }
                                    let wk = kernel(cos) * solid[r];
                                    let t = src.texels[r * w + c];
                                    acc[0] += wk * t[0] as f64;
                                    acc[1] += wk * t[1] as f64;
                                    acc[2] += wk * t[2] as f64;
                                    wsum += wk;
                                }
                            }
                            let norm = if wsum > 0.0 { 1.0 / wsum } else { 1.0 };
                            line.push(acc.map(|a| (a * norm) as f32));
                        }
                        out.push(line);
                    }
                    out
                })
            })
            .collect();
        handles.into_iter().flat_map(|h| h.join().unwrap_or_default()).collect()
    });
    LatLongMap { width: w, height: h, texels: rows_out.into_iter().flatten().collect() }
}

/// Irradiance on a lat-long grid whose rows include both poles: row j at θ_j = π j/(rows − 1),
/// column i at φ_i = 2π (i + ½)/width. Every texel of row 0 holds E(+Y) exactly (and the last row
/// E(−Y)), so bilinear lookups near the poles interpolate towards the true pole value instead of
/// clamping to a ring of texels half a row away, whose values depend on φ wherever a bright source
/// sits near the horizon (courtyard.exr's low sun: E 1.91–2.29 on the first ring of a 64×32 map
/// around E(+Y) = 2.10). GLSL lookup: `irradiance_grid_lookup` in shaders-glsl/common/envmap.glsl.
#[derive(Clone, Debug, PartialEq)]
pub struct IrradianceGrid {
    pub width: usize,
    pub rows: usize,
    /// Row-major, row 0 at +Y.
    pub texels: Vec<[f32; 3]>,
}

impl IrradianceGrid {
    /// E = Σ_texels L max(n·ω, 0) Ω over `src` resampled to 2·width × 2·(rows − 1) (twice the grid), at every grid direction. Needs width ≥ 1, rows ≥ 2.
    pub fn compute(src: &LatLongMap, width: usize, rows: usize) -> Self {
        assert!(width >= 1 && rows >= 2, "irradiance grid {width}x{rows}");
        let work = resample(src, 2 * width, 2 * (rows - 1));
        let (w, h) = (work.width, work.height);
        let dirs: Vec<[f64; 3]> = (0..w * h).map(|i| work.texel_direction(i % w, i / w)).collect();
        let solid: Vec<f64> = (0..h).map(|r| texel_solid_angle(r, w, h)).collect();
        let radiance: Vec<[f64; 3]> =
            work.texels.iter().enumerate().map(|(i, t)| t.map(|c| c as f64 * solid[i / w])).collect();
        let texels: Vec<[f32; 3]> = std::thread::scope(|s| {
            let workers = std::thread::available_parallelism().map_or(1, |n| n.get()).clamp(1, 8);
            let chunk = rows.div_ceil(workers);
            let handles: Vec<_> = (0..rows)
                .step_by(chunk)
                .map(|r0| {
                    let (dirs, radiance) = (&dirs, &radiance);
                    s.spawn(move || {
                        let mut out = Vec::with_capacity(chunk * width);
                        for row in r0..(r0 + chunk).min(rows) {
                            for col in 0..width {
                                let n = Self::direction_of(col, row, width, rows);
                                let mut e = [0.0f64; 3];
                                for (d, l) in dirs.iter().zip(radiance) {
                                    let c = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
                                    if c > 0.0 {
                                        for k in 0..3 {
                                            e[k] += l[k] * c;
                                        }
                                    }
                                }
                                out.push(e.map(|x| x as f32));
                            }
                        }
                        out
                    })
                })
                .collect();
            handles.into_iter().flat_map(|h| h.join().expect("irradiance worker")).collect()
        });
        Self { width, rows, texels }
    }

    fn direction_of(col: usize, row: usize, width: usize, rows: usize) -> [f64; 3] {
        crate::envmap::latlong_direction((col as f64 + 0.5) / width as f64, row as f64 / (rows - 1) as f64)
    }

    /// Direction of texel (col, row).
    pub fn direction(&self, col: usize, row: usize) -> [f64; 3] {
        Self::direction_of(col, row, self.width, self.rows)
    }

    /// Bilinear lookup (REPEAT in u, CLAMP_TO_EDGE in v), the f64 twin of the GLSL lookup: texture
    /// coordinate v' = (θ/π (rows − 1) + ½)/rows puts the pole rows' centres at θ = 0 and π.
    pub fn lookup_bilinear(&self, d: [f64; 3]) -> [f64; 3] {
        let (u, v) = crate::envmap::latlong_uv(d);
        let texel = |c: usize, r: usize| self.texels[r * self.width + c];
        let (x, y) = (u * self.width as f64 - 0.5, v * (self.rows - 1) as f64);
        crate::envmap::bilinear_wrap_u(texel, self.width, self.rows, x, y)
    }
}

/// The SG-prefiltered map of level `level` (λ = [`prefilter_lambda`]): the normalized convolution
/// Γ̄(a) = ∫ L(ω) G(ω; a, λ) dω / ∫ G dω, at `width` × `height`. Multiply by
/// [`sg_unit_integral`] to get ISG Eq. 10's Γ_L.
pub fn sg_prefiltered_map(src: &LatLongMap, level: usize, width: usize, height: usize) -> LatLongMap {
    let lambda = prefilter_lambda(level);
    // Working resolution: the kernel's width 1/√λ spans about two texels, within [16, height] rows.
    let mut rows = 16;
    while rows < height && (PI / rows as f64) > 0.5 / lambda.sqrt() {
        rows *= 2;
    }
    let work = resample(src, 2 * rows, rows);
    // Support: the kernel falls below 1e-6 of its peak.
    let support = (1.0 - 13.8 / lambda).max(-1.0).acos();
    let conv = convolve(&work, support, |c| (lambda * (c - 1.0)).exp());
    resample(&conv, width, height)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_environment_is_preserved() {
        // Furnace: a constant map convolves to itself (normalized).
        let m = LatLongMap::constant(64, 32, [2.0, 1.0, 0.5]);
        for level in [0, 4, 8] {
            let p = sg_prefiltered_map(&m, level, 32, 16);
            for t in &p.texels {
                assert!((t[1] - 1.0).abs() < 1e-5, "level {level}: {t:?}");
            }
        }
    }

    /// The pole rows hold E(±Y) of the working map exactly, every row of a constant map is πL, and
    /// lookups at and near the poles are the pole value, whatever φ the direction has.
    #[test]
    fn irradiance_grid_includes_the_poles() {
        let c = IrradianceGrid::compute(&LatLongMap::constant(64, 32, [2.0, 1.0, 0.5]), 16, 9);
        let worst = c.texels.iter().map(|t| (t[0] as f64 - 2.0 * PI).abs() / (2.0 * PI)).fold(0.0, f64::max);
        // The clamped cosine summed over a 32×16 working grid: within 0.5 % of π.
        assert!(worst < 6e-3, "constant map: πL within {worst}");
        // A sun near the horizon: one bright texel at θ ≈ 84°.
        let (w, h) = (128, 64);
        let mut m = LatLongMap::constant(w, h, [0.1; 3]);
        m.texels[30 * w + 17] = [5000.0; 3];
        let g = IrradianceGrid::compute(&m, 32, 17);
        let work = resample(&m, 64, 32);
        let brute = |n: [f64; 3]| -> f64 {
            (0..work.width * work.height)
                .map(|i| {
                    let (col, row) = (i % work.width, i / work.width);
                    let d = work.texel_direction(col, row);
                    let c = (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]).max(0.0);
                    work.texel(col, row)[0] as f64 * c * texel_solid_angle(row, work.width, work.height)
                })
                .sum()
        };
        let top = brute([0.0, 1.0, 0.0]);
        for col in 0..32 {
            assert!((g.texels[col][0] as f64 - top).abs() < 1e-4 * top, "pole row, column {col}");
        }
        for phi in [0.0f64, 1.0, 2.5, 4.0] {
            let got = g.lookup_bilinear([phi.cos() * 1e-9, 1.0, phi.sin() * 1e-9])[0];
            assert!((got - top).abs() < 1e-4 * top, "lookup at +Y (φ {phi}): {got} vs {top}");
        }
        // Off the poles, a smooth environment (the lobe of the next test) is interpolated within 1.5 %.
        let texels = (0..w * h)
            .map(|i| {
                let d = latlong_direction(((i % w) as f64 + 0.5) / w as f64, ((i / w) as f64 + 0.5) / h as f64);
                [d[2].max(0.0).powi(2) as f32; 3]
            })
            .collect();
        let g = IrradianceGrid::compute(&LatLongMap { width: w, height: h, texels }, 32, 17);
        for (u, v) in [(0.13, 0.3), (0.5, 0.05), (0.8, 0.7), (0.3, 1.0)] {
            let n = latlong_direction(u, v);
            let exact = crate::quadrature::integrate_sphere(
                |d| d[2].max(0.0).powi(2) * (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]).max(0.0),
                24,
                8,
                256,
            );
            let got = g.lookup_bilinear(n)[0];
            assert!((got - exact).abs() < 0.015 * (PI / 2.0), "n {n:?}: {got} vs {exact}");
        }
    }
}
