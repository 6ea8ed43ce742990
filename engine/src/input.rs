//! Errors of the engine's inputs that reach calls on the GPU side (the scene as it is uploaded or changed):
//! typed apart from Vulkan and device failures, so that a caller can tell bad input from a broken GPU.

/// The scene, or a change to it, cannot be uploaded as given: the message names the instance, mesh, material,
/// light, plane or parameter and what is wrong with it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct SceneInputError(pub String);
