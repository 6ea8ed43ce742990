//! Device loss and hangs: every fence wait is bounded (engine::gpu::watchdog); a submission that runs past the
//! timeout, or a lost device, is an error naming what was running, never a hang or a panic, and the context
//! still tears down without a leak or a validation error.
//!
//! The hang is real: a test-only shader (shaders-glsl/tests/spin.comp) made to run longer than a timeout the
//! test sets. Device loss is simulated (lavapipe cannot lose a device): the hook in `engine::gpu` makes the
//! next fence wait report VK_ERROR_DEVICE_LOST.

use engine::gpu::{Binding, BufferDesc, ComputePipeline, Frame, Gpu, GpuError, Result};
use std::time::{Duration, Instant};

/// The most loop iterations per invocation of the spin shader (under llvmpipe's 65535 cap; the shader clamps).
const MAX_ITERATIONS: u32 = 60000;

/// How much the spin pass does: `iterations` per invocation (≤ [`MAX_ITERATIONS`]) over `rows` × 65536.
#[derive(Clone, Copy, Debug)]
struct Work {
    iterations: u32,
    rows: u32,
}

impl Work {
    const TINY: Work = Work { iterations: 1, rows: 1 };

    /// Twice as much: more iterations first, then more rows.
    fn doubled(self) -> Work {
        match self.iterations * 2 <= MAX_ITERATIONS {
            true => Work { iterations: self.iterations * 2, ..self },
            false => Work { rows: self.rows * 2, ..self },
        }
    }
}

/// One frame: a tiny `before` pass, `spin` doing `work`, a tiny `after` pass.
fn spin_frame(
    gpu: &Gpu,
    frame: &mut Frame,
    pipe: &ComputePipeline,
    out: &engine::gpu::Buffer,
    work: Work,
) -> Result<()> {
    let bind = [Binding::buffer("Output", out)];
    gpu.run_frame(frame, None, None, |rec| {
        rec.begin_pass("before");
        rec.dispatch(pipe, &bind, bytemuck::bytes_of(&1u32), [64, 1, 1])?;
        rec.begin_pass("spin");
        rec.dispatch(pipe, &bind, bytemuck::bytes_of(&work.iterations), [65536, work.rows, 1])?;
        rec.begin_pass("after");
        rec.dispatch(pipe, &bind, bytemuck::bytes_of(&1u32), [64, 1, 1])
    })
    .map(|_| ())
}

#[test]
fn a_pass_that_runs_too_long_is_a_timeout_naming_it() {
    let gpu = engine_tests::gpu();
    assert_eq!(gpu.fence_timeout(), engine::gpu::DEFAULT_FENCE_TIMEOUT, "no ENGINE_FENCE_TIMEOUT_S in the tests");
    let pipe = gpu.create_compute_pipeline("tests/spin.comp", &[]).unwrap();
    let out = gpu.create_buffer("spin-out", BufferDesc::gpu_only(4096)).unwrap();
    let mut frame = gpu.create_frame().unwrap();
    // Calibrate: grow the spin pass until one frame takes ≥ 0.3 s under the default timeout (on any machine).
    let mut work = Work { iterations: 500, rows: 1 };
    let took = loop {
        let t0 = Instant::now();
        spin_frame(&gpu, &mut frame, &pipe, &out, work).unwrap();
        let took = t0.elapsed();
        if took >= Duration::from_millis(300) || work.rows >= 1 << 12 {
            break took;
        }
        work = work.doubled();
    };
    assert!(took >= Duration::from_millis(300), "{work:?} took only {took:?}");
    // A twentieth of that: the same frame must time out, and the error must say the spin pass was running.
    let limit = took / 20;
    gpu.set_fence_timeout(limit);
    let t0 = Instant::now();
    let err = spin_frame(&gpu, &mut frame, &pipe, &out, work).unwrap_err();
    let waited = t0.elapsed();
    let msg = err.to_string();
    assert!(matches!(err, GpuError::Timeout { .. }), "{msg}");
    assert!(msg.contains("pass 'spin' was running"), "{msg}");
    assert!(msg.contains("finished: before") && msg.contains("not started: after"), "{msg}");
    assert!(msg.contains("ENGINE_FENCE_TIMEOUT_S"), "{msg}");
    assert!(waited < took, "the error came after {waited:?}, the frame takes {took:?}");
    eprintln!("calibrated frame {took:?} ({work:?}); timeout {limit:?}; error after {waited:?}: {msg}");
    // The frame is reusable after the timeout (its submission is drained first) and the context is sound.
    gpu.set_fence_timeout(engine::gpu::DEFAULT_FENCE_TIMEOUT);
    spin_frame(&gpu, &mut frame, &pipe, &out, Work::TINY).unwrap();
    // Time out once more and destroy everything at once: the destroys wait for the device (validation clean).
    gpu.set_fence_timeout(limit);
    assert!(matches!(spin_frame(&gpu, &mut frame, &pipe, &out, work), Err(GpuError::Timeout { .. })));
    gpu.destroy_frame(frame);
    gpu.destroy_buffer(out);
    gpu.destroy_compute_pipeline(pipe);
    gpu.shutdown().unwrap();
}

#[test]
fn a_lost_device_is_an_error_naming_the_submission_and_is_permanent() {
    let gpu = engine_tests::gpu();
    let pipe = gpu.create_compute_pipeline("tests/spin.comp", &[]).unwrap();
    let out = gpu.create_buffer("spin-out", BufferDesc::gpu_only(4096)).unwrap();
    let mut frame = gpu.create_frame().unwrap();
    spin_frame(&gpu, &mut frame, &pipe, &out, Work::TINY).unwrap();
    assert!(!gpu.is_lost());
    gpu.simulate_device_loss_after(1);
    let err = spin_frame(&gpu, &mut frame, &pipe, &out, Work::TINY).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, GpuError::DeviceLost { .. }), "{msg}");
    assert!(msg.contains("VK_ERROR_DEVICE_LOST"), "{msg}");
    assert!(msg.contains("a frame with passes [before, spin, after]"), "{msg}");
    assert!(gpu.is_lost());
    // Permanent, as a real loss: frames and one-time submissions are refused, without touching the queue.
    let again = spin_frame(&gpu, &mut frame, &pipe, &out, Work::TINY).unwrap_err().to_string();
    assert!(again.contains("refused") && again.contains("VK_ERROR_DEVICE_LOST"), "{again}");
    let read = gpu.read_buffer::<f32>(&out).unwrap_err().to_string();
    assert!(read.contains("a buffer readback") && read.contains("refused"), "{read}");
    // Teardown is clean: no leak, no validation error (the destroys wait for the abandoned submission).
    gpu.destroy_frame(frame);
    gpu.destroy_buffer(out);
    gpu.destroy_compute_pipeline(pipe);
    gpu.shutdown().unwrap();
}

#[test]
fn a_lost_device_during_an_upload_names_it() {
    let gpu = engine_tests::gpu();
    gpu.simulate_device_loss_after(1);
    let Err(err) = gpu.upload_buffer("data", BufferDesc::gpu_only(16), &[1.0f32; 4]) else {
        panic!("the upload succeeded on a lost device")
    };
    let msg = err.to_string();
    assert!(msg.contains("a buffer upload") && msg.contains("VK_ERROR_DEVICE_LOST"), "{msg}");
    gpu.shutdown().unwrap();
}

#[test]
fn the_timeout_variable_is_checked() {
    use engine::gpu::parse_fence_timeout;
    assert_eq!(parse_fence_timeout("2.5"), Ok(Duration::from_millis(2500)));
    assert_eq!(parse_fence_timeout(" 60 "), Ok(Duration::from_secs(60)));
    for bad in ["", "x", "0", "-1", "nan", "inf", "1e9"] {
        let e = parse_fence_timeout(bad).unwrap_err();
        assert!(e.contains("ENGINE_FENCE_TIMEOUT_S"), "{bad}: {e}");
    }
}
