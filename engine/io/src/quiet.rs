//! Parsers that may panic, contained without a word on stderr.
//!
//! `catch_unwind` stops a panic, but the panic hook has already printed `thread 'main' panicked at …` by then: a
//! user who gave a bad file saw that line before our `error:` line. [`catch_quiet`] installs, for as long as any
//! thread is inside it, a hook that says nothing for panics of threads inside it and hands every other panic to
//! the hook that was there before; the last thread to leave puts that hook back. The hook is process-wide and
//! tests run on parallel threads, hence a per-thread flag and a count of threads inside, not a swap per call (two
//! overlapping swaps would restore each other's hooks).

use std::cell::Cell;
use std::panic::{AssertUnwindSafe, PanicHookInfo};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

type Hook = Box<dyn Fn(&PanicHookInfo<'_>) + Send + Sync + 'static>;

thread_local! {
    /// How deep this thread is in [`catch_quiet`] (nested calls allowed).
    static QUIET: Cell<usize> = const { Cell::new(0) };
}

/// Threads inside [`catch_quiet`] (the quiet hook is installed while this is > 0).
static INSIDE: Mutex<usize> = Mutex::new(0);
/// The hook to forward other threads' panics to, and to restore. Locked only briefly, never while the
/// process's hook lock is wanted (a panicking thread holds that lock while it runs the hook).
static PREVIOUS: Mutex<Option<Arc<Hook>>> = Mutex::new(None);
/// Panics contained so far (the fuzzer reports them).
static CONTAINED: AtomicU64 = AtomicU64::new(0);

/// Panics [`catch_quiet`] has contained in this process.
pub fn contained_panics() -> u64 {
    CONTAINED.load(Ordering::Relaxed)
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    // A panic while a guard is held cannot leave these values half-written: use them as they are.
    m.lock().unwrap_or_else(|p| p.into_inner())
}

fn quiet_hook(info: &PanicHookInfo<'_>) {
    if QUIET.with(|q| q.get()) > 0 {
        CONTAINED.fetch_add(1, Ordering::Relaxed);
        return;
    }
    let previous = lock(&PREVIOUS).clone();
    if let Some(p) = previous {
        p(info);
    }
}

fn enter() {
    let mut inside = lock(&INSIDE);
    if *inside == 0 {
        let previous = std::panic::take_hook();
        *lock(&PREVIOUS) = Some(Arc::new(previous));
        std::panic::set_hook(Box::new(quiet_hook));
    }
    *inside += 1;
}

fn leave() {
    let mut inside = lock(&INSIDE);
    *inside -= 1;
    if *inside == 0 {
        // Waits for any panic hook still running; after it nothing else holds the previous hook.
        drop(std::panic::take_hook());
        if let Some(previous) = lock(&PREVIOUS).take() {
            let hook = Arc::try_unwrap(previous).unwrap_or_else(|shared| Box::new(move |i| shared(i)));
            std::panic::set_hook(hook);
        }
    }
}

/// Run `f`; a panic inside it becomes `Err(its message)` and prints nothing. Panics of other threads meanwhile
/// print as before.
pub fn catch_quiet<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    enter();
    QUIET.with(|q| q.set(q.get() + 1));
    let result = std::panic::catch_unwind(AssertUnwindSafe(f));
    QUIET.with(|q| q.set(q.get() - 1));
    leave();
    result.map_err(|payload| match payload.downcast_ref::<&str>() {
        Some(s) => s.to_string(),
        None => payload.downcast_ref::<String>().cloned().unwrap_or_else(|| "a panic".into()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicUsize;

    /// One test for the whole hook life cycle: the hook is process-wide, so its checks must not run beside
    /// another test of this crate that swaps it.
    #[test]
    fn contained_panics_are_silent_counted_and_the_previous_hook_returns() {
        static SEEN: AtomicUsize = AtomicUsize::new(0);
        let original = std::panic::take_hook();
        std::panic::set_hook(Box::new(|_| {
            SEEN.fetch_add(1, Ordering::SeqCst);
        }));
        let before = contained_panics();
        let r: Result<(), String> = catch_quiet(|| panic!("bad input {}", 7));
        assert_eq!(r.unwrap_err(), "bad input 7");
        assert_eq!(SEEN.load(Ordering::SeqCst), 0, "the contained panic reached the previous hook");
        assert_eq!(contained_panics(), before + 1);
        // Nested, and a value through.
        assert_eq!(catch_quiet(|| catch_quiet(|| 5).unwrap() + 1), Ok(6));
        // Outside, the previous hook is back.
        let _ = std::panic::catch_unwind(|| panic!("loud"));
        assert_eq!(SEEN.load(Ordering::SeqCst), 1, "the previous hook was not restored");
        // Another thread's panic while this one is inside goes to the previous hook.
        let r = catch_quiet(|| {
            let _ = std::thread::spawn(|| panic!("other thread")).join();
            7
        });
        assert_eq!(r, Ok(7));
        assert_eq!(SEEN.load(Ordering::SeqCst), 2, "another thread's panic was swallowed");
        std::panic::set_hook(original);
    }
}
