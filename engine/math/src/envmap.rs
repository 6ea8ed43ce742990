//! Equirectangular (lat-long) environment maps: the one direction convention of the engine.
//!
//! World space is Y-up. Texel (column i, row j) of a W×H map covers u ∈ [i/W, (i+1)/W),
//! v ∈ [j/H, (j+1)/H); row 0 is the zenith (+Y). A direction is
//! `(sin θ cos φ, cos θ, sin θ sin φ)` with `θ = π v` (polar angle from +Y) and `φ = 2π u`.
//! `shaders-glsl/common/envmap.glsl` is the GLSL twin.

use std::f64::consts::PI;

/// Unit direction for texture coordinates (u, v) ∈ [0, 1]².
pub fn latlong_direction(u: f64, v: f64) -> [f64; 3] {
    let theta = PI * v;
    let phi = 2.0 * PI * u;
    let s = theta.sin();
    [s * phi.cos(), theta.cos(), s * phi.sin()]
}

/// Texture coordinates (u ∈ [0, 1), v ∈ [0, 1]) of a direction (need not be normalized).
pub fn latlong_uv(d: [f64; 3]) -> (f64, f64) {
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(f64::MIN_POSITIVE);
    let y = (d[1] / len).clamp(-1.0, 1.0);
    let theta = y.acos();
    let mut phi = d[2].atan2(d[0]);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    ((phi / (2.0 * PI)).min(1.0 - 1e-12), theta / PI)
}

/// Exact solid angle of one texel in row `row` of a map with `width` × `height` texels.
pub fn texel_solid_angle(row: usize, width: usize, height: usize) -> f64 {
    let t0 = PI * row as f64 / height as f64;
    let t1 = PI * (row + 1) as f64 / height as f64;
    (2.0 * PI / width as f64) * (t0.cos() - t1.cos())
}

/// Bilinear interpolation of a `width` × `rows` texel grid at continuous texel coordinates (x, y) (texel
/// centres at integers), wrapping in x and clamping in y: a GPU sampler with REPEAT in u and CLAMP_TO_EDGE in v.
pub(crate) fn bilinear_wrap_u(
    texel: impl Fn(usize, usize) -> [f32; 3],
    width: usize,
    rows: usize,
    x: f64,
    y: f64,
) -> [f64; 3] {
    let y = y.clamp(0.0, (rows - 1) as f64);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let w = width as i64;
    let c0 = (x0 as i64).rem_euclid(w) as usize;
    let c1 = (x0 as i64 + 1).rem_euclid(w) as usize;
    let r0 = y0 as usize;
    let r1 = (r0 + 1).min(rows - 1);
    let (t00, t10, t01, t11) = (texel(c0, r0), texel(c1, r0), texel(c0, r1), texel(c1, r1));
    [0, 1, 2].map(|k| blend([t00[k], t10[k], t01[k], t11[k]], fx, fy))
}

/// Bilinear interpolation of a `width` × `rows` grid of scalars at continuous texel coordinates (x, y) (texel
/// centres at integers), clamped to the edge in both: a GPU sampler with CLAMP_TO_EDGE (material maps).
pub fn bilinear_clamp(texel: impl Fn(usize, usize) -> f32, width: usize, rows: usize, x: f64, y: f64) -> f64 {
    let axis = |v: f64, n: usize| {
        let v = v.clamp(0.0, (n - 1) as f64);
        let i = (v.floor() as usize).min(n - 1);
        (i, (i + 1).min(n - 1), v - i as f64)
    };
    let ((c0, c1, fx), (r0, r1, fy)) = (axis(x, width), axis(y, rows));
    blend([texel(c0, r0), texel(c1, r0), texel(c0, r1), texel(c1, r1)], fx, fy)
}

/// (t00, t10, t01, t11) weighted by the fractions (fx, fy) along x and y.
fn blend(t: [f32; 4], fx: f64, fy: f64) -> f64 {
    let a = t[0] as f64 * (1.0 - fx) + t[1] as f64 * fx;
    let b = t[2] as f64 * (1.0 - fx) + t[3] as f64 * fx;
    a * (1.0 - fy) + b * fy
}

/// An RGB lat-long radiance map in linear units, row-major, row 0 at the zenith.
#[derive(Clone, Debug, PartialEq)]
pub struct LatLongMap {
    pub width: usize,
    pub height: usize,
    pub texels: Vec<[f32; 3]>,
}

impl LatLongMap {
    /// A map with every texel equal to `radiance`.
    pub fn constant(width: usize, height: usize, radiance: [f32; 3]) -> Self {
        Self { width, height, texels: vec![radiance; width * height] }
    }

    pub fn texel(&self, col: usize, row: usize) -> [f32; 3] {
        self.texels[row * self.width + col]
    }

    /// Direction through the centre of texel (col, row).
    pub fn texel_direction(&self, col: usize, row: usize) -> [f64; 3] {
        latlong_direction((col as f64 + 0.5) / self.width as f64, (row as f64 + 0.5) / self.height as f64)
    }

    /// Nearest-texel lookup.
    pub fn lookup_nearest(&self, d: [f64; 3]) -> [f32; 3] {
        let (u, v) = latlong_uv(d);
        let col = ((u * self.width as f64) as usize).min(self.width - 1);
        let row = ((v * self.height as f64) as usize).min(self.height - 1);
        self.texel(col, row)
    }

    /// Bilinear lookup (wrapping in u, clamped in v), matching a GPU sampler with
    /// REPEAT in u and CLAMP_TO_EDGE in v.
    pub fn lookup_bilinear(&self, d: [f64; 3]) -> [f64; 3] {
        let (u, v) = latlong_uv(d);
        let y = v * self.height as f64 - 0.5;
        bilinear_wrap_u(|c, r| self.texel(c, r), self.width, self.height, u * self.width as f64 - 0.5, y)
    }

    /// This map rotated about +y by `degrees`: every row shifts by `degrees / 360` of its width,
    /// interpolating linearly between columns (a whole-texel shift is exact; 360° is the identity).
    pub fn rotated_y(&self, degrees: f32) -> Self {
        let w = self.width;
        if w == 0 {
            return self.clone();
        }
        let shift = (degrees as f64 / 360.0).rem_euclid(1.0) * w as f64;
        let (whole, frac) = (shift.floor() as usize % w, (shift - shift.floor()) as f32);
        let mut texels = self.texels.clone();
        for y in 0..self.height {
            for x in 0..w {
                let a = self.texels[y * w + (x + w - whole) % w];
                let b = self.texels[y * w + (x + 2 * w - whole - 1) % w];
                texels[y * w + x] = [0, 1, 2].map(|c| (1.0 - frac) * a[c] + frac * b[c]);
            }
        }
        Self { width: w, height: self.height, texels }
    }

    /// Downsample by an integer box filter weighted by texel solid angle (keeps the integral).
    pub fn downsample(&self, factor: usize) -> Self {
        assert!(factor >= 1 && self.width.is_multiple_of(factor) && self.height.is_multiple_of(factor));
        let (w, h) = (self.width / factor, self.height / factor);
        // Every texel of a row has the same solid angle: one weight per source row.
        let row_sa: Vec<f64> = (0..self.height).map(|r| texel_solid_angle(r, self.width, self.height)).collect();
        let mut texels = vec![[0.0f32; 3]; w * h];
        let mut acc = vec![[0.0f64; 3]; w];
        for row in 0..h {
            acc.iter_mut().for_each(|a| *a = [0.0; 3]);
            let mut wsum = 0.0;
            for sr in 0..factor {
                let r = row * factor + sr;
                let sa = row_sa[r];
                let src = &self.texels[r * self.width..(r + 1) * self.width];
                for (col, a) in acc.iter_mut().enumerate() {
                    for t in &src[col * factor..(col + 1) * factor] {
                        for k in 0..3 {
                            a[k] += t[k] as f64 * sa;
                        }
                    }
                }
                wsum += sa * factor as f64;
            }
            for (col, a) in acc.iter().enumerate() {
                texels[row * w + col] = a.map(|x| (x / wsum) as f32);
            }
        }
        Self { width: w, height: h, texels }
    }

    /// ∫ L(ω) dω per channel, by texel solid angles.
    pub fn integral(&self) -> [f64; 3] {
        let mut acc = [0.0; 3];
        for row in 0..self.height {
            let sa = texel_solid_angle(row, self.width, self.height);
            for col in 0..self.width {
                let t = self.texel(col, row);
                for k in 0..3 {
                    acc[k] += t[k] as f64 * sa;
                }
            }
        }
        acc
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bilinear_clamp_interpolates_between_centres_and_clamps_at_edges() {
        let g = [0.0f32, 1.0, 2.0, 3.0]; // 2 × 2: row 0 = (0, 1), row 1 = (2, 3)
        let f = |x: f64, y: f64| bilinear_clamp(|c, r| g[r * 2 + c], 2, 2, x, y);
        assert_eq!(f(0.0, 0.0), 0.0);
        assert_eq!(f(1.0, 1.0), 3.0);
        assert!((f(0.5, 0.5) - 1.5).abs() < 1e-12);
        assert!((f(0.25, 1.0) - 2.25).abs() < 1e-12);
        assert_eq!(f(-3.0, 9.0), 2.0, "clamped to the corner texel");
        assert_eq!(bilinear_clamp(|_, _| 0.7, 1, 1, 0.4, -2.0), 0.7f32 as f64);
    }

    #[test]
    fn direction_uv_round_trip() {
        for &(u, v) in &[(0.1, 0.2), (0.75, 0.5), (0.99, 0.9), (0.5, 0.01)] {
            let (u2, v2) = latlong_uv(latlong_direction(u, v));
            assert!((u - u2).abs() < 1e-12 && (v - v2).abs() < 1e-12);
        }
        let up = latlong_direction(0.3, 0.0);
        assert!((up[1] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn solid_angles_sum_to_sphere() {
        let (w, h) = (64, 32);
        let total: f64 = (0..h).map(|r| texel_solid_angle(r, w, h) * w as f64).sum();
        assert!((total - 4.0 * PI).abs() < 1e-12);
        let m = LatLongMap::constant(w, h, [2.0, 2.0, 2.0]);
        assert!((m.integral()[0] - 8.0 * PI).abs() < 1e-9);
        assert!((m.downsample(4).integral()[1] - 8.0 * PI).abs() < 1e-9);
    }
}
