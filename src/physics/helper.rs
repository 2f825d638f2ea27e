//! A second thread for the solver's two-way splits, kept awake for a short while after each
//! job so that the next one, tens of microseconds later, starts at once.
//!
//! A force evaluation at 1024 cubature points and K = 17 takes about 50 us on one thread. Split
//! over a rayon pool from the solver's thread, the hand-off (waking a sleeping worker, the
//! caller sleeping on a latch) cost more than the half it saved: the rod's poke went from a
//! median step of 0.767 and 0.746 ms to 1.317 and 1.473 ms (`bench sim --shape rod --scenario
//! poke --handles 16 --cubature 1024`, FEM left out, alternating runs, printed, 2026-12-03).
//! Handed to this thread, from 0.849 and 0.873 ms to 0.590 and 0.542 ms, and the poke's p99
//! from 2.567 and 2.416 ms to 1.877 and 1.856 ms.

use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use std::sync::{Mutex, OnceLock};
use std::thread::Thread;
use std::time::{Duration, Instant};

/// How long the helper stays awake for the next job (yielding its core whenever it looks)
/// before it sleeps. A solve's evaluations come 5-20 us apart and a factorization between them
/// takes 0.1-0.3 ms; between a node's ticks (milliseconds) it sleeps, so it spends at most this
/// much of a core after each solve, less where another thread wants the core.
const SPIN_WINDOW: Duration = Duration::from_micros(200);

/// How long the caller spins for the helper's share before it yields its core each time it
/// looks: the helper may be waiting for that core itself.
const CALLER_SPIN: Duration = Duration::from_micros(2);

const IDLE: u8 = 0;
const POSTED: u8 = 1;
const DONE: u8 = 2;

/// A job's closure with its lifetime erased: `join` does not return (nor unwind) before the
/// helper is done with it.
struct Job(*const (dyn Fn() + Sync));

// SAFETY: the closure behind the pointer is `Sync`, and `join` keeps it alive until the helper
// has run it (see `WaitForHelper`).
unsafe impl Send for Job {}

/// The state the caller and the helper thread share.
struct Shared {
    /// One caller at a time; another one runs both shares itself.
    caller: Mutex<()>,
    state: AtomicU8,
    job: Mutex<Option<Job>>,
    /// Set by the helper before it parks, so that a caller knows to unpark it.
    sleeping: AtomicBool,
    thread: OnceLock<Thread>,
}

/// The helper, started on first use where the machine has a second core.
fn shared() -> Option<&'static Shared> {
    static SHARED: OnceLock<Option<&'static Shared>> = OnceLock::new();
    *SHARED.get_or_init(|| {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        (cores >= 2).then(start).flatten()
    })
}

fn start() -> Option<&'static Shared> {
    let shared: &'static Shared = Box::leak(Box::new(Shared {
        caller: Mutex::new(()),
        state: AtomicU8::new(IDLE),
        job: Mutex::new(None),
        sleeping: AtomicBool::new(false),
        thread: OnceLock::new(),
    }));
    let handle = std::thread::Builder::new()
        .name("physskin-helper".into())
        .spawn(move || shared.serve())
        .ok()?;
    shared.thread.set(handle.thread().clone()).ok()?;
    Some(shared)
}

/// Runs `mine` on this thread and `theirs` on the helper at the same time, and returns both
/// results. Without a helper (one core), or while another thread uses it, both run here.
/// A panic in either is passed on once both are done.
pub(crate) fn join<A, B: Send>(mine: impl FnOnce() -> A, theirs: impl Fn() -> B + Sync) -> (A, B) {
    let Some(shared) = shared() else {
        return (mine(), theirs());
    };
    // A caller that panicked poisoned the lock but left the helper idle (`WaitForHelper`).
    let _caller = match shared.caller.try_lock() {
        Ok(guard) => guard,
        Err(std::sync::TryLockError::Poisoned(poisoned)) => poisoned.into_inner(),
        Err(std::sync::TryLockError::WouldBlock) => return (mine(), theirs()),
    };
    let result: Mutex<Option<std::thread::Result<B>>> = Mutex::new(None);
    let job = || {
        let outcome = catch_unwind(AssertUnwindSafe(&theirs));
        *result.lock().unwrap_or_else(|e| e.into_inner()) = Some(outcome);
    };
    let job: &(dyn Fn() + Sync + '_) = &job;
    // SAFETY: only the lifetime is erased; `wait` below outlives the helper's use of `job`.
    let job = Job(unsafe {
        std::mem::transmute::<*const (dyn Fn() + Sync + '_), *const (dyn Fn() + Sync + 'static)>(
            job,
        )
    });
    let wait = WaitForHelper(shared);
    shared.post(job);
    let mine = mine();
    drop(wait);
    let theirs = result.lock().unwrap_or_else(|e| e.into_inner()).take();
    match theirs.expect("the helper ran the job") {
        Ok(theirs) => (mine, theirs),
        Err(panic) => resume_unwind(panic),
    }
}

/// Waits for the helper to finish the posted job when dropped, also while unwinding: the job
/// borrows the caller's stack.
struct WaitForHelper(&'static Shared);

impl Drop for WaitForHelper {
    fn drop(&mut self) {
        let started = Instant::now();
        while self.0.state.load(Ordering::Acquire) != DONE {
            if started.elapsed() < CALLER_SPIN {
                std::hint::spin_loop();
            } else {
                std::thread::yield_now();
            }
        }
        self.0.state.store(IDLE, Ordering::Release);
    }
}

impl Shared {
    fn post(&self, job: Job) {
        *self.job.lock().unwrap_or_else(|e| e.into_inner()) = Some(job);
        self.state.store(POSTED, Ordering::SeqCst);
        // Paired with `wait_for_job`: either the helper sees the job before it parks, or this
        // sees it sleeping and unparks it (an unpark before the park makes the park return).
        if self.sleeping.load(Ordering::SeqCst) {
            if let Some(thread) = self.thread.get() {
                thread.unpark();
            }
        }
    }

    fn serve(&self) {
        loop {
            self.wait_for_job();
            let job = self.job.lock().unwrap_or_else(|e| e.into_inner()).take();
            if let Some(Job(job)) = job {
                // SAFETY: the caller waits for DONE before the closure goes out of scope.
                unsafe { (*job)() };
            }
            self.state.store(DONE, Ordering::Release);
        }
    }

    /// Looks for a job for up to [`SPIN_WINDOW`], then sleeps until one is posted.
    fn wait_for_job(&self) {
        let mut started = Instant::now();
        while self.state.load(Ordering::Acquire) != POSTED {
            if started.elapsed() < SPIN_WINDOW {
                // Yielding, not spinning: woken on the caller's core, the helper would
                // otherwise hold it from the caller until the scheduler moves one of them.
                std::thread::yield_now();
                continue;
            }
            self.sleeping.store(true, Ordering::SeqCst);
            if self.state.load(Ordering::SeqCst) != POSTED {
                std::thread::park();
            }
            self.sleeping.store(false, Ordering::SeqCst);
            started = Instant::now();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_shares_run_and_return_in_place() {
        for n in 0..200u64 {
            let (a, b) = join(|| n * 2, || n * 3);
            assert_eq!((a, b), (2 * n, 3 * n));
        }
    }

    /// Other tests may hold the helper for a while (then both shares run here): joins are
    /// tried for up to ten seconds, a millisecond apart, until one runs on two threads.
    #[test]
    fn the_second_share_runs_on_another_thread() {
        let here = std::thread::current().id();
        let started = Instant::now();
        let elsewhere = std::iter::repeat_with(|| {
            let (mine, theirs) = join(
                || std::thread::current().id(),
                || std::thread::current().id(),
            );
            assert_eq!(mine, here);
            std::thread::sleep(Duration::from_millis(1));
            theirs != here
        })
        .take_while(|_| started.elapsed() < Duration::from_secs(10))
        .any(|ran_elsewhere| ran_elsewhere);
        assert!(
            elsewhere || shared().is_none(),
            "the helper never ran a share"
        );
    }

    #[test]
    fn the_helpers_share_borrows_the_callers_data() {
        let data: Vec<u64> = (0..10_000).collect();
        let (first, second) = join(
            || data[..5000].iter().sum::<u64>(),
            || data[5000..].iter().sum::<u64>(),
        );
        assert_eq!(first + second, data.iter().sum::<u64>());
    }

    #[test]
    fn a_panic_on_the_helper_reaches_the_caller_and_the_helper_goes_on() {
        let caught = catch_unwind(|| join(|| 1, || -> u32 { panic!("the helper's share") }));
        assert!(caught.is_err());
        assert_eq!(join(|| 1, || 2), (1, 2));
    }

    #[test]
    fn callers_on_several_threads_each_get_their_own_results() {
        std::thread::scope(|scope| {
            for t in 0..4u64 {
                scope.spawn(move || {
                    for n in 0..500 {
                        assert_eq!(join(|| t + n, || t * n), (t + n, t * n));
                    }
                });
            }
        });
    }

    #[test]
    fn the_helper_wakes_after_sleeping() {
        assert_eq!(join(|| 1, || 2), (1, 2));
        std::thread::sleep(SPIN_WINDOW * 5);
        assert_eq!(join(|| 3, || 4), (3, 4));
    }
}
