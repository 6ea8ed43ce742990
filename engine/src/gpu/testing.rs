//! Test harness for GLSL kernels: run a compute shader over an input buffer of floats and read
//! the output back. Used by the GPU-vs-CPU tests of every `shaders-glsl/common` twin.
//!
//! The shader's interface (see shaders-glsl/tests/*_twin.comp):
//! ```glsl
//! layout(std430, set = 0, binding = 0) readonly buffer Input { float data_in[]; };
//! layout(std430, set = 0, binding = 1) writeonly buffer Output { float data_out[]; };
//! layout(push_constant) uniform Push { uint count; } pc;
//! ```

use super::{Binding, BufferDesc, Gpu, GpuDesc, Result, ValidationMode};

/// A GPU context for tests: validation layer required, quiet.
pub fn test_gpu() -> Result<Gpu> {
    Gpu::new(&GpuDesc { validation: ValidationMode::Required, verbose: false, ..GpuDesc::default() })
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
        (Err(e), _) | (_, Err(e)) => Err(super::GpuError::Other(e.to_string())),
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
