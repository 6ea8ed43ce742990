//! `engine::blockers`: sphere-set approximations of blocker geometry (CPU side, no Vulkan).
//!
//! - [`mesh`]: triangle meshes, OBJ loading, generalized winding numbers (inside tests with holes).
//! - [`fit`]: variational sphere-set fitting (SHEXP §6.2 after Wang et al. 2006), a k-means
//!   baseline, and the outside-volume / coverage evaluation.
//! - [`file`]: the versioned `.spheres.json` format and the fit-once cache.
//! - [`bvh`]: binary LBVH over spheres (Karras 2012), refit, point / cone / angle-cut queries,
//!   and its std430 node layout.
//! - [`hierarchy`]: the 4-ary bottom-up sphere hierarchy of SHEXP §6.3 and its per-receiver cut.
//! - [`traverse`]: bounded-stack traversal of the device node layout (f64 twin of
//!   `shaders-glsl/common/bvh.glsl`) and a structural check of GPU-built node arrays.
//! - [`plane`]: plane blockers (half-spaces and rectangles: the ground as a blocker), twins of
//!   `shaders-glsl/common/planes.glsl`.
//! - [`geom`]: sphere primitives (merge, subtended angle, cone test), twins of
//!   `shaders-glsl/common/spheres.glsl`.

pub mod bvh;
pub mod file;
pub mod fit;
pub mod geom;
pub mod hierarchy;
pub mod mesh;
pub mod plane;
pub mod traverse;

pub use geom::{Cone, Sphere, MAX_SPHERE_COORDINATE};
pub use plane::BlockerPlane;

/// Errors at this crate's boundary. Every bad input named in the blockers issue maps to one of these;
/// no public function panics on bad data.
#[derive(Debug, thiserror::Error)]
pub enum BlockerError {
    #[error("mesh has no triangles")]
    EmptyMesh,
    #[error("mesh vertex {vertex} has a non-finite position {position:?}")]
    NonFinitePosition { vertex: usize, position: [f64; 3] },
    #[error("triangle {triangle} uses vertex index {index}, but the mesh has {vertex_count} vertices")]
    IndexOutOfRange { triangle: usize, index: u32, vertex_count: usize },
    #[error("every triangle of the mesh is degenerate (zero total area)")]
    DegenerateMesh,
    #[error("cannot read OBJ {path}: {message}")]
    Obj { path: String, message: String },
    #[error("sphere {index} is invalid: {reason}")]
    InvalidSphere { index: usize, reason: String },
    #[error("no spheres given")]
    NoSpheres,
    #[error("sphere count must be at least 1")]
    ZeroCount,
    #[error("cannot fit {count} spheres to {samples} sample points: ask for at most {samples}")]
    CountTooLarge { count: usize, samples: usize },
    #[error("invalid fit settings: {0}")]
    InvalidSettings(String),
    #[error("{path}: {message}")]
    Io { path: String, message: String },
    #[error("sphere file {path}: {message}")]
    Format { path: String, message: String },
    #[error("sphere file {path} has format version {found}, this build reads version {expected}")]
    Version { path: String, found: u32, expected: u32 },
}

/// Shared fixtures of the unit tests.
#[cfg(test)]
pub(crate) mod test_util {
    use crate::geom::Sphere;
    use engine_math::rng::Pcg32;
    use glam::DVec3;

    /// `n` seeded random spheres in [−5, 5]³ with radii in [0.05, 0.8].
    pub fn random_spheres(rng: &mut Pcg32, n: usize) -> Vec<Sphere> {
        (0..n)
            .map(|_| {
                Sphere::new(
                    DVec3::new(rng.uniform(-5.0, 5.0), rng.uniform(-5.0, 5.0), rng.uniform(-5.0, 5.0)),
                    rng.uniform(0.05, 0.8),
                )
            })
            .collect()
    }
}
