//! Real spherical harmonics: basis, projection, triple-product tensor, products, zonal rotation,
//! circle (sphere-blocker) visibility and its log (SHEXP paper, Ren et al. 2006, Sec. 3, 5, 6.1, 7).
//!
//! Conventions (docs/design.md §3):
//! - Real, orthonormal basis; order `n` means bands `l = 0..n-1`, `n²` coefficients, index
//!   `i = l² + l + m`. The polar axis of the basis is +z (`cos θ = z`, `φ = atan2(y, x)`); this is a
//!   choice of basis only: every operation here is rotation-covariant, and directions follow the
//!   engine's Y-up convention through `engine_math::envmap`.
//! - No Condon–Shortley phase: `y_1,-1 = K y`, `y_10 = K z`, `y_11 = K x` with `K = √(3/4π)`
//!   (Ramamoorthi & Hanrahan 2001). `y_l,m>0 ∝ cos(mφ)`, `y_l,m<0 ∝ sin(|m|φ)`.
//! - The constant function 1 is `(√(4π), 0, …)` (paper Eq. 12).
//! - Orders up to [`MAX_ORDER`] = 8.
//!
//! `shaders-glsl/common/sh.glsl` is the f32 GLSL twin of the evaluation, ZH rotation and dot product.
//!
//! # Files
//! - `basis`: indexing, evaluation, reconstruction, Legendre polynomials;
//! - `projection`: windowing and projection of functions and lat-long maps;
//! - `tensor`: the triple-product tensor (Gaunt coefficients) and SH products;
//! - `zonal`: zonal rotation, circle visibility, irradiance weighting;
//! - `log`: the SH log by the eigen method and the circle log table.
//!
//! Every public item is re-exported here (`engine_math::sh::X`).

mod basis;
mod log;
mod projection;
mod tensor;
mod zonal;

pub use basis::*;
pub use log::*;
pub use projection::*;
pub use tensor::*;
pub use zonal::*;
