//! Sphere-set files (`*.spheres.json`) and the fit-once cache.
//!
//! Format, version 1 (JSON, unknown keys rejected):
//!
//! ```json
//! {
//!   "format": "engine-blockers/spheres",
//!   "version": 1,
//!   "source_mesh": "assets/meshes/bunny.obj",
//!   "mesh_hash": "fnv1a64:0123456789abcdef",
//!   "settings": { "count": 64, "seed": 1, "grid_resolution": 24, "lookup_resolution": 48,
//!                 "volume_samples": 96, "max_iterations": 40, "max_teleports": 12, "stall_ratio": 0.01 },
//!   "stats": { "outside_sum": 1.23, "iterations": 17, "teleports_tried": 3, "teleports_accepted": 1 },
//!   "spheres": [[cx, cy, cz, r], ...]
//! }
//! ```
//!
//! - `format` is fixed; `version` is [`FORMAT_VERSION`] and any other is an error (no silent reading
//!   of a future layout).
//! - `source_mesh` is informational (the path as given when fitting); `mesh_hash` is
//!   [`Mesh::content_hash`] of the geometry (positions and indices, not the file bytes).
//! - `settings` are the [`FitSettings`] used; `stats` are informational ([`FitStats`]).
//! - `spheres` are in mesh units, f64, in fitting order; on load each is validated (finite centre,
//!   finite non-negative radius) and an empty list is an error.
//!
//! The cache ([`load_or_fit`]) reuses a file only when its version, mesh hash and settings all equal
//! the current ones; otherwise it fits again and rewrites the file.

use crate::fit::{fit_spheres, FitProgress, FitResult, FitSettings};
use crate::mesh::Mesh;
use crate::{BlockerError, Sphere};
use serde::{Deserialize, Serialize};
use std::path::Path;

pub const FORMAT_NAME: &str = "engine-blockers/spheres";
pub const FORMAT_VERSION: u32 = 1;

/// Informational statistics of the fit that produced a file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitStats {
    pub outside_sum: f64,
    pub iterations: usize,
    pub teleports_tried: usize,
    pub teleports_accepted: usize,
}

/// The contents of a sphere-set file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereSetFile {
    pub format: String,
    pub version: u32,
    pub source_mesh: String,
    pub mesh_hash: String,
    pub settings: FitSettings,
    pub stats: Option<FitStats>,
    pub spheres: Vec<[f64; 4]>,
}

impl SphereSetFile {
    pub fn from_fit(source_mesh: &str, mesh: &Mesh, settings: &FitSettings, fit: &FitResult) -> Self {
        Self {
            format: FORMAT_NAME.into(),
            version: FORMAT_VERSION,
            source_mesh: source_mesh.into(),
            mesh_hash: mesh.content_hash(),
            settings: settings.clone(),
            stats: Some(FitStats {
                outside_sum: fit.outside_sum,
                iterations: fit.iterations,
                teleports_tried: fit.teleports_tried,
                teleports_accepted: fit.teleports_accepted,
            }),
            spheres: fit.spheres.iter().map(|s| s.to_array()).collect(),
        }
    }

    /// The spheres, validated.
    pub fn spheres(&self) -> Result<Vec<Sphere>, BlockerError> {
        if self.spheres.is_empty() {
            return Err(BlockerError::NoSpheres);
        }
        self.spheres
            .iter()
            .enumerate()
            .map(|(i, &a)| {
                let s = Sphere::from_array(a);
                s.validate(i).map(|_| s)
            })
            .collect()
    }

    /// Parses and validates (format name, version, spheres). `path` is used in messages only.
    pub fn from_json(text: &str, path: &str) -> Result<Self, BlockerError> {
        // Read the version first so a future file reports a version error, not a field error.
        #[derive(Deserialize)]
        struct Header {
            format: Option<String>,
            version: Option<u32>,
        }
        // serde_json quotes unknown keys and wrong strings whole: cut them.
        let fmt_err =
            |message: String| BlockerError::Format { path: path.into(), message: engine_io::shorten(&message) };
        let header: Header = serde_json::from_str(text).map_err(|e| fmt_err(e.to_string()))?;
        if header.format.as_deref() != Some(FORMAT_NAME) {
            return Err(fmt_err(format!("\"format\" must be \"{FORMAT_NAME}\", found {:?}", header.format)));
        }
        match header.version {
            Some(FORMAT_VERSION) => {}
            Some(found) => return Err(BlockerError::Version { path: path.into(), found, expected: FORMAT_VERSION }),
            None => return Err(fmt_err("missing \"version\"".into())),
        }
        let file: Self = serde_json::from_str(text).map_err(|e| fmt_err(e.to_string()))?;
        file.spheres().map_err(|e| fmt_err(e.to_string()))?;
        file.settings.validate().map_err(|e| fmt_err(e.to_string()))?;
        Ok(file)
    }

    pub fn to_json(&self) -> String {
        // Serializing plain numbers and strings cannot fail; non-finite floats would, but the
        // spheres are validated at construction.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// Reads `path` through `engine_io` (a regular file of at most `Limit::SPHERES`).
    pub fn load(path: &Path) -> Result<Self, BlockerError> {
        let text = engine_io::read_to_string(path, engine_io::Limit::SPHERES)
            .map_err(|e| BlockerError::Io { path: path.display().to_string(), message: e.message() })?;
        Self::from_json(&text, &path.display().to_string())
    }

    /// Writes atomically (temporary file, then rename) so a crash never leaves half a cache file.
    pub fn save(&self, path: &Path) -> Result<(), BlockerError> {
        self.spheres()?;
        let io = |e: std::io::Error| BlockerError::Io { path: path.display().to_string(), message: e.to_string() };
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(io)?;
        }
        let tmp = path.with_extension("json.tmp");
        std::fs::write(&tmp, self.to_json()).map_err(io)?;
        std::fs::rename(&tmp, path).map_err(io)
    }
}

/// Whether the cache at `cache` is reusable, and if so its spheres.
#[derive(Debug)]
pub enum CacheOutcome {
    Hit(Vec<Sphere>),
    /// Fitted (again), with the reason.
    Fitted {
        spheres: Vec<Sphere>,
        reason: String,
    },
}

impl CacheOutcome {
    pub fn spheres(&self) -> &[Sphere] {
        match self {
            CacheOutcome::Hit(s) | CacheOutcome::Fitted { spheres: s, .. } => s,
        }
    }
}

/// Fit once: returns the spheres in `cache` if it exists, parses, and matches `mesh`'s hash and
/// `settings`; otherwise fits, writes `cache`, and returns the new spheres. An unreadable or stale
/// cache is refitted (the reason is returned), never an error; failing to write it is.
pub fn load_or_fit(
    mesh: &Mesh,
    source_mesh: &str,
    settings: &FitSettings,
    cache: &Path,
    progress: &mut dyn FnMut(&FitProgress),
) -> Result<CacheOutcome, BlockerError> {
    let reason = match SphereSetFile::load(cache) {
        Ok(file) if file.mesh_hash != mesh.content_hash() => "mesh changed".to_string(),
        Ok(file) if file.settings != *settings => "settings changed".to_string(),
        // Written before a sheet's spheres had a floor radius (fit.rs, sheet_radius): they block nothing.
        Ok(file) if file.spheres.iter().all(|s| s[3] == 0.0) => "every sphere has radius 0".to_string(),
        Ok(file) => return Ok(CacheOutcome::Hit(file.spheres()?)),
        Err(e) => format!("no usable cache ({e})"),
    };
    let fit = fit_spheres(mesh, settings, progress)?;
    let file = SphereSetFile::from_fit(source_mesh, mesh, settings, &fit);
    file.save(cache)?;
    Ok(CacheOutcome::Fitted { spheres: fit.spheres, reason })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::uv_sphere;
    use glam::DVec3;

    fn small_settings() -> FitSettings {
        FitSettings {
            count: 4,
            grid_resolution: 6,
            lookup_resolution: 12,
            volume_samples: 32,
            max_iterations: 4,
            max_teleports: 1,
            ..Default::default()
        }
    }

    #[test]
    fn round_trip_and_bad_files() {
        let mesh = uv_sphere(DVec3::ZERO, 1.0, 6, 8);
        let settings = small_settings();
        let fit = fit_spheres(&mesh, &settings, &mut |_| {}).unwrap();
        let file = SphereSetFile::from_fit("sphere.obj", &mesh, &settings, &fit);
        let back = SphereSetFile::from_json(&file.to_json(), "mem").unwrap();
        assert_eq!(back, file, "JSON round trip must be exact (serde_json writes shortest round-trip floats)");
        let text = file.to_json();
        let future = text.replacen("\"version\": 1", "\"version\": 2", 1);
        assert!(matches!(SphereSetFile::from_json(&future, "f"), Err(BlockerError::Version { found: 2, .. })));
        let unknown = text.replacen("\"version\": 1", "\"version\": 1, \"colour\": 3", 1);
        assert!(matches!(SphereSetFile::from_json(&unknown, "f"), Err(BlockerError::Format { .. })));
        let negative = SphereSetFile { spheres: vec![[0.0, 0.0, 0.0, -1.0]], ..file.clone() };
        assert!(SphereSetFile::from_json(&negative.to_json(), "f").is_err());
        let empty = SphereSetFile { spheres: vec![], ..file.clone() };
        assert!(SphereSetFile::from_json(&empty.to_json(), "f").is_err());
        assert!(SphereSetFile::from_json("not json", "f").is_err());
        assert!(SphereSetFile::from_json("{\"format\": \"other\", \"version\": 1}", "f").is_err());
        // NaN cannot be written as JSON; `null` in its place is rejected.
        let null = text.replacen(&format!("{}", file.spheres[0][3]), "null", 1);
        assert!(SphereSetFile::from_json(&null, "f").is_err());
    }

    #[test]
    fn cache_hits_and_refits() {
        let dir = std::env::temp_dir().join(format!("engine-blockers-cache-{}", std::process::id()));
        let path = dir.join("s.spheres.json");
        let _ = std::fs::remove_file(&path);
        let mesh = uv_sphere(DVec3::ZERO, 1.0, 6, 8);
        let settings = small_settings();
        let first = load_or_fit(&mesh, "m", &settings, &path, &mut |_| {}).unwrap();
        assert!(matches!(first, CacheOutcome::Fitted { .. }));
        let second = load_or_fit(&mesh, "m", &settings, &path, &mut |_| {}).unwrap();
        assert!(matches!(second, CacheOutcome::Hit(_)));
        assert_eq!(first.spheres(), second.spheres());
        let other = FitSettings { seed: 2, ..settings.clone() };
        match load_or_fit(&mesh, "m", &other, &path, &mut |_| {}).unwrap() {
            CacheOutcome::Fitted { reason, .. } => assert_eq!(reason, "settings changed"),
            hit => panic!("expected refit, got {hit:?}"),
        }
        let moved = uv_sphere(DVec3::X, 1.0, 6, 8);
        match load_or_fit(&moved, "m", &other, &path, &mut |_| {}).unwrap() {
            CacheOutcome::Fitted { reason, .. } => assert_eq!(reason, "mesh changed"),
            hit => panic!("expected refit, got {hit:?}"),
        }
        std::fs::write(&path, "{ corrupt").unwrap();
        assert!(matches!(load_or_fit(&moved, "m", &other, &path, &mut |_| {}).unwrap(), CacheOutcome::Fitted { .. }));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
