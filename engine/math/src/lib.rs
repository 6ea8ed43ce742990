//! `engine::math`: the mathematics of the three techniques, in f64, with no Vulkan.
//!
//! Every GLSL function in `shaders-glsl/common` has its twin here and a GPU-vs-CPU test.
//! The formulas follow docs/design.md §3 (which restores the symbols the paper texts lost).

pub mod brdf;
pub mod env_lights;
pub mod envmap;
pub mod isg;
pub mod linalg;
pub mod lobes;
pub mod prefilter;
pub mod quadrature;
pub mod rng;
pub mod sg;
pub mod sh;
pub mod shading;
pub mod shexp;
pub mod sphere_light;
pub mod table_gen;
pub mod tables;
pub mod tonemap;
