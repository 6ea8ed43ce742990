//! Bounded fence waits: every wait for a submission has a timeout, and a timed-out submission or a lost
//! device becomes a [`GpuError`] naming the submission (and, for frames, the pass that was running), never a
//! hang or a panic.
//!
//! Why a timeout at all: a shader that never ends (a loop whose bound came from bad data) or a driver that
//! stops answering would otherwise block `vkWaitForFences(.., u64::MAX)` forever, with no message. With the
//! timeout the process reports what was running and exits.
//!
//! After a timeout the submission may still be executing: its command buffer, fence and every resource it
//! reads are in use. Destroying any of them then is invalid (and the validation layer says so), so the wait
//! marks the context as *draining*, and the next destroy (or teardown) waits for the device to be idle first
//! ([`Watchdog::drain`]). On a real hang that wait ends when the driver gives up on the device (then
//! `vkDeviceWaitIdle` returns `VK_ERROR_DEVICE_LOST`); the error has been returned to the caller before it.
//!
//! A lost device is permanent (Vulkan spec, "Lost Device"): later submissions are refused with the same
//! error kind instead of being sent to a dead queue.
//!
//! Lavapipe cannot lose a device, so a test hook simulates it: [`Gpu::simulate_device_loss_after`] (or
//! `ENGINE_SIMULATE_DEVICE_LOSS=N` in the environment) makes the N-th fence wait from then on report
//! `VK_ERROR_DEVICE_LOST` as if the driver had.

use super::{Gpu, GpuError, Result, VkCheck};
use ash::vk;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

/// The default limit on one fence wait: 120 s. Generous on purpose: the slowest legitimate submission in this
/// project is a 64-sample reference frame at 1920×1080 on lavapipe (2 cores), which takes tens of seconds, and
/// a false timeout would kill a correct run. `ENGINE_FENCE_TIMEOUT_S` overrides it (seconds, > 0, may be
/// fractional), as does [`Gpu::set_fence_timeout`].
pub const DEFAULT_FENCE_TIMEOUT: Duration = Duration::from_secs(120);

/// The environment variable that sets the fence timeout in seconds.
pub const FENCE_TIMEOUT_ENV: &str = "ENGINE_FENCE_TIMEOUT_S";

/// The environment variable of the device-loss test hook: the N-th fence wait reports a lost device.
pub const SIMULATE_LOSS_ENV: &str = "ENGINE_SIMULATE_DEVICE_LOSS";

/// The timeout from the value of [`FENCE_TIMEOUT_ENV`]: a finite number of seconds > 0 (at least 1 µs, at most
/// a year), or an error saying what was wrong.
pub fn parse_fence_timeout(value: &str) -> std::result::Result<Duration, String> {
    let s: f64 = value.trim().parse().map_err(|_| format!("{FENCE_TIMEOUT_ENV}={value}: not a number of seconds"))?;
    if !s.is_finite() || s <= 0.0 || s > 365.0 * 86400.0 {
        return Err(format!("{FENCE_TIMEOUT_ENV}={value}: must be a number of seconds in (0, 31536000]"));
    }
    Ok(Duration::from_secs_f64(s.max(1e-6)))
}

/// The fence-wait state of one [`Gpu`].
pub(crate) struct Watchdog {
    timeout_ns: AtomicU64,
    /// A submission was given up on (timed out, or the device was reported lost) and may still run.
    draining: AtomicBool,
    /// The device was lost: every later submission is refused.
    lost: AtomicBool,
    /// Test hook: when > 0, counts fence waits down; the wait that brings it to 0 reports a lost device.
    simulate_loss_in: AtomicU64,
}

impl Watchdog {
    /// From the environment ([`FENCE_TIMEOUT_ENV`], [`SIMULATE_LOSS_ENV`]); a malformed value is an error, not
    /// a silent default.
    pub(crate) fn from_env() -> Result<Self> {
        let timeout = match std::env::var(FENCE_TIMEOUT_ENV) {
            Ok(v) if !v.trim().is_empty() => parse_fence_timeout(&v).map_err(GpuError::Other)?,
            _ => DEFAULT_FENCE_TIMEOUT,
        };
        let loss = match std::env::var(SIMULATE_LOSS_ENV) {
            Ok(v) if !v.trim().is_empty() => v.trim().parse::<u64>().map_err(|_| {
                GpuError::Other(format!("{SIMULATE_LOSS_ENV}={v}: not a count of fence waits (0: off)"))
            })?,
            _ => 0,
        };
        Ok(Self {
            timeout_ns: AtomicU64::new(timeout.as_nanos().min(u64::MAX as u128) as u64),
            draining: AtomicBool::new(false),
            lost: AtomicBool::new(false),
            simulate_loss_in: AtomicU64::new(loss),
        })
    }

    /// Clear the draining mark (teardown, which waits for idle itself); whether it was set.
    pub(crate) fn take_draining(&self) -> bool {
        self.draining.swap(false, Ordering::Relaxed)
    }
}

impl Gpu {
    /// The limit on one fence wait ([`DEFAULT_FENCE_TIMEOUT`] unless `ENGINE_FENCE_TIMEOUT_S` or
    /// [`Gpu::set_fence_timeout`] changed it).
    pub fn fence_timeout(&self) -> Duration {
        Duration::from_nanos(self.watchdog.timeout_ns.load(Ordering::Relaxed))
    }

    /// Change the limit on fence waits (at least 1 ns).
    pub fn set_fence_timeout(&self, timeout: Duration) {
        let ns = timeout.as_nanos().clamp(1, u64::MAX as u128) as u64;
        self.watchdog.timeout_ns.store(ns, Ordering::Relaxed);
    }

    /// Test hook (lavapipe cannot lose a device): the `n`-th fence wait from now (1: the next) reports
    /// `VK_ERROR_DEVICE_LOST` without waiting, and the context behaves as after a real loss. 0 turns it off.
    pub fn simulate_device_loss_after(&self, n: u64) {
        self.watchdog.simulate_loss_in.store(n, Ordering::Relaxed);
    }

    /// Whether the device was lost (really or by the test hook).
    pub fn is_lost(&self) -> bool {
        self.watchdog.lost.load(Ordering::Relaxed)
    }

    /// Refuse a submission on a lost device.
    pub(crate) fn check_not_lost(&self, submission: &str) -> Result<()> {
        if self.is_lost() {
            return Err(GpuError::DeviceLost {
                submission: submission.to_string(),
                detail: "refused: the device was lost by an earlier submission".into(),
            });
        }
        Ok(())
    }

    /// Wait for `fence` at most [`Gpu::fence_timeout`]. `describe` names the submission (called only on
    /// failure, so a steady frame formats nothing).
    pub(crate) fn wait_fence(&self, fence: vk::Fence, describe: impl FnOnce() -> String) -> Result<()> {
        let hook = self.watchdog.simulate_loss_in.load(Ordering::Relaxed);
        if hook > 0 {
            self.watchdog.simulate_loss_in.store(hook - 1, Ordering::Relaxed);
            if hook == 1 {
                self.watchdog.lost.store(true, Ordering::Relaxed);
                self.watchdog.draining.store(true, Ordering::Relaxed);
                return Err(GpuError::DeviceLost {
                    submission: describe(),
                    detail: format!("simulated by the test hook ({SIMULATE_LOSS_ENV})"),
                });
            }
        }
        let timeout = self.fence_timeout();
        // SAFETY: the fence belongs to this device and was submitted with work.
        match unsafe { self.device.wait_for_fences(&[fence], true, timeout.as_nanos() as u64) } {
            Ok(()) => Ok(()),
            Err(vk::Result::TIMEOUT) => {
                self.watchdog.draining.store(true, Ordering::Relaxed);
                Err(GpuError::Timeout { submission: describe(), seconds: timeout.as_micros() as f64 * 1e-6 })
            }
            Err(vk::Result::ERROR_DEVICE_LOST) => {
                self.watchdog.lost.store(true, Ordering::Relaxed);
                self.watchdog.draining.store(true, Ordering::Relaxed);
                Err(GpuError::DeviceLost { submission: describe(), detail: "reported by vkWaitForFences".into() })
            }
            Err(e) => Err(GpuError::Vk { call: "vkWaitForFences", result: e }),
        }
    }

    /// After a submission was given up on, wait for the device to be idle before anything it may use is
    /// destroyed or reused (see the module notes). Cheap when nothing was given up on.
    pub(crate) fn drain(&self) {
        if self.watchdog.take_draining() {
            // SAFETY: valid device. A lost device returns VK_ERROR_DEVICE_LOST at once; then destroying is allowed.
            if let Err(e) = unsafe { self.device.device_wait_idle() }.vk("vkDeviceWaitIdle") {
                log::warn!("waiting for the device after a failed submission: {e}");
            }
        }
    }
}
