//! Lights from the environment: the bright, compact regions of an equirectangular map as spherical lights,
//! and a residual map holding the rest (DESIGN §7; the sun-extraction way, with median-cut splits of
//! regions too wide to be one light, after Debevec 2005).
//!
//! # The decomposition
//! 1. **Detection** on a copy box-filtered to at most [`DETECTION_WIDTH`] texels across (solid-angle
//!    weighted: [`LatLongMap::downsample`]): a texel is *bright* when its luminance exceeds `threshold` times
//!    the map's mean radiance (total power / 4π). Bright texels are joined into 8-connected regions on the
//!    sphere (wrapping across the seam, and across each pole).
//! 2. **Fill.** Each region gets the solid-angle-weighted mean RGB of the texels around it (its border):
//!    what the map would hold there without the bright source. Inside a region the residual is
//!    `min(texel, fill)` per channel and the *excess* `texel − residual` goes to the lights, so the
//!    residual is continuous with its surroundings and nothing is negative.
//! 3. **Compactness.** A region's spread is the excess-weighted moment `m = E[1 − d·ω]` about its mean
//!    direction d (plus each texel's own extent, `Ω_texel / 4π`); a uniform cap of half-angle α has
//!    `m = (1 − cos α)/2`, so the region's angular radius is `α = acos(1 − 2m)`. A region wider than
//!    `max_radius` is cut in two at the excess-weighted median along its wider axis (in the tangent plane at
//!    d) until every piece is compact enough; each piece is a candidate light.
//! 4. **Selection.** A candidate qualifies when its excess holds at least `min_share` of the map's power;
//!    the `max_lights` largest qualifying candidates become lights. Fewer qualifying candidates than asked
//!    for: the decomposition stops there and says so ([`EnvDecomposition::note`]).
//! 5. **The lights**, from the full-resolution texels of each selected piece: direction d (the
//!    excess-weighted mean), half-angle α (the moment match above), radiance `L = power / Ω_cap` per channel,
//!    `Ω_cap = 2π(1 − cos α)`, so a light's power is exactly its piece's excess.
//!
//! **Nothing is counted twice:** the residual plus the lights' power equals the map's power per channel
//! (to rounding), and unshadowed, a light stands in for its piece with the same power, mean direction and
//! spread (the difference is of second order in the piece's size: tested per pixel with `none` in
//! tests/tests/env_lights.rs). Pieces not selected stay in the residual unchanged.
//!
//! Hard cases: a black map or a map with no power gives no lights and the map itself as residual (no
//! division by zero); a constant map has no texel above its mean, so no lights; `max_lights = 0` changes
//! nothing; a map that is one bright texel gives one light of that texel's power and size and a black
//! residual. Non-finite texels are treated as black by the detection (the loaders refuse or repair them).

use crate::envmap::{latlong_direction, texel_solid_angle, LatLongMap};
use std::f64::consts::PI;

/// The detection copy is at most this many texels wide (the map is box-filtered down by an integer factor).
pub const DETECTION_WIDTH: usize = 256;

/// The most lights a decomposition makes.
pub const MAX_ENV_LIGHTS: usize = 16;

/// Rec. 709 luminance of linear RGB.
pub fn luminance(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// How a map is split (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvLightParams {
    /// At most this many lights (K); 0: no decomposition.
    pub max_lights: usize,
    /// A texel is bright above this many times the map's mean radiance (> 1 keeps a constant map whole).
    pub threshold: f64,
    /// A light must carry at least this share of the map's power (luminance, 0..1).
    pub min_share: f64,
    /// Regions wider than this angular radius (radians) are split into pieces.
    pub max_radius: f64,
}

impl Default for EnvLightParams {
    fn default() -> Self {
        Self { max_lights: 8, threshold: 4.0, min_share: 0.01, max_radius: 15f64.to_radians() }
    }
}

impl EnvLightParams {
    /// Each field in its range, or a message naming the bad one.
    pub fn check(&self) -> Result<(), String> {
        if self.max_lights > MAX_ENV_LIGHTS {
            return Err(format!("environment lights: K = {} (at most {MAX_ENV_LIGHTS})", self.max_lights));
        }
        if !(self.threshold.is_finite() && self.threshold > 1.0 && self.threshold <= 1e6) {
            return Err(format!(
                "environment lights: threshold {} (a number of times the mean radiance in (1, 1e6])",
                self.threshold
            ));
        }
        if !(self.min_share.is_finite() && self.min_share > 0.0 && self.min_share <= 1.0) {
            return Err(format!("environment lights: share {} (a fraction of the power in (0, 1])", self.min_share));
        }
        if !(self.max_radius.is_finite() && self.max_radius > 0.0 && self.max_radius <= PI / 2.0) {
            return Err(format!(
                "environment lights: radius {}° (an angle in (0, 90] degrees)",
                self.max_radius.to_degrees()
            ));
        }
        Ok(())
    }
}

/// One light taken from the map: a uniform cap seen from the scene's centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvLight {
    /// Unit direction of the cap's axis (the map's convention: +Y is row 0).
    pub direction: [f64; 3],
    /// Half-angle α of the cap (radians).
    pub half_angle: f64,
    /// Radiance over the cap, linear RGB.
    pub radiance: [f64; 3],
    /// Its share of the map's power (luminance).
    pub share: f64,
}

impl EnvLight {
    /// Solid angle of the cap, 2π(1 − cos α), without cancellation for small α.
    pub fn solid_angle(&self) -> f64 {
        4.0 * PI * (self.half_angle / 2.0).sin().powi(2)
    }

    /// ∫ over the cap of the radiance, per channel.
    pub fn power(&self) -> [f64; 3] {
        let o = self.solid_angle();
        self.radiance.map(|l| l * o)
    }

    /// The sphere that subtends this cap from `center` at `distance`: its centre and radius
    /// (`distance · sin α`). Far enough that a scene of radius R ≪ distance sees it in the same direction
    /// from every point (parallax R/distance).
    pub fn sphere(&self, center: [f64; 3], distance: f64) -> ([f64; 3], f64) {
        let c = [0, 1, 2].map(|k| center[k] + distance * self.direction[k]);
        (c, distance * self.half_angle.sin())
    }
}

/// The lights and the residual (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvDecomposition {
    /// Largest share first.
    pub lights: Vec<EnvLight>,
    /// The residual as the texels that differ from the map: (texel index, residual value), the lights'
    /// pieces only (a small part of the map; [`EnvDecomposition::residual`] applies them to a copy).
    pub edits: Vec<(u32, [f32; 3])>,
    /// Candidates that qualified (by share); `lights.len()` is the smaller of this and K.
    pub qualified: usize,
    /// Bright regions found before splitting and qualifying.
    pub regions: usize,
    /// Share of the map's power (luminance) moved into the lights.
    pub share: f64,
    /// Set when fewer lights were found than asked for (the decomposition stopped early), for the user.
    pub note: Option<String>,
}

impl EnvDecomposition {
    /// The residual map: `map` (the one decomposed) with the lights' excess taken out.
    pub fn residual(&self, map: &LatLongMap) -> LatLongMap {
        let mut r = map.clone();
        for &(i, t) in &self.edits {
            r.texels[i as usize] = t;
        }
        r
    }
}

/// One bright texel of the detection copy, with its excess over its region's fill.
#[derive(Clone, Copy)]
struct Texel {
    index: usize,
    dir: [f64; 3],
    /// Luminance of the excess × solid angle.
    weight: f64,
    solid_angle: f64,
}

/// Excess-weighted mean direction, angular radius (moment match) and total weight of a set of texels.
fn spread(texels: &[Texel]) -> ([f64; 3], f64, f64) {
    let mut sum = [0.0; 3];
    let (mut w, mut extent) = (0.0, 0.0);
    for t in texels {
        for (s, d) in sum.iter_mut().zip(t.dir) {
            *s += t.weight * d;
        }
        w += t.weight;
        extent += t.weight * t.solid_angle / (4.0 * PI);
    }
    if w <= 0.0 {
        return ([0.0, 1.0, 0.0], 0.0, 0.0);
    }
    let len = (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt();
    let d = if len > 0.0 { sum.map(|s| s / len) } else { [0.0, 1.0, 0.0] };
    // m = E[1 − d·ω] = 1 − |E[ω]| (d is E[ω]'s direction), plus the texels' own extent.
    let m = ((1.0 - len / w) + extent / w).clamp(0.0, 1.0);
    (d, (1.0 - 2.0 * m).clamp(-1.0, 1.0).acos(), w)
}

/// Cut `texels` into pieces of angular radius ≤ `max_radius` at excess-weighted medians (median cut).
fn split_compact(mut texels: Vec<Texel>, max_radius: f64, out: &mut Vec<Vec<Texel>>) {
    // At most 64 pieces a region: beyond that the pieces are far below any useful share.
    let mut stack = vec![std::mem::take(&mut texels)];
    while let Some(piece) = stack.pop() {
        let (d, alpha, w) = spread(&piece);
        if alpha <= max_radius || piece.len() < 2 || w <= 0.0 || out.len() + stack.len() >= 63 {
            out.push(piece);
            continue;
        }
        // Tangent frame at d; project and split along the axis of larger weighted variance.
        let up = if d[1].abs() < 0.9 { [0.0, 1.0, 0.0] } else { [1.0, 0.0, 0.0] };
        let e1 = normalize(cross(up, d));
        let e2 = cross(d, e1);
        let coord = |t: &Texel, e: [f64; 3]| t.dir[0] * e[0] + t.dir[1] * e[1] + t.dir[2] * e[2];
        let var = |e: [f64; 3]| {
            let mean: f64 = piece.iter().map(|t| t.weight * coord(t, e)).sum::<f64>() / w;
            piece.iter().map(|t| t.weight * (coord(t, e) - mean).powi(2)).sum::<f64>()
        };
        let axis = if var(e1) >= var(e2) { e1 } else { e2 };
        let mut piece = piece;
        piece.sort_by(|a, b| coord(a, axis).total_cmp(&coord(b, axis)));
        let mut acc = 0.0;
        let cut = piece
            .iter()
            .position(|t| {
                acc += t.weight;
                acc >= 0.5 * w
            })
            .unwrap_or(piece.len() / 2)
            .clamp(0, piece.len() - 2)
            + 1;
        let rest = piece.split_off(cut);
        stack.push(piece);
        stack.push(rest);
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt().max(f64::MIN_POSITIVE);
    a.map(|x| x / l)
}

/// The integer box-filter factor that brings `map` to at most [`DETECTION_WIDTH`] texels across (1 when
/// no factor divides both sides).
fn detection_factor(map: &LatLongMap) -> usize {
    (1..=map.width)
        .find(|&f| map.width / f <= DETECTION_WIDTH && map.width.is_multiple_of(f) && map.height.is_multiple_of(f))
        .unwrap_or(1)
}

/// The 8 neighbours of texel (c, r) on the sphere: wrapping in columns, and across the pole in the first
/// and last row (the texel half a turn away).
fn neighbours(c: usize, r: usize, w: usize, h: usize) -> impl Iterator<Item = (usize, usize)> {
    let mut out = Vec::with_capacity(9);
    for dr in -1i64..=1 {
        for dc in -1i64..=1 {
            if dr == 0 && dc == 0 {
                continue;
            }
            let rr = r as i64 + dr;
            if rr < 0 || rr >= h as i64 {
                continue;
            }
            out.push(((c as i64 + dc).rem_euclid(w as i64) as usize, rr as usize));
        }
    }
    if r == 0 || r + 1 == h {
        out.push(((c + w / 2) % w, r));
    }
    out.into_iter()
}

/// Split `map` into at most `params.max_lights` lights and a residual (see the module docs).
pub fn decompose(map: &LatLongMap, params: &EnvLightParams) -> EnvDecomposition {
    let whole = |note: Option<String>, regions| EnvDecomposition {
        lights: Vec::new(),
        edits: Vec::new(),
        qualified: 0,
        regions,
        share: 0.0,
        note,
    };
    if params.max_lights == 0 || map.width == 0 || map.height == 0 {
        return whole(None, 0);
    }
    let f = detection_factor(map);
    let low = if f > 1 { map.downsample(f) } else { map.clone() };
    let (w, h) = (low.width, low.height);
    let lum: Vec<f64> = low
        .texels
        .iter()
        .map(|t| {
            let l = luminance(t.map(|c| c as f64));
            if l.is_finite() {
                l.max(0.0)
            } else {
                0.0
            }
        })
        .collect();
    let row_sa: Vec<f64> = (0..h).map(|r| texel_solid_angle(r, w, h)).collect();
    let total: f64 = lum.iter().enumerate().map(|(i, l)| l * row_sa[i / w]).sum();
    if !(total > 0.0 && total.is_finite()) {
        return whole(Some("the environment has no power: no lights".into()), 0);
    }
    let tau = params.threshold * total / (4.0 * PI);
    // 1. Regions: 8-connected bright texels.
    let mut label = vec![usize::MAX; w * h];
    let mut regions: Vec<Vec<usize>> = Vec::new();
    for start in 0..w * h {
        if lum[start] <= tau || label[start] != usize::MAX {
            continue;
        }
        let id = regions.len();
        let mut members = vec![start];
        label[start] = id;
        let mut k = 0;
        while k < members.len() {
            let i = members[k];
            k += 1;
            for (c, r) in neighbours(i % w, i / w, w, h) {
                let j = r * w + c;
                if lum[j] > tau && label[j] == usize::MAX {
                    label[j] = id;
                    members.push(j);
                }
            }
        }
        regions.push(members);
    }
    // 2–3. Fill per region (its border's mean), excess weights, compact pieces.
    let mut fills: Vec<[f64; 3]> = Vec::with_capacity(regions.len());
    let mut pieces: Vec<(usize, Vec<Texel>)> = Vec::new();
    for (id, members) in regions.iter().enumerate() {
        let (mut sum, mut sa) = ([0.0; 3], 0.0);
        let mut seen = std::collections::HashSet::new();
        for &i in members {
            for (c, r) in neighbours(i % w, i / w, w, h) {
                let j = r * w + c;
                if label[j] != id && seen.insert(j) {
                    let t = low.texels[j];
                    for k in 0..3 {
                        sum[k] += t[k] as f64 * row_sa[r];
                    }
                    sa += row_sa[r];
                }
            }
        }
        let fill = if sa > 0.0 { sum.map(|s| (s / sa).max(0.0)) } else { [0.0; 3] };
        fills.push(fill);
        let texels: Vec<Texel> = members
            .iter()
            .map(|&i| {
                let t = low.texels[i].map(|c| c as f64);
                let excess = [0, 1, 2].map(|k| (t[k] - t[k].min(fill[k])).max(0.0));
                let (c, r) = (i % w, i / w);
                Texel {
                    index: i,
                    dir: latlong_direction((c as f64 + 0.5) / w as f64, (r as f64 + 0.5) / h as f64),
                    weight: luminance(excess) * row_sa[r],
                    solid_angle: row_sa[r],
                }
            })
            .collect();
        let mut out = Vec::new();
        split_compact(texels, params.max_radius, &mut out);
        pieces.extend(out.into_iter().map(|p| (id, p)));
    }
    // 4. Qualify and select.
    let mut candidates: Vec<(f64, usize)> = pieces
        .iter()
        .enumerate()
        .map(|(k, (_, p))| (p.iter().map(|t| t.weight).sum::<f64>() / total, k))
        .filter(|&(s, _)| s >= params.min_share)
        .collect();
    candidates.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let qualified = candidates.len();
    candidates.truncate(params.max_lights);
    // 5. Full resolution: residual = min(texel, fill) inside the selected pieces; the lights from the excess.
    let mut edits: Vec<(u32, [f32; 3])> = Vec::new();
    let mut lights = Vec::with_capacity(candidates.len());
    let full_sa: Vec<f64> = (0..map.height).map(|r| texel_solid_angle(r, map.width, map.height)).collect();
    // Texel directions from per-row (sin θ, cos θ) and per-column (cos φ, sin φ): no trigonometry per texel.
    let rows: Vec<(f64, f64)> =
        (0..map.height).map(|r| (PI * (r as f64 + 0.5) / map.height as f64).sin_cos()).collect();
    let cols: Vec<(f64, f64)> = (0..map.width)
        .map(|c| {
            let (s, co) = (2.0 * PI * (c as f64 + 0.5) / map.width as f64).sin_cos();
            (co, s)
        })
        .collect();
    let mut moved = 0.0;
    for &(_, k) in &candidates {
        let (region, piece) = &pieces[k];
        let fill = fills[*region];
        let (mut power, mut sum, mut lw, mut extent) = ([0.0; 3], [0.0; 3], 0.0, 0.0);
        for t in piece {
            let (lc, lr) = (t.index % w, t.index / w);
            for r in lr * f..(lr + 1) * f {
                for (c, &(cp, sp)) in cols.iter().enumerate().take((lc + 1) * f).skip(lc * f) {
                    let index = r * map.width + c;
                    let orig = map.texels[index].map(|x| if x.is_finite() { x.max(0.0) as f64 } else { 0.0 });
                    let kept = [0, 1, 2].map(|k| orig[k].min(fill[k]) as f32);
                    edits.push((index as u32, kept));
                    // The excess as stored (f32 rounding of `kept` included), so the sum is conserved.
                    let excess = [0, 1, 2].map(|k| (orig[k] - kept[k] as f64).max(0.0));
                    let sa = full_sa[r];
                    let weight = luminance(excess) * sa;
                    let (st, ct) = rows[r];
                    let dir = [st * cp, ct, st * sp];
                    for (k, (p, s)) in power.iter_mut().zip(sum.iter_mut()).enumerate() {
                        *p += excess[k] * sa;
                        *s += weight * dir[k];
                    }
                    lw += weight;
                    extent += weight * sa / (4.0 * PI);
                }
            }
        }
        if lw <= 0.0 {
            continue;
        }
        let len = (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt();
        let direction = if len > 0.0 { sum.map(|s| s / len) } else { [0.0, 1.0, 0.0] };
        // Moment match (module docs); at least the texels' own extent, at most a hemisphere.
        let m = ((1.0 - len / lw) + extent / lw).clamp(1e-12, 0.5);
        let half_angle = (1.0 - 2.0 * m).clamp(-1.0, 1.0).acos();
        let cap = 4.0 * PI * m; // 2π(1 − cos α) with 1 − cos α = 2m
        moved += lw;
        lights.push(EnvLight { direction, half_angle, radiance: power.map(|p| p / cap), share: lw / total });
    }
    lights.sort_by(|a, b| b.share.total_cmp(&a.share));
    let note = (lights.len() < params.max_lights).then(|| {
        format!(
            "environment lights: {} asked for, {} found ({} bright region(s) above {}x the mean radiance, {} \
             piece(s) with at least {:.1} % of the power)",
            params.max_lights,
            lights.len(),
            regions.len(),
            params.threshold,
            qualified,
            100.0 * params.min_share
        )
    });
    EnvDecomposition { lights, edits, qualified, regions: regions.len(), share: moved / total, note }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::envmap::latlong_uv;

    /// A dim sky with one bright disc of half-angle `alpha` about `dir`.
    fn sky_with_sun(w: usize, h: usize, dir: [f64; 3], alpha: f64, sun: f32) -> LatLongMap {
        let mut m = LatLongMap::constant(w, h, [0.2, 0.3, 0.5]);
        for r in 0..h {
            for c in 0..w {
                let d = m.texel_direction(c, r);
                if d[0] * dir[0] + d[1] * dir[1] + d[2] * dir[2] >= alpha.cos() {
                    m.texels[r * w + c] = [sun, sun * 0.9, sun * 0.7];
                }
            }
        }
        m
    }

    fn assert_conserved(map: &LatLongMap, d: &EnvDecomposition, tol: f64) {
        let orig = map.integral();
        let res = d.residual(map).integral();
        for k in 0..3 {
            let lights: f64 = d.lights.iter().map(|l| l.power()[k]).sum();
            let sum = res[k] + lights;
            assert!((sum - orig[k]).abs() <= tol * orig[k].max(1e-30), "channel {k}: {sum} vs {}", orig[k]);
        }
        assert!(d.residual(map).texels.iter().flatten().all(|c| c.is_finite() && *c >= 0.0));
    }

    #[test]
    fn a_sun_becomes_one_light_in_its_direction_and_size() {
        let dir = normalize([0.4, 0.6, -0.3]);
        let alpha = 0.05;
        let map = sky_with_sun(512, 256, dir, alpha, 500.0);
        let d = decompose(&map, &EnvLightParams::default());
        assert_eq!(d.lights.len(), 1, "{d:?}");
        let l = d.lights[0];
        let cos = l.direction[0] * dir[0] + l.direction[1] * dir[1] + l.direction[2] * dir[2];
        assert!(cos > (0.005f64).cos(), "direction off by {} rad", cos.acos());
        assert!((l.half_angle - alpha).abs() < 0.1 * alpha, "half-angle {} vs {alpha}", l.half_angle);
        // The sun's excess over the sky (500 − 0.2 etc.) is its radiance, to the discretisation.
        assert!((l.radiance[0] / (500.0 - 0.2) - 1.0).abs() < 0.25, "{:?}", l.radiance);
        // Its share: the disc's excess luminance power over the map's.
        let disc = luminance([500.0 - 0.2, 450.0 - 0.3, 350.0 - 0.5]) * 2.0 * PI * (1.0 - alpha.cos());
        let want = disc / luminance(map.integral());
        assert!((d.share / want - 1.0).abs() < 0.1, "share {} vs {want}", d.share);
        assert_conserved(&map, &d, 1e-6);
        // The residual is the sky where the sun was.
        let (u, v) = latlong_uv(dir);
        let t = d.residual(&map).texel((u * 512.0) as usize, (v * 256.0) as usize);
        assert!((t[0] - 0.2).abs() < 1e-6 && (t[2] - 0.5).abs() < 1e-6, "{t:?}");
        assert_eq!(d.note.as_deref().map(|n| n.contains("8 asked for, 1 found")), Some(true), "{:?}", d.note);
    }

    #[test]
    fn black_constant_and_k0_maps_give_no_lights() {
        let black = LatLongMap::constant(64, 32, [0.0; 3]);
        let d = decompose(&black, &EnvLightParams::default());
        assert!(d.lights.is_empty() && d.edits.is_empty() && d.note.is_some());
        let constant = LatLongMap::constant(64, 32, [1.0, 2.0, 3.0]);
        let d = decompose(&constant, &EnvLightParams::default());
        assert!(d.lights.is_empty() && d.edits.is_empty() && d.regions == 0);
        let sun = sky_with_sun(128, 64, [0.0, 1.0, 0.0], 0.2, 100.0);
        let d = decompose(&sun, &EnvLightParams { max_lights: 0, ..Default::default() });
        assert!(d.lights.is_empty() && d.edits.is_empty() && d.note.is_none());
    }

    #[test]
    fn one_bright_texel_is_one_light_and_a_black_residual() {
        let mut map = LatLongMap::constant(64, 32, [0.0; 3]);
        map.texels[10 * 64 + 20] = [1e4, 2e4, 3e4];
        let d = decompose(&map, &EnvLightParams::default());
        assert_eq!(d.lights.len(), 1);
        assert!(d.residual(&map).texels.iter().all(|t| *t == [0.0; 3]));
        assert_conserved(&map, &d, 1e-6);
        // Its cap has the texel's solid angle (the moment of a single texel is its own extent).
        let sa = texel_solid_angle(10, 64, 32);
        assert!((d.lights[0].solid_angle() / sa - 1.0).abs() < 1e-6);
        let dir = map.texel_direction(20, 10);
        let cos: f64 = (0..3).map(|k| d.lights[0].direction[k] * dir[k]).sum();
        assert!(cos > 1.0 - 1e-9);
    }

    #[test]
    fn a_wide_region_is_split_into_compact_lights_and_the_count_is_capped() {
        // A bright band 60° wide: more than one 15° light.
        let map = sky_with_sun(256, 128, [1.0, 0.0, 0.0], 30f64.to_radians(), 50.0);
        let p = EnvLightParams { max_lights: 16, ..Default::default() };
        let d = decompose(&map, &p);
        assert!(d.lights.len() >= 4, "{} lights", d.lights.len());
        for l in &d.lights {
            assert!(l.half_angle <= 1.25 * p.max_radius, "{}° wide", l.half_angle.to_degrees());
        }
        assert_conserved(&map, &d, 1e-6);
        let two = decompose(&map, &EnvLightParams { max_lights: 2, ..p });
        assert_eq!(two.lights.len(), 2);
        assert!(two.note.is_none() && two.qualified >= 4);
        assert_conserved(&map, &two, 1e-6);
        // The two kept are the largest.
        assert!(two.lights[0].share >= d.lights[3].share);
    }

    #[test]
    fn regions_join_across_the_seam_and_the_pole() {
        // A disc centred on the seam (u = 0) and one on the zenith: one light each, not two halves.
        for dir in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            let map = sky_with_sun(256, 128, dir, 0.1, 300.0);
            let d = decompose(&map, &EnvLightParams::default());
            assert_eq!(d.regions, 1, "{dir:?}");
            assert_eq!(d.lights.len(), 1, "{dir:?}");
            let cos: f64 = (0..3).map(|k| d.lights[0].direction[k] * dir[k]).sum();
            assert!(cos > 0.9995, "{dir:?}: {cos}");
        }
    }

    #[test]
    fn params_are_checked() {
        assert!(EnvLightParams::default().check().is_ok());
        for bad in [
            EnvLightParams { max_lights: 17, ..Default::default() },
            EnvLightParams { threshold: 1.0, ..Default::default() },
            EnvLightParams { threshold: f64::NAN, ..Default::default() },
            EnvLightParams { min_share: 0.0, ..Default::default() },
            EnvLightParams { max_radius: 2.0, ..Default::default() },
        ] {
            assert!(bad.check().is_err(), "{bad:?}");
        }
    }

    #[test]
    fn a_light_sphere_subtends_its_cap_from_the_centre() {
        let l = EnvLight { direction: [0.0, 0.0, 1.0], half_angle: 0.3, radiance: [1.0; 3], share: 0.5 };
        let (c, r) = l.sphere([1.0, 2.0, 3.0], 100.0);
        assert_eq!(c, [1.0, 2.0, 103.0]);
        assert!((r / 100.0 - 0.3f64.sin()).abs() < 1e-12);
        assert!((l.solid_angle() - 2.0 * PI * (1.0 - 0.3f64.cos())).abs() < 1e-12);
    }
}
