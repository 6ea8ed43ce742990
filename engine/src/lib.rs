//! The engine: soft shadows from sphere-set blockers under environment and spherical lights.
//!
//! Layers, lowest first; a module imports only from layers below it or its own (checked by
//! tests/tests/layering.rs, which reads these sources):
//! 0. `gpu` (the only raw Vulkan), `options` (spec parsing), `input` (scene input errors), `output`;
//!    the crates `engine_math` (f64 math) and `engine_blockers` (sphere sets, BVH) sit beside them;
//! 1. `scene` (plain data: meshes, materials, environment, lights, camera; loaders);
//! 2. `tables` (the math tables in device memory);
//! 3. `resources` (the scene in device memory, prepared once per scene and shared by every pass);
//! 4. `passes` (one file per pass, each with its shader folder; `passes::shade` holds the techniques
//!    and their registry);
//! 5. `renderer` (one frame: skin → blocker spheres → cloth → thin shells → BVH → G-buffer → shade →
//!    tonemap).
//!
//! Measuring (error metrics, the reference's convergence loops) lives above the engine, in the `lab` crate.

pub use engine_blockers as blockers;
pub use engine_io as io;
pub use engine_math as math;

pub mod gpu;
pub mod input;
pub mod options;
pub mod output;
pub mod passes;
pub mod renderer;
pub mod resources;
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
