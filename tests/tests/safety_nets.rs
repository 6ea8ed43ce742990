//! The safety nets fail when they should: a deliberate validation error and a deliberate leak fail
//! `shutdown()`, and fail a test that forgets `shutdown()` (engine::gpu::testing::TestGpu), without a
//! double panic aborting the test binary when the test was failing already.
//!
//! The "forgotten shutdown" cases run as real tests in a child process (this test binary, filtered to
//! one ignored child test), so what is checked is the harness's verdict on such a test: it fails,
//! with exit status 101 (a test failure), not an abort.

use engine::gpu::testing::{provoke_validation_error, test_gpu};
use engine::gpu::BufferDesc;
use std::process::Command;

/// Set in the child process: which child test is meant to run.
const CHILD: &str = "ENGINE_SAFETY_NET_CHILD";

#[test]
fn a_validation_error_fails_shutdown() {
    let gpu = test_gpu().expect("GPU");
    let seen = provoke_validation_error(&gpu).expect("the canary call");
    assert!(!seen.is_empty(), "the validation layer reported nothing for the canary call");
    assert!(seen.iter().any(|e| e.contains("anisotropy")), "{seen:?}");
    let err = gpu.shutdown().unwrap_err().to_string();
    assert!(err.contains("validation error") && err.contains("anisotropy"), "{err}");
}

// (A deliberate leak failing shutdown(): gpu_backend.rs, leaks_fail_teardown.)

#[test]
fn a_clean_test_that_forgets_shutdown_passes() {
    let gpu = test_gpu().expect("GPU");
    gpu.destroy_buffer(gpu.create_buffer("kept-tidy", BufferDesc::gpu_only(256)).expect("buffer"));
    drop(gpu); // no shutdown(): nothing to report, no panic
}

/// Runs child test `name` of this binary; returns (exit code, stdout + stderr).
fn run_child(name: &str) -> (Option<i32>, String) {
    let out = Command::new(std::env::current_exe().expect("test binary"))
        .args(["--ignored", "--exact", name, "--test-threads=1", "--nocapture"])
        .env(CHILD, name)
        .output()
        .expect("run the test binary");
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    (out.status.code(), text)
}

/// A child test body runs only in the child process it was started for (so `--include-ignored` runs
/// of the whole suite do not fail on these deliberate failures).
fn is_child(name: &str) -> bool {
    std::env::var(CHILD).is_ok_and(|v| v == name)
}

#[test]
fn a_test_that_forgets_shutdown_fails_on_a_validation_error() {
    let (code, out) = run_child("child_validation_error_without_shutdown");
    assert_eq!(code, Some(101), "the child test should fail (exit 101):\n{out}");
    assert!(out.contains("test child_validation_error_without_shutdown ... FAILED"), "{out}");
    assert!(out.contains("anisotropy") && out.contains("dropped without shutdown()"), "{out}");
}

#[test]
fn a_test_that_forgets_shutdown_fails_on_a_leak() {
    let (code, out) = run_child("child_leak_without_shutdown");
    assert_eq!(code, Some(101), "the child test should fail (exit 101):\n{out}");
    assert!(out.contains("leaked device allocation 'forgotten-buffer'"), "{out}");
    assert!(out.contains("dropped without shutdown()"), "{out}");
}

// A test that fails its own assertion while it also leaks: one failure (the assertion's), the leak
// printed, and the binary exits as a failed test (101), not by an abort from a second panic.
#[test]
fn a_failing_test_that_also_leaks_reports_its_own_failure() {
    let (code, out) = run_child("child_assertion_and_leak");
    assert_eq!(code, Some(101), "expected a test failure, not an abort:\n{out}");
    assert!(out.contains("the child's own assertion"), "{out}");
    assert!(out.contains("leaked device allocation 'leaked-while-failing'"), "{out}");
    assert!(out.contains("not raised again"), "{out}");
    assert!(!out.contains("panic in a destructor") && !out.contains("while processing panic"), "{out}");
}

#[test]
#[ignore = "deliberately fails: run as a child process by a_test_that_forgets_shutdown_fails_on_a_validation_error"]
fn child_validation_error_without_shutdown() {
    if !is_child("child_validation_error_without_shutdown") {
        return;
    }
    let gpu = test_gpu().expect("GPU");
    provoke_validation_error(&gpu).expect("the canary call");
}

#[test]
#[ignore = "deliberately fails: run as a child process by a_test_that_forgets_shutdown_fails_on_a_leak"]
fn child_leak_without_shutdown() {
    if !is_child("child_leak_without_shutdown") {
        return;
    }
    let gpu = test_gpu().expect("GPU");
    std::mem::forget(gpu.create_buffer("forgotten-buffer", BufferDesc::gpu_only(256)).expect("buffer"));
}

#[test]
#[ignore = "deliberately fails: run as a child process by a_failing_test_that_also_leaks_reports_its_own_failure"]
fn child_assertion_and_leak() {
    if !is_child("child_assertion_and_leak") {
        return;
    }
    let gpu = test_gpu().expect("GPU");
    std::mem::forget(gpu.create_buffer("leaked-while-failing", BufferDesc::gpu_only(256)).expect("buffer"));
    let answer = 41;
    assert_eq!(answer, 42, "the child's own assertion");
}
