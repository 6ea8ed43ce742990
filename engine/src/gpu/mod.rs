//! `engine::gpu`: the only module that touches raw Vulkan.
//!
//! A [`Gpu`] owns the instance, the chosen device, one graphics+compute queue, the gpu-allocator
//! allocator and the validation messenger. Resources ([`Buffer`], [`Image`]) are `{ raw, desc,
//! allocation }` values destroyed explicitly by value; [`Gpu::shutdown`] turns leaked allocations
//! and validation errors into an error, so tests fail on either, and the tests' context
//! ([`testing::TestGpu`]) fails a test that forgets to call it.

mod context;
pub mod layout_check;
mod pipeline;
mod recorder;
mod resources;
mod shader;
mod spirv;
mod swapchain;
pub mod testing;
mod watchdog;

pub use context::{default_shader_root, AdapterInfo, Gpu, GpuDesc, MemoryStats, ValidationMode};
pub use pipeline::{Binding, ComputePipeline, GraphicsPipeline, GraphicsPipelineDesc};
pub use recorder::{Frame, PassTiming, Recorder};
pub use resources::{Buffer, BufferDesc, Image, ImageDesc, ImageFormat, Memory};
pub use shader::{ShaderCompiler, ShaderModuleInfo, ShaderStage};
pub use spirv::{DescriptorKind, MemberLayout, ReflectedBinding, Reflection, Scalar, ScalarKind, StructLayout};
pub use swapchain::{surface_extensions, Swapchain, SwapchainImage};
pub use watchdog::{parse_fence_timeout, DEFAULT_FENCE_TIMEOUT, FENCE_TIMEOUT_ENV, SIMULATE_LOSS_ENV};

/// Errors of the GPU layer.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("could not load the Vulkan loader (libvulkan.so.1): {0}. Install libvulkan1 and a driver (mesa-vulkan-drivers for lavapipe), or run `cargo xtask demo`, which installs them")]
    Loader(String),
    #[error("no usable Vulkan device: {0}")]
    NoDevice(String),
    #[error("Vulkan call {call} failed: {result:?}")]
    Vk { call: &'static str, result: ash::vk::Result },
    #[error("memory allocation '{name}' failed: {source}")]
    Alloc {
        name: String,
        #[source]
        source: gpu_allocator::AllocationError,
    },
    #[error("shader {path}: {message}")]
    Shader { path: String, message: String },
    #[error("pipeline {pipeline}: {message}")]
    Binding { pipeline: String, message: String },
    #[error("{0}")]
    Other(String),
    /// A technique spec or its options do not parse (an input error that reached a GPU-side call such as
    /// `Renderer::new`; it names the technique or the key and what it accepts).
    #[error(transparent)]
    Option(#[from] crate::options::OptionError),
    /// The scene (or a change to it) is refused at upload: names what is wrong.
    #[error(transparent)]
    Scene(#[from] crate::input::SceneInputError),
    /// A submission did not finish within the fence timeout ([`Gpu::fence_timeout`]).
    #[error("GPU submission did not finish within {seconds} s: {submission} ({FENCE_TIMEOUT_ENV} sets the limit)")]
    Timeout { submission: String, seconds: f64 },
    /// `VK_ERROR_DEVICE_LOST` (or the test hook that simulates it).
    #[error("the Vulkan device was lost (VK_ERROR_DEVICE_LOST) during {submission} ({detail})")]
    DeviceLost { submission: String, detail: String },
    #[error("GPU teardown found problems:\n{0}")]
    Teardown(String),
}

pub type Result<T, E = GpuError> = std::result::Result<T, E>;

/// Map a `VkResult` error onto [`GpuError::Vk`] naming the call.
pub(crate) trait VkCheck<T> {
    fn vk(self, call: &'static str) -> Result<T>;
}

impl<T> VkCheck<T> for std::result::Result<T, ash::vk::Result> {
    fn vk(self, call: &'static str) -> Result<T> {
        self.map_err(|result| GpuError::Vk { call, result })
    }
}
