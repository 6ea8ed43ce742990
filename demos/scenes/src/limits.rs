//! The range of every number a user gives, in one table shared by the command line (`demo`'s options) and the
//! scene files (`--scene FILE.toml`, `crate::user`): a value one of them refuses, the other refuses too, with the
//! same range in the message. A scene file's `environment.rotation = -9223372036854775808` was accepted (and
//! turned the map) while `--env-rotation` refused it.
//!
//! Each entry is a scene-file key (`model.scale` is `[[model]] scale`, checked per model as `model[i].scale`), the
//! option that sets the same thing (if any), and the closed or open bounds. Every bound keeps the arithmetic it
//! feeds within f32: positions within ±10⁹ (their differences and squared lengths stay far from f32's 3.4·10³⁸),
//! angles within ±10⁵ degrees (f32 still resolves 0.01° there), radiance within [`MAX_RADIANCE`].

use engine::scene::MAX_RADIANCE;

/// One number's range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    /// The scene-file key (`section.key`; `model.` and `light.` keys are per `[[model]]` / `[[light]]`).
    pub key: &'static str,
    /// The command-line option that sets the same value, if there is one.
    pub option: Option<&'static str>,
    pub lo: f64,
    pub hi: f64,
    /// Whether `lo` itself is refused: (lo, hi] instead of [lo, hi].
    pub lo_open: bool,
    /// Whether `hi` itself is refused.
    pub hi_open: bool,
    /// Whole numbers only.
    pub integer: bool,
    /// What the number is, for messages (`degrees`, `a percentage`).
    pub what: &'static str,
}

const fn closed(key: &'static str, option: Option<&'static str>, lo: f64, hi: f64, what: &'static str) -> Range {
    Range { key, option, lo, hi, lo_open: false, hi_open: false, integer: false, what }
}

const fn open_lo(key: &'static str, option: Option<&'static str>, lo: f64, hi: f64, what: &'static str) -> Range {
    Range { lo_open: true, ..closed(key, option, lo, hi, what) }
}

const fn count(key: &'static str, option: Option<&'static str>, lo: f64, hi: f64, what: &'static str) -> Range {
    Range { integer: true, ..closed(key, option, lo, hi, what) }
}

/// World-space coordinates (camera, lights, translations): ±10⁹.
pub const MAX_COORDINATE: f64 = 1e9;
/// Angles in degrees (`--env-rotation`, `--env-spin`, rotations): ±10⁵.
pub const MAX_DEGREES: f64 = 1e5;

pub const CAMERA_EYE: Range = closed("camera.eye", None, -MAX_COORDINATE, MAX_COORDINATE, "a coordinate");
pub const CAMERA_TARGET: Range = closed("camera.target", None, -MAX_COORDINATE, MAX_COORDINATE, "a coordinate");
pub const CAMERA_FOV_Y: Range =
    Range { hi_open: true, ..open_lo("camera.fov_y", None, 1.0, 179.0, "a vertical field of view in degrees") };
pub const ENV_INTENSITY: Range =
    closed("environment.intensity", None, 0.0, MAX_RADIANCE as f64, "an intensity (× the map's radiance)");
pub const ENV_ROTATION: Range =
    closed("environment.rotation", Some("--env-rotation"), -MAX_DEGREES, MAX_DEGREES, "a finite number of degrees");
/// `--env-spin` (no scene-file key: degrees per second of animation).
pub const ENV_SPIN: Range =
    closed("", Some("--env-spin"), -MAX_DEGREES, MAX_DEGREES, "a finite number of degrees per second");
pub const ENV_LIGHTS: Range = count(
    "environment.lights",
    Some("--env-lights"),
    0.0,
    engine::math::env_lights::MAX_ENV_LIGHTS as f64,
    "a number of environment lights",
);
pub const ENV_LIGHT_THRESHOLD: Range =
    open_lo("environment.light_threshold", Some("--env-light-threshold"), 1.0, 1e6, "a multiple of the mean radiance");
pub const ENV_LIGHT_SHARE: Range =
    open_lo("environment.light_share", Some("--env-light-share"), 0.0, 100.0, "a percentage");
pub const ENV_LIGHT_RADIUS: Range =
    open_lo("environment.light_radius", Some("--env-light-radius"), 0.0, 90.0, "an angle in degrees");
pub const GROUND_SUBDIVISIONS: Range = count("ground.subdivisions", None, 1.0, 512.0, "a number of quads per side");
pub const LIGHT_CENTER: Range = closed("light.center", None, -MAX_COORDINATE, MAX_COORDINATE, "a coordinate");
pub const LIGHT_RADIUS: Range = open_lo("light.radius", None, 0.0, MAX_COORDINATE, "a radius");
pub const LIGHT_RADIANCE: Range = closed("light.radiance", None, 0.0, MAX_RADIANCE as f64, "a radiance");
pub const MODEL_TRANSLATION: Range = closed("model.translation", None, -MAX_COORDINATE, MAX_COORDINATE, "a coordinate");
pub const MODEL_ROTATION: Range =
    closed("model.rotation", None, -MAX_DEGREES, MAX_DEGREES, "a finite number of degrees");
pub const MODEL_SCALE: Range = closed("model.scale", None, 1e-6, 1e6, "a scale factor");
pub const MODEL_SPHERES: Range = count("model.spheres", Some("--spheres"), 0.0, 4096.0, "a number of spheres per mesh");
pub const COLOUR: Range = closed("material.diffuse", None, 0.0, 1.0, "a colour channel");
pub const SPECULAR: Range = closed("material.specular", None, 0.0, 1.0, "a colour channel");
pub const SHININESS: Range = closed("material.shininess", None, 1e-3, 1e6, "an exponent");
pub const MAP_LEVELS: Range = count(
    "material_map.levels",
    None,
    2.0,
    engine::scene::material_map::MAX_LEVELS as f64,
    "a number of palette levels",
);
/// `--exposure` (no scene-file key).
pub const EXPOSURE: Range = closed("", Some("--exposure"), 1e-6, 1e6, "an exposure multiplier");

/// Every range: the scene files' numeric keys and the options. (`material.*` keys are those of every material
/// table: `model.material`, `ground.material` and the maps' `material_map.material`.)
pub const RANGES: &[Range] = &[
    CAMERA_EYE,
    CAMERA_TARGET,
    CAMERA_FOV_Y,
    ENV_INTENSITY,
    ENV_ROTATION,
    ENV_SPIN,
    ENV_LIGHTS,
    ENV_LIGHT_THRESHOLD,
    ENV_LIGHT_SHARE,
    ENV_LIGHT_RADIUS,
    GROUND_SUBDIVISIONS,
    LIGHT_CENTER,
    LIGHT_RADIUS,
    LIGHT_RADIANCE,
    MODEL_TRANSLATION,
    MODEL_ROTATION,
    MODEL_SCALE,
    MODEL_SPHERES,
    COLOUR,
    SPECULAR,
    SHININESS,
    MAP_LEVELS,
    EXPOSURE,
];

/// A value as the file wrote it: a scene file's numbers are f32, so an f32 prints as f32 (`1e38`, not the 38
/// digits of its f64 widening).
fn shown(x: f64) -> String {
    let f = x as f32;
    if f as f64 == x && f.is_finite() && f != 0.0 && (f.abs() >= 1e6 || f.abs() < 1e-3) {
        format!("{f:e}")
    } else if f as f64 == x {
        format!("{f}")
    } else {
        number(x)
    }
}

/// A bound as people write it: `100000`, `0.001`, but `1e6` and `1e-6`.
fn number(x: f64) -> String {
    if x != 0.0 && (x.abs() >= 1e6 || x.abs() < 1e-3) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

impl Range {
    /// Whether `x` is in the range (NaN and infinities never are). A closed bound is also met by its f32
    /// rounding (a scene file's `scale = 1e-6` reads as 9.99999997e-7).
    pub fn contains(&self, x: f64) -> bool {
        let at = |bound: f64| x == bound || x == bound as f32 as f64;
        x.is_finite()
            && (x > self.lo || (!self.lo_open && at(self.lo)))
            && (x < self.hi || (!self.hi_open && at(self.hi)))
            && (!self.integer || x.fract() == 0.0)
    }

    /// The range as a message writes it: `[-100000, 100000]`, `(1, 1e6]`, `0..=16`.
    pub fn bounds(&self) -> String {
        if self.integer {
            return format!("{}..={}", self.lo, self.hi);
        }
        let (l, r) = (if self.lo_open { '(' } else { '[' }, if self.hi_open { ')' } else { ']' });
        format!("{l}{}, {}{r}", number(self.lo), number(self.hi))
    }

    /// `x` if it is in the range, else the message (without the key: the caller names where the value is).
    pub fn check(&self, x: f64) -> Result<f64, String> {
        if self.contains(x) {
            Ok(x)
        } else {
            Err(format!("{} is not {} in {}", shown(x), self.what, self.bounds()))
        }
    }

    /// Each of `values` checked, for the scene-file key `key` (`model[2].scale`).
    pub fn check_key(&self, key: &str, values: &[f64]) -> anyhow::Result<()> {
        for &x in values {
            self.check(x).map_err(|m| anyhow::anyhow!("{key}: {m}"))?;
        }
        Ok(())
    }

    /// A command-line value: a number in the range, or the message quoting what was given.
    pub fn parse(&self, s: &str) -> Result<f64, String> {
        match s.trim().parse::<f64>() {
            Ok(x) if self.contains(x) => Ok(x),
            Ok(x) => Err(format!("{x} is not {} in {}", self.what, self.bounds())),
            Err(_) => Err(format!("'{}' is not {} in {}", engine::io::excerpt(s), self.what, self.bounds())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_are_inclusive_or_exclusive_as_written() {
        assert!(ENV_ROTATION.contains(1e5) && !ENV_ROTATION.contains(100000.01) && !ENV_ROTATION.contains(f64::NAN));
        assert!(!ENV_LIGHT_SHARE.contains(0.0) && ENV_LIGHT_SHARE.contains(100.0));
        assert!(!CAMERA_FOV_Y.contains(179.0) && !CAMERA_FOV_Y.contains(1.0) && CAMERA_FOV_Y.contains(45.0));
        assert!(MODEL_SPHERES.contains(4096.0) && !MODEL_SPHERES.contains(4097.0) && !MODEL_SPHERES.contains(1.5));
        assert_eq!(ENV_ROTATION.bounds(), "[-100000, 100000]");
        assert_eq!(ENV_LIGHT_THRESHOLD.bounds(), "(1, 1e6]");
        assert_eq!(EXPOSURE.bounds(), "[1e-6, 1e6]");
        assert_eq!(ENV_LIGHTS.bounds(), "0..=16");
        let e = ENV_ROTATION.parse("-9223372036854775808").unwrap_err();
        assert!(e.contains("not a finite number of degrees in [-100000, 100000]"), "{e}");
        // Keys are unique; every key has a section and a name.
        for (i, r) in RANGES.iter().enumerate() {
            assert!(r.key.is_empty() || r.key.contains('.'), "{r:?}");
            assert!(r.key.is_empty() || RANGES[..i].iter().all(|o| o.key != r.key), "{} twice", r.key);
            assert!(!r.key.is_empty() || r.option.is_some(), "{r:?}");
            assert!(r.lo < r.hi, "{r:?}");
        }
    }
}
