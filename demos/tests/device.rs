//! A device choice that fails (`--device` naming no adapter) is an error that names the text asked for and
//! lists the adapters present, and exits with status 1 after tearing down in order. It used to run
//! `vkDestroyDebugUtilsMessengerEXT` after libvulkan was unloaded: exit 139 (SIGSEGV), no message.

use engine::gpu::{Gpu, GpuDesc, ValidationMode};
use std::process::Command;

const NO_SUCH: &str = "NoSuchGPU-7f3a";

#[test]
fn demo_with_an_unknown_device_exits_with_a_message() {
    for validation in ["1", "0"] {
        let out = Command::new(env!("CARGO_BIN_EXE_demo"))
            .args(["--device", NO_SUCH, "--width", "64", "--height", "48"])
            .env("ENGINE_VALIDATION", validation)
            .output()
            .expect("run demo");
        let stderr = String::from_utf8_lossy(&out.stderr);
        // `code()` is None when a signal ended the process (the segfault this guards against).
        assert_eq!(out.status.code(), Some(1), "ENGINE_VALIDATION={validation}: {:?}\n{stderr}", out.status);
        assert!(stderr.contains(NO_SUCH), "the error names the device text: {stderr}");
        assert!(
            stderr.contains("available adapters") || stderr.contains("Install a driver"),
            "the error says what is available or how to get a device: {stderr}"
        );
        assert!(!stderr.contains("validation error"), "{stderr}");
    }
}

#[test]
fn gpu_new_with_an_unknown_device_is_an_error() {
    // Twice in one process: a broken teardown (loader unloaded under it) would crash on the first, a
    // leaked instance or messenger would show up as a validation complaint on the second.
    for _ in 0..2 {
        let desc = GpuDesc {
            validation: ValidationMode::Required,
            device_name: Some(NO_SUCH.into()),
            verbose: false,
            ..GpuDesc::default()
        };
        let err = match Gpu::new(&desc) {
            Ok(_) => panic!("an adapter matched {NO_SUCH:?}"),
            Err(e) => e.to_string(),
        };
        assert!(err.contains(NO_SUCH), "{err}");
        assert!(err.contains("available adapters") || err.contains("Install a driver"), "{err}");
    }
    // The normal path still works in the same process afterwards.
    let gpu = Gpu::new(&GpuDesc { validation: ValidationMode::Required, verbose: false, ..GpuDesc::default() })
        .expect("default device");
    gpu.shutdown().expect("clean teardown");
}
