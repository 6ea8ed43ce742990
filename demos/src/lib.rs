//! The demos: the scene registry ([`scenes`]), the viewer, capture, the report sweep, the Mitsuba export and
//! the measurement helpers of the binaries in src/bin.

use engine::scene::Scene;
use std::path::PathBuf;

pub mod bench;
pub mod capture;
pub mod export;
pub mod gltf_writer;
pub mod measure;
pub mod report;
pub mod scenes;
pub mod soak;
pub mod viewer;

pub use scenes::Animation;

/// The project's `assets/` folder (`ENGINE_ASSETS` overrides).
pub fn assets_dir() -> PathBuf {
    std::env::var_os("ENGINE_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets"))
}

/// The binaries' `main`: print the error with its causes as `error: …` and exit with status 1.
pub fn exit_on_error(result: anyhow::Result<()>) {
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

/// Set the specular BRDF of material 0 from a `--brdf` spec
/// ([`engine::scene::Material::apply_brdf_spec`]).
pub fn apply_brdf(scene: &mut Scene, spec: &str) -> anyhow::Result<()> {
    let m = scene.materials.first_mut().ok_or_else(|| anyhow::anyhow!("--brdf: the scene has no material"))?;
    m.apply_brdf_spec(spec).map_err(anyhow::Error::msg)
}
