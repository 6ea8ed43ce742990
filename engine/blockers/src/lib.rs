//! `engine::blockers`: sphere-set approximations of blocker geometry (CPU side, no Vulkan).
//! (work in progress: see the blockers issue)
