//! The command-line side of the environment's lights (engine::math::env_lights): the options that set the
//! decomposition ([`EnvLightArgs`], shared by `demo` and `compare`), and the preview picture of the lights over
//! the map (`demo --env-lights-preview`).

use crate::limits;
use engine::math::env_lights::{EnvDecomposition, EnvLightParams};
use engine::math::envmap::{latlong_uv, LatLongMap};
use engine::scene::Scene;
use std::path::Path;

/// How the environment is split into lights and a residual, for the techniques whose `env_lights` option is
/// on. Each option overrides the scene's value (a scene file's `[environment] lights`, `light_threshold`, ...).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct EnvLightArgs {
    /// Environment lights: at most K of the environment's bright regions become spherical lights (0: none) for
    /// the techniques run with `env_lights=on` [default: the scene's, else 8].
    #[arg(long, value_name = "K", allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(0..=limits::ENV_LIGHTS.hi as i64))]
    pub env_lights: Option<u32>,
    /// A texel is bright above this many times the environment's mean radiance, in (1, 1e6] [default: 4].
    #[arg(long, value_name = "X", allow_negative_numbers = true, value_parser = parse_threshold)]
    pub env_light_threshold: Option<f64>,
    /// An environment light carries at least this share of the map's power, in percent, (0, 100] [default: 1].
    #[arg(long, value_name = "PERCENT", allow_negative_numbers = true, value_parser = parse_share)]
    pub env_light_share: Option<f64>,
    /// Bright regions wider than this angular radius are split into several lights, degrees in (0, 90]
    /// [default: 15].
    #[arg(long, value_name = "DEG", allow_negative_numbers = true, value_parser = parse_radius)]
    pub env_light_radius: Option<f64>,
}

// The ranges are the shared table's (`crate::limits`): a scene file's `[environment]` keys have the same.
fn parse_threshold(s: &str) -> Result<f64, String> {
    limits::ENV_LIGHT_THRESHOLD.parse(s)
}

fn parse_share(s: &str) -> Result<f64, String> {
    limits::ENV_LIGHT_SHARE.parse(s)
}

fn parse_radius(s: &str) -> Result<f64, String> {
    limits::ENV_LIGHT_RADIUS.parse(s)
}

impl EnvLightArgs {
    /// The scene's parameters with the options given applied.
    pub fn params(&self, scene: &EnvLightParams) -> EnvLightParams {
        let mut p = *scene;
        if let Some(k) = self.env_lights {
            p.max_lights = k as usize;
        }
        if let Some(t) = self.env_light_threshold {
            p.threshold = t;
        }
        if let Some(s) = self.env_light_share {
            p.min_share = s / 100.0;
        }
        if let Some(r) = self.env_light_radius {
            p.max_radius = r.to_radians();
        }
        p
    }

    /// Apply the options given to `scene`.
    pub fn apply(&self, scene: &mut Scene) {
        scene.env_lights = self.params(&scene.env_lights);
    }
}

/// Which part of a split environment a measurement keeps (`compare --env-part`): the scene as it is, its
/// residual alone (the environment replaced by the residual, no environment lights), or its lights alone (a
/// black environment, the environment's lights added to the scene's as spheres). Each part is then measured
/// against a reference of the same part, so the error of the lights and of the residual can be told apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum EnvPart {
    Whole,
    Residual,
    Lights,
}

/// `scene` reduced to `part` of its environment split by its own settings (`Whole`: unchanged).
pub fn keep_part(scene: &mut Scene, part: EnvPart) {
    if part == EnvPart::Whole {
        return;
    }
    let env = &scene.environment;
    let scaled = LatLongMap {
        width: env.width,
        height: env.height,
        texels: env.texels.iter().map(|t| t.map(|c| c * scene.environment_intensity)).collect(),
    };
    let d = engine::math::env_lights::decompose(&scaled, &scene.env_lights);
    match part {
        EnvPart::Residual => scene.environment = d.residual(&scaled),
        _ => {
            let (lo, hi) = scene.bounds();
            let (center, radius) = (0.5 * (lo + hi), (0.5 * (hi - lo).length()).max(1e-3));
            scene.lights.extend(engine::resources::environment::env_sphere_lights(&d, center, radius));
            scene.environment = LatLongMap::constant(scaled.width, scaled.height, [0.0; 3]);
        }
    }
    scene.environment_intensity = 1.0;
    // The part is what there is now: nothing more to split.
    scene.env_lights.max_lights = 0;
}

/// The lights of a decomposition as lines for the user: direction (azimuth about +y from +x, elevation),
/// half-angle, radiance and share of the power.
pub fn describe(d: &EnvDecomposition) -> Vec<String> {
    let mut lines: Vec<String> = d
        .lights
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let [x, y, z] = l.direction;
            format!(
                "light {i}: azimuth {:6.1}°, elevation {:5.1}°, half-angle {:5.2}°, radiance ({:.3}, {:.3}, {:.3}), \
                 {:.1} % of the power",
                z.atan2(x).to_degrees(),
                y.clamp(-1.0, 1.0).asin().to_degrees(),
                l.half_angle.to_degrees(),
                l.radiance[0],
                l.radiance[1],
                l.radiance[2],
                100.0 * l.share
            )
        })
        .collect();
    lines.push(format!(
        "{} light(s) from {} bright region(s): {:.1} % of the power; the residual keeps {:.1} %",
        d.lights.len(),
        d.regions,
        100.0 * d.share,
        100.0 * (1.0 - d.share)
    ));
    if let Some(n) = &d.note {
        lines.push(format!("note: {n}"));
    }
    lines
}

/// One colour per light, cycling.
const PALETTE: [[u8; 3]; 8] = [
    [0, 255, 255],
    [255, 0, 255],
    [255, 255, 0],
    [0, 255, 0],
    [255, 128, 0],
    [0, 128, 255],
    [255, 0, 0],
    [255, 255, 255],
];

/// The preview picture: the map (top) and the residual (bottom), `width` × `width`/2 each, tone-mapped alike, with
/// each light's cap outlined in its colour on both (RGBA8, `width` × `width` pixels).
pub fn preview(map: &LatLongMap, d: &EnvDecomposition, width: usize) -> Vec<u8> {
    let (w, h) = (width.max(2), (width / 2).max(1));
    let mean = engine::math::env_lights::luminance(map.integral()) / (4.0 * std::f64::consts::PI);
    // Exposure: the mean radiance at about a fifth of white (so the bright regions are visible as bright).
    let k = if mean > 0.0 { 0.25 / mean } else { 1.0 };
    let tone = |c: f64| {
        let x = (c * k).max(0.0);
        ((x / (1.0 + x)).powf(1.0 / 2.2) * 255.0).round() as u8
    };
    let mut out = vec![0u8; w * 2 * h * 4];
    let residual = d.residual(map);
    for (half, m) in [map, &residual].into_iter().enumerate() {
        for r in 0..h {
            for c in 0..w {
                let dir =
                    engine::math::envmap::latlong_direction((c as f64 + 0.5) / w as f64, (r as f64 + 0.5) / h as f64);
                let t = m.lookup_nearest(dir);
                let o = ((half * h + r) * w + c) * 4;
                out[o..o + 4].copy_from_slice(&[tone(t[0] as f64), tone(t[1] as f64), tone(t[2] as f64), 255]);
            }
        }
    }
    // The cap outlines: points on each cap's circle, mapped to both halves.
    for (i, l) in d.lights.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let a = l.direction;
        let up = if a[1].abs() < 0.9 { [0.0, 1.0, 0.0] } else { [1.0, 0.0, 0.0] };
        let e1 = normalize(cross(up, a));
        let e2 = cross(a, e1);
        let (s, co) = l.half_angle.max(0.5f64.to_radians()).sin_cos();
        for step in 0..720 {
            let phi = step as f64 * std::f64::consts::TAU / 720.0;
            let dir = [0, 1, 2].map(|k| co * a[k] + s * (phi.cos() * e1[k] + phi.sin() * e2[k]));
            let (u, v) = latlong_uv(dir);
            let (c, r) = (((u * w as f64) as usize).min(w - 1), ((v * h as f64) as usize).min(h - 1));
            for half in 0..2 {
                let o = ((half * h + r) * w + c) * 4;
                out[o..o + 3].copy_from_slice(&colour);
            }
        }
    }
    out
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt().max(f64::MIN_POSITIVE);
    a.map(|x| x / l)
}

/// `demo --env-lights-preview`: decompose the scene's environment (as the renderer would: scaled by its
/// intensity), print the lights and write the preview picture to `path` (CPU only, no GPU).
pub fn write_preview(scene: &Scene, path: &Path) -> anyhow::Result<Vec<String>> {
    scene.env_lights.check().map_err(anyhow::Error::msg)?;
    let env = &scene.environment;
    let scaled = LatLongMap {
        width: env.width,
        height: env.height,
        texels: env.texels.iter().map(|t| t.map(|c| c * scene.environment_intensity)).collect(),
    };
    let t0 = std::time::Instant::now();
    let d = engine::math::env_lights::decompose(&scaled, &scene.env_lights);
    let seconds = t0.elapsed().as_secs_f64();
    let width = scaled.width.clamp(2, 512);
    let rgba = preview(&scaled, &d, width);
    if let Some(dir) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| anyhow::anyhow!("cannot create {}: {e}", dir.display()))?;
    }
    engine::output::write_png(path, width as u32, (2 * (width / 2).max(1)) as u32, &rgba)?;
    let mut lines = describe(&d);
    lines.push(format!(
        "decomposed {}x{} in {:.1} ms; wrote {} (top: the map, bottom: the residual, each light's cap outlined)",
        scaled.width,
        scaled.height,
        seconds * 1e3,
        path.display()
    ));
    Ok(lines)
}
