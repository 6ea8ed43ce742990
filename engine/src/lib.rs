//! The engine: soft shadows from sphere-set blockers under environment and spherical lights.
//!
//! Layers (dependencies point down): `gpu` (the only raw Vulkan) → `math` (f64, no Vulkan) →
//! `scene` (plain data) → `blockers` → `passes` → `renderer`.

pub use engine_blockers as blockers;
pub use engine_math as math;

pub mod gpu;

pub mod metrics;

pub mod output;
pub mod passes;
pub mod renderer;
pub mod scene;
pub mod tables;

/// The engine's error at its outer boundary.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Gpu(#[from] gpu::GpuError),
    #[error(transparent)]
    Scene(#[from] scene::SceneError),
    #[error(transparent)]
    Output(#[from] output::OutputError),
}
