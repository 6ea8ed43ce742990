//! The GPU layer itself: kernels run, bindings are checked by name, errors name files and lines,
//! leaks and validation errors fail teardown.

use engine::gpu::testing::{run_f32_kernel, test_gpu};
use engine::gpu::{Binding, BufferDesc};

#[test]
fn kernel_harness_round_trip() {
    let gpu = test_gpu().expect("GPU");
    let input: Vec<f32> = (0..1000).map(|i| i as f32 * 0.5).collect();
    let out = run_f32_kernel(&gpu, "tests/smoke.comp", &input, 1000, 1000).expect("kernel");
    for (i, (x, y)) in input.iter().zip(&out).enumerate() {
        assert_eq!(*y, 2.0 * x + i as f32);
    }
    gpu.shutdown().expect("clean teardown");
}

#[test]
fn bindings_are_checked_by_name() {
    let gpu = test_gpu().expect("GPU");
    let pipe = gpu.create_compute_pipeline("tests/smoke.comp", &[]).expect("pipeline");
    let names: Vec<&str> = pipe.bindings().iter().map(|b| b.name.as_str()).collect();
    assert_eq!(names, ["Input", "Output"]);
    assert_eq!(pipe.push_constant_size(), 4);
    let buf = gpu.create_buffer("b", BufferDesc::gpu_only(64)).expect("buffer");
    let mut frame = gpu.create_frame().expect("frame");
    let err = gpu
        .run_frame(&mut frame, None, None, |rec| {
            rec.dispatch(
                &pipe,
                &[Binding::buffer("Input", &buf), Binding::buffer("Outptu", &buf)],
                &4u32.to_le_bytes(),
                [1, 1, 1],
            )
        })
        .unwrap_err()
        .to_string();
    assert!(err.contains("Output") && err.contains("not given"), "{err}");
    let err = gpu
        .run_frame(&mut frame, None, None, |rec| {
            rec.dispatch(
                &pipe,
                &[Binding::buffer("Input", &buf), Binding::buffer("Output", &buf)],
                &[0u8; 8],
                [1, 1, 1],
            )
        })
        .unwrap_err()
        .to_string();
    assert!(err.contains("push constants"), "{err}");
    gpu.destroy_frame(frame);
    gpu.destroy_buffer(buf);
    gpu.destroy_compute_pipeline(pipe);
    gpu.shutdown().expect("clean teardown");
}

#[test]
fn compile_errors_name_file_and_line() {
    let dir = std::env::temp_dir().join(format!("shader-err-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("common")).unwrap();
    std::fs::write(dir.join("common/bad.glsl"), "float f() {\n  return undefined_thing;\n}\n").unwrap();
    std::fs::write(
        dir.join("main.comp"),
        "#version 460\n#extension GL_GOOGLE_include_directive : require\n#include \"common/bad.glsl\"\nlayout(local_size_x=1) in;\nvoid main() { f(); }\n",
    )
    .unwrap();
    let c = engine::gpu::ShaderCompiler::new(dir.clone()).unwrap();
    let err = c.compile("main.comp", engine::gpu::ShaderStage::Compute, &[]).unwrap_err().to_string();
    assert!(err.contains("common/bad.glsl:2"), "{err}");
    assert!(err.contains("undefined_thing"), "{err}");
    // Warnings are errors too.
    std::fs::write(dir.join("warn.comp"), "#version 460\nlayout(local_size_x=1) in;\nvoid main() { int x = 1.0; }\n")
        .unwrap();
    assert!(c.compile("warn.comp", engine::gpu::ShaderStage::Compute, &[]).is_err());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn leaks_fail_teardown() {
    let gpu = test_gpu().expect("GPU");
    let leaked = gpu.create_buffer("deliberately-leaked", BufferDesc::gpu_only(256)).expect("buffer");
    std::mem::forget(leaked);
    let err = gpu.shutdown().unwrap_err().to_string();
    assert!(err.contains("deliberately-leaked"), "{err}");
}
