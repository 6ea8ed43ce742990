//! Shared checks of the GPU-vs-CPU twin tests (math_gpu_*.rs): every comparison is
//! `|gpu − cpu| ≤ tol` with a tolerance derived beside the call, and the worst `error / tol` of each
//! output is printed (`--nocapture`) so that a reader can see how tight each bound is.

#![allow(dead_code)] // each test binary uses a subset

use std::collections::BTreeMap;

/// f32 unit roundoff, 2⁻²⁴.
pub const EPS: f64 = 5.960464477539063e-8;
/// Smallest normal f32: results below it may be flushed to zero (or be denormal) on the GPU.
pub const F32_MIN_NORMAL: f64 = 1.1754943508222875e-38;
/// Absolute error of GLSL `log` on [0.5, 2] allowed by the Vulkan spec (2⁻²¹); outside it 3 ulp.
/// (lavapipe: 1.5e-7 near 1, which is why a log1p written `log(u)·x/(u − 1)` is not accurate there.)
pub const LOG_ABS: f64 = 4.76837158203125e-7;
/// GLSL `exp(x)` is taken accurate to `(EXP_ULP + 2|x|)` ulp: the spec says 3 + 2|x|, lavapipe
/// measures up to 10.5 ulp near x = 0 (math_gpu_sg.rs checks the bound).
pub const EXP_ULP: f64 = 12.0;
/// Absolute error of GLSL `atan` / `atan2` (lavapipe measures 3.4e-6; the spec allows 4096 ulp).
/// GLSL `asin` and `acos` are far looser on lavapipe (3.9e-4 and 1.6e-4): the twins avoid them.
pub const ATAN_ABS: f64 = 4e-6;

/// The worst error / tolerance seen per output name.
#[derive(Default)]
pub struct Checker {
    worst: BTreeMap<&'static str, (f64, String)>,
}

impl Checker {
    /// Assert `got` is finite and within `tol` of `want`.
    pub fn check(&mut self, name: &'static str, case: usize, got: f32, want: f64, tol: f64) {
        assert!(got.is_finite(), "case {case} {name}: GPU gave {got} (want {want})");
        assert!(want.is_finite(), "case {case} {name}: CPU twin gave {want}");
        let err = (got as f64 - want).abs();
        let ratio = err / tol;
        assert!(err <= tol, "case {case} {name}: GPU {got} vs CPU {want}: error {err:e} > tolerance {tol:e}");
        let e = self.worst.entry(name).or_insert((0.0, String::new()));
        if ratio > e.0 {
            *e = (ratio, format!("case {case}: err {err:.3e}, tol {tol:.3e}"));
        }
    }

    /// Assert exact equality (booleans as 0/1, clamped ends).
    pub fn exact(&mut self, name: &'static str, case: usize, got: f32, want: f64) {
        assert!(got as f64 == want, "case {case} {name}: GPU {got} vs CPU {want}");
        self.worst.entry(name).or_insert((0.0, String::from("exact")));
    }

    /// Print the worst ratio per output.
    pub fn report(&self, what: &str) {
        eprintln!("{what}: worst error / tolerance per output");
        for (name, (r, at)) in &self.worst {
            eprintln!("  {name:<28} {r:.3}  ({at})");
        }
    }
}

/// Every output float is finite (no NaN or inf may leave a twin).
pub fn assert_all_finite(out: &[f32], stride: usize) {
    for (i, v) in out.iter().enumerate() {
        assert!(v.is_finite(), "case {} output {}: {v}", i / stride, i % stride);
    }
}

pub fn f32v(v: [f64; 3]) -> [f32; 3] {
    v.map(|x| x as f32)
}

/// An f32 vector back in f64 (the CPU twin sees exactly the GPU's inputs).
pub fn f64v(v: [f32; 3]) -> [f64; 3] {
    v.map(|x| x as f64)
}

pub fn normalize(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|x| x / l)
}

pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a + s b`.
pub fn madd(a: [f64; 3], s: f64, b: [f64; 3]) -> [f64; 3] {
    [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]]
}

/// Log-uniform in [lo, hi].
pub fn log_uniform(rng: &mut engine::math::rng::Pcg32, lo: f64, hi: f64) -> f64 {
    rng.uniform(lo.ln(), hi.ln()).exp()
}
