//! Test harness for GLSL kernels: run a compute shader over an input buffer of floats and read
//! the output back. Used by the GPU-vs-CPU tests of every `shaders-glsl/common` twin.
//!
//! The shader's interface (see shaders-glsl/tests/*_twin.comp):
//! ```glsl
//! layout(std430, set = 0, binding = 0) readonly buffer Input { float data_in[]; };
//! layout(std430, set = 0, binding = 1) writeonly buffer Output { float data_out[]; };
//! layout(push_constant) uniform Push { uint count; } pc;
//! ```

use super::{Binding, BufferDesc, Gpu, GpuDesc, GpuError, Result, ValidationMode};
use ash::vk;

/// A GPU context for tests: validation layer required, quiet, and checked even when the test
/// forgets [`TestGpu::shutdown`].
pub fn test_gpu() -> Result<TestGpu> {
    let gpu = Gpu::new(&GpuDesc { validation: ValidationMode::Required, verbose: false, ..GpuDesc::default() })?;
    Ok(TestGpu { gpu: Some(gpu) })
}

/// The [`Gpu`] of a test. It derefs to the `Gpu`; [`TestGpu::shutdown`] tears down and returns the
/// leaks and validation errors as an error, like [`Gpu::shutdown`]. A test that never calls it still
/// fails: dropping a `TestGpu` runs the same teardown and panics on any problem.
///
/// Why a guard here and not a panic in `Gpu`'s own `Drop`: the demos and the viewer drop their `Gpu`
/// on every error path, where an error is already on its way to the user; a panic there would replace
/// that message (or abort, inside winit's event loop). Tests are where a leak or a validation error
/// must fail loudly, so only the test context panics.
///
/// The panic happens only when the thread is not already panicking: a test that fails an assertion
/// unwinds through this `Drop`, and a second panic during unwinding would abort the whole test binary
/// (every other test's result lost, "panic in a destructor during cleanup"). Then the problems are
/// printed instead, after the test's own failure message.
pub struct TestGpu {
    gpu: Option<Gpu>,
}

impl TestGpu {
    /// Tear down (as [`Gpu::shutdown`]): an error listing leaked allocations and validation errors.
    pub fn shutdown(mut self) -> Result<()> {
        match self.gpu.take() {
            Some(gpu) => gpu.shutdown(),
            None => Ok(()),
        }
    }
}

impl std::ops::Deref for TestGpu {
    type Target = Gpu;
    fn deref(&self) -> &Gpu {
        // Only `shutdown` (by value) and `drop` take the context out.
        self.gpu.as_ref().expect("TestGpu used after shutdown")
    }
}

impl Drop for TestGpu {
    fn drop(&mut self) {
        let Some(gpu) = self.gpu.take() else { return };
        if let Err(e) = gpu.shutdown() {
            if std::thread::panicking() {
                eprintln!("{e}\n(found while dropping the test's GPU during a panic: not raised again)");
            } else {
                panic!("{e}\n(found when the test's GPU was dropped without shutdown())");
            }
        }
    }
}

/// Canary support: make one call that breaks a valid-usage rule the Khronos validation layer checks
/// and that lavapipe survives, so a test can prove a validation error fails the run. The call creates
/// a sampler with anisotropic filtering although the device was created without the
/// `samplerAnisotropy` feature (VUID-VkSamplerCreateInfo-anisotropyEnable-01070); drivers support
/// anisotropy and ignore the flag, so nothing else goes wrong. Returns the validation errors seen
/// by the call (the layer reports synchronously, in the calling thread).
pub fn provoke_validation_error(gpu: &Gpu) -> Result<Vec<String>> {
    let before = gpu.validation_errors().len();
    let info = vk::SamplerCreateInfo::default().anisotropy_enable(true).max_anisotropy(2.0).max_lod(1.0);
    // SAFETY: a plain create on a valid device; the sampler (if the layer let the call through) is
    // destroyed at once and never used.
    let sampler = unsafe { gpu.device.create_sampler(&info, None) };
    match sampler {
        // SAFETY: created above from this device, unused.
        Ok(s) => unsafe { gpu.device.destroy_sampler(s, None) },
        // The layer may stop an invalid call (VK_ERROR_VALIDATION_FAILED_EXT): the error is recorded.
        Err(vk::Result::ERROR_VALIDATION_FAILED_EXT) => {}
        Err(result) => return Err(GpuError::Vk { call: "vkCreateSampler", result }),
    }
    Ok(gpu.validation_errors().split_off(before))
}

/// Run `shader` (relative to shaders-glsl) with `count` invocations over `input`; return
/// `output_len` floats of `data_out`.
pub fn run_f32_kernel(gpu: &Gpu, shader: &str, input: &[f32], output_len: usize, count: u32) -> Result<Vec<f32>> {
    let pipe = gpu.create_compute_pipeline(shader, &[])?;
    let input_buf = gpu.upload_buffer("kernel-input", BufferDesc::gpu_only(4), input);
    let output_buf = gpu.create_buffer("kernel-output", BufferDesc::gpu_only((output_len.max(1) * 4) as u64));
    let result = match (&input_buf, &output_buf) {
        (Ok(i), Ok(o)) => {
            let mut frame = gpu.create_frame()?;
            let r = gpu
                .run_frame(&mut frame, None, None, |rec| {
                    rec.begin_pass("kernel");
                    rec.dispatch(
                        &pipe,
                        &[Binding::buffer("Input", i), Binding::buffer("Output", o)],
                        bytemuck::bytes_of(&count),
                        [count, 1, 1],
                    )
                })
                .and_then(|_| gpu.read_buffer::<f32>(o));
            gpu.destroy_frame(frame);
            r.map(|mut v| {
                v.truncate(output_len);
                v
            })
        }
        (Err(e), _) | (_, Err(e)) => Err(GpuError::Other(e.to_string())),
    };
    if let Ok(b) = input_buf {
        gpu.destroy_buffer(b);
    }
    if let Ok(b) = output_buf {
        gpu.destroy_buffer(b);
    }
    gpu.destroy_compute_pipeline(pipe);
    result
}
