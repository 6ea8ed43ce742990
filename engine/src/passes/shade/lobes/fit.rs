//! The per-depth light leaf weights w_d, fitted once against the exact answer (paper §5.3, Eq. 39: the paper
//! set its w_i(dist, depth) by hand). Calibration: receivers on a plane under one blocker sphere and one
//! spherical light (several sizes and heights), the diffuse light term of the f64 twin
//! ([`super::cpu::Twin::light_terms`]) against the exact one (the cap integrated by quadrature with an exact
//! ray–sphere test). The twin's S is linear in the weights (`LightTerms::s_by_depth`), so the fit is a
//! least-squares solve, regularized towards 1.

use super::cpu::{Twin, TwinBvh, TwinLight, TwinReceiver};
use super::{LobesOptions, WEIGHT_DEPTHS};
use engine_blockers::geom::Sphere;
use glam::DVec3;
use std::f64::consts::PI;

/// One calibration set-up: a blocker sphere over the plane y = 0 and a spherical light.
#[derive(Clone, Copy, Debug)]
pub struct Setup {
    pub blocker: Sphere,
    pub light_center: DVec3,
    pub light_radius: f64,
}

/// The calibration set-ups (blockers low and high, small and large; lights small and large, overhead and
/// slanted).
pub fn setups() -> Vec<Setup> {
    let mut out = Vec::new();
    for (bh, br) in [(0.35, 0.25), (0.8, 0.3), (0.5, 0.12)] {
        for (lc, lr) in
            [(DVec3::new(0.0, 2.5, 0.0), 0.3), (DVec3::new(-1.2, 2.2, 0.6), 0.15), (DVec3::new(0.6, 3.0, -0.4), 0.6)]
        {
            out.push(Setup { blocker: Sphere::new(DVec3::new(0.0, bh, 0.0), br), light_center: lc, light_radius: lr });
        }
    }
    out
}

/// The exact light term at `p` (normal +y) for f_r = 1 (ρ = π) and radiance 1: ∫_cap (n·ω)⁺ V(ω) dω by the
/// midpoint rule over (cos θ, φ) about the light's axis, `k` × 4k cells.
pub fn exact_light(p: DVec3, s: &Setup, k: usize) -> f64 {
    let d = s.light_center - p;
    let dist = d.length();
    if dist <= s.light_radius {
        return 0.0;
    }
    let a = d / dist;
    let cos_max = ((dist - s.light_radius) * (dist + s.light_radius)).max(0.0).sqrt() / dist;
    let (t, b) = a.any_orthonormal_pair();
    let (nc, np) = (k, 4 * k);
    let mut sum = 0.0;
    for i in 0..nc {
        let c = 1.0 - (1.0 - cos_max) * (i as f64 + 0.5) / nc as f64;
        let sn = (1.0 - c * c).max(0.0).sqrt();
        for j in 0..np {
            let ph = 2.0 * PI * (j as f64 + 0.5) / np as f64;
            let w = a * c + (t * ph.cos() + b * ph.sin()) * sn;
            let cos_n = w.y;
            if cos_n <= 0.0 || s.blocker.ray_hits(p, w) {
                continue;
            }
            sum += cos_n;
        }
    }
    sum * (1.0 - cos_max) * 2.0 * PI / (nc * np) as f64
}

/// One receiver's row: the twin's U, its S by depth (unit weights), and the exact term; and the receiver's
/// distances to the light's and the blocker's centres in their radii (the candidate `dist` of Eq. 39).
#[derive(Clone, Debug)]
pub struct Row {
    pub u: f64,
    pub s_by_depth: [f64; WEIGHT_DEPTHS],
    pub exact: f64,
    pub light_dist: f64,
    pub blocker_dist: f64,
}

/// The calibration rows of `options` (its light weights are ignored: unit weights, no pruning) over a
/// `grid` × `grid` square of receivers of half-side 1.5 under each set-up.
pub fn rows(options: &LobesOptions, grid: usize, quad: usize) -> Result<Vec<Row>, String> {
    let o = LobesOptions { light_weights: [1.0; WEIGHT_DEPTHS], threshold: 0.0, ..options.clone() };
    let twin = Twin::new(&o).map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    for s in setups() {
        let bvh = TwinBvh::new(&[s.blocker])?;
        let light = TwinLight { center: s.light_center, radius: s.light_radius, radiance: [1.0; 3] };
        for i in 0..grid {
            for j in 0..grid {
                let x = -1.5 + 3.0 * (i as f64 + 0.5) / grid as f64;
                let z = -1.5 + 3.0 * (j as f64 + 0.5) / grid as f64;
                let p = DVec3::new(x, 0.0, z);
                let r = TwinReceiver { p, n: DVec3::Y, view: DVec3::Y, rho: [PI; 3], specular: Vec::new() };
                let t = twin.light_terms(&r, &light, &bvh, &[]);
                if !t.outside || t.hidden {
                    continue;
                }
                out.push(Row {
                    u: t.u[1],
                    s_by_depth: t.s_by_depth,
                    exact: exact_light(p, &s, quad),
                    light_dist: (s.light_center - p).length() / s.light_radius,
                    blocker_dist: (s.blocker.center - p).length() / s.blocker.radius,
                });
            }
        }
    }
    Ok(out)
}

/// Relative RMSE of max(U − Σ_d w_d S_d, 0) against the exact terms.
pub fn error(rows: &[Row], w: &[f64; WEIGHT_DEPTHS]) -> f64 {
    let (num, den) = squared_errors(rows, w);
    (num / den.max(1e-300)).sqrt()
}

/// Σ (max(U − Σ_d w_d S_d, 0) − exact)² and Σ exact².
fn squared_errors(rows: &[Row], w: &[f64; WEIGHT_DEPTHS]) -> (f64, f64) {
    let (mut num, mut den) = (0.0, 0.0);
    for r in rows {
        let s: f64 = (0..WEIGHT_DEPTHS).map(|d| w[d] * r.s_by_depth[d]).sum();
        let e = (r.u - s).max(0.0) - r.exact;
        num += e * e;
        den += r.exact * r.exact;
    }
    (num, den)
}

/// What weights w(depth, dist) could gain over per-depth weights: the rows split into octaves of `dist(row)`
/// (bins [2^k, 2^(k+1))), each bin fitted on its own, and the relative RMSE of all rows with their bin's
/// weights. Fitted and scored on the same rows, so it bounds from above what a table over those bins would
/// gain on them. Returns (bins, error).
pub fn binned_error(rows: &[Row], dist: impl Fn(&Row) -> f64) -> (usize, f64) {
    let mut bins: std::collections::BTreeMap<i32, Vec<Row>> = Default::default();
    for r in rows {
        bins.entry(dist(r).max(1e-9).log2().floor() as i32).or_default().push(r.clone());
    }
    let (mut num, mut den) = (0.0, 0.0);
    for rows in bins.values() {
        let (n, d) = squared_errors(rows, &fit(rows, LAMBDA));
        num += n;
        den += d;
    }
    (bins.len(), (num / den.max(1e-300)).sqrt())
}

/// Least squares for w (index loops: the normal equations read clearer that way): minimize Σ (U − Σ_d w_d S_d − exact)² + λ Σ_d (w_d − 1)² (λ scaled by the
/// regressors' mean square; depths no leaf reached keep 1), weights clamped to [0, 4].
#[allow(clippy::needless_range_loop)]
pub fn fit(rows: &[Row], lambda: f64) -> [f64; WEIGHT_DEPTHS] {
    const N: usize = WEIGHT_DEPTHS;
    let mut a = [[0.0; N]; N];
    let mut y = [0.0; N];
    for r in rows {
        let target = r.u - r.exact;
        for i in 0..N {
            y[i] += r.s_by_depth[i] * target;
            for j in 0..N {
                a[i][j] += r.s_by_depth[i] * r.s_by_depth[j];
            }
        }
    }
    let scale = (0..N).map(|i| a[i][i]).sum::<f64>() / N as f64;
    for i in 0..N {
        let reg = if a[i][i] > 0.0 { lambda * scale } else { 1.0 };
        a[i][i] += reg;
        y[i] += reg;
    }
    engine_math::linalg::solve(a, y).map(|w| w.clamp(0.0, 4.0))
}

/// The fitted table: `assets/tables/lobes_weights.txt` (text, versioned; written by `cargo xtask lobes-weights`).
pub const TABLE_FILE: &str = "lobes_weights.txt";
/// Its format version.
pub const FORMAT: u32 = 1;
/// Calibration resolution: receivers per side of each set-up, quadrature cells (k × 4k) per receiver, and λ.
pub const GRID: usize = 24;
pub const QUAD: usize = 48;
pub const LAMBDA: f64 = 1e-3;

/// The fit at the default options: (weights, rows, calibration error with unit weights, with the fit).
pub fn fit_default() -> Result<([f64; WEIGHT_DEPTHS], usize, f64, f64), String> {
    let rows = rows(&LobesOptions::default(), GRID, QUAD)?;
    let w = fit(&rows, LAMBDA);
    Ok((w, rows.len(), error(&rows, &[1.0; WEIGHT_DEPTHS]), error(&rows, &w)))
}

/// The table's text for `weights`.
pub fn table_text(weights: &[f64; WEIGHT_DEPTHS], rows: usize, uniform: f64, fitted: f64) -> String {
    let o = LobesOptions::default();
    let w: Vec<String> = weights.iter().map(|x| format!("{x:?}")).collect();
    format!(
        "# Per-depth factors of the lobes technique's light leaf weights (index = quad-tree depth 0..6), fitted by\n\
         # `cargo xtask lobes-weights` (engine::passes::shade::lobes::fit) against the exact light term of a plane under\n\
         # one sphere and one spherical light ({} set-ups, {GRID}x{GRID} receivers each, {QUAD}x{} quadrature cells).\n\
         format {FORMAT}\n\
         options depth={} split={} leaves=half extent={} sharpen={} light_scale=energy\n\
         calibration rows={rows} uniform={uniform:?} fitted={fitted:?}\n\
         weights {}\n",
        setups().len(),
        4 * QUAD,
        o.depth,
        o.split,
        o.extent,
        o.sharpen,
        w.join(" ")
    )
}

/// Parse the table (strict: the format version, seven finite weights in [0, 4]); errors name the line.
pub fn parse_table(text: &str) -> Result<[f64; WEIGHT_DEPTHS], String> {
    let mut format = None;
    let mut weights = None;
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (key, rest) = line.split_once(' ').unwrap_or((line, ""));
        match key {
            "format" => {
                format = Some(rest.trim().parse::<u32>().map_err(|_| format!("line {}: bad format '{rest}'", i + 1))?)
            }
            "weights" => {
                let v: Vec<f64> = rest
                    .split_whitespace()
                    .map(|x| x.parse::<f64>().ok().filter(|w| w.is_finite() && (0.0..=4.0).contains(w)))
                    .collect::<Option<_>>()
                    .ok_or_else(|| format!("line {}: weights must be numbers in [0, 4]", i + 1))?;
                let w: [f64; WEIGHT_DEPTHS] =
                    v.try_into().map_err(|_| format!("line {}: {WEIGHT_DEPTHS} weights expected", i + 1))?;
                weights = Some(w);
            }
            "options" | "calibration" => {}
            other => return Err(format!("line {}: unknown key '{other}'", i + 1)),
        }
    }
    match format {
        Some(FORMAT) => {}
        Some(f) => {
            return Err(format!("format {f}, this build reads format {FORMAT} (run `cargo xtask lobes-weights`)"))
        }
        None => return Err("no format line".into()),
    }
    weights.ok_or_else(|| "no weights line".into())
}

/// The fitted weights from `dir/lobes_weights.txt`; errors name the file.
pub fn load_table(dir: &std::path::Path) -> Result<[f64; WEIGHT_DEPTHS], String> {
    let path = dir.join(TABLE_FILE);
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    parse_table(&text).map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_round_trip_and_bad_tables() {
        let w = [1.0, 1.0, 1.0, 1.25, 0.875, 1.0, 1.0];
        assert_eq!(parse_table(&table_text(&w, 10, 0.1, 0.05)).unwrap(), w);
        for (bad, needle) in [
            ("format 2\nweights 1 1 1 1 1 1 1", "format 2"),
            ("weights 1 1 1 1 1 1 1", "no format"),
            ("format 1\nweights 1 1 1", "7 weights"),
            ("format 1\nweights 1 1 1 NaN 1 1 1", "[0, 4]"),
            ("format 1\nweights 1 1 1 9 1 1 1", "[0, 4]"),
            ("format 1\ncolour 3", "unknown key 'colour'"),
            ("format 1", "no weights"),
        ] {
            let e = parse_table(bad).unwrap_err();
            assert!(e.contains(needle), "{bad:?}: {e}");
        }
    }

    #[test]
    fn a_missing_table_names_the_file() {
        let e = load_table(std::path::Path::new("/nonexistent/tables")).unwrap_err();
        assert!(e.contains("/nonexistent/tables/lobes_weights.txt"), "{e}");
    }

    /// The least squares recover known weights from synthetic rows (exact = U − Σ w S).
    #[test]
    fn fit_recovers_known_weights() {
        let truth = [1.0, 1.0, 0.7, 1.3, 0.9, 1.0, 1.0];
        let mut rows = Vec::new();
        for i in 0..200 {
            let x = i as f64;
            let s = [0.0, 0.0, (x * 0.37).sin().abs(), (x * 0.11).cos().abs(), (x * 0.05).sin().abs() * 0.5, 0.0, 0.0];
            let u = 3.0;
            let exact = u - (0..WEIGHT_DEPTHS).map(|d| truth[d] * s[d]).sum::<f64>();
            rows.push(Row { u, s_by_depth: s, exact, light_dist: 1.0, blocker_dist: x });
        }
        let w = fit(&rows, 1e-9);
        for d in 0..WEIGHT_DEPTHS {
            assert!((w[d] - truth[d]).abs() < 1e-5, "{w:?}");
        }
        assert!(error(&rows, &w) < 1e-6);
        // Binned fits of rows made with one set of weights find them again in every bin (up to the
        // regularization towards 1; octaves [64, 128), [128, 256), [256, 512)).
        let (bins, e) = binned_error(&rows, |r| r.blocker_dist + 64.0);
        assert!(bins == 3 && e < 1e-3, "{bins} {e}");
    }
}
