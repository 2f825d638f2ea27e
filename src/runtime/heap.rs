//! Free heap handed back to the system after a build. The binary keeps freed memory on
//! purpose (large trim threshold and top pad, `keep_freed_memory` in `cli::app`), so that the
//! stepping thread does not fault pages in again every step; a build's temporaries (tens of
//! MB, freed in another order than taken) then left holes that the resident memory kept and
//! grew by, a megabyte or so a minute under `bench soak`'s stream of shapes.

/// Returns the heaps' free pages to the system (glibc's `malloc_trim`); a no-op elsewhere.
/// Called on the build thread once a build is handed over, never on the stepping thread:
/// it takes each heap's lock in turn, for 0.6 to 19 ms (median 6.9) under `bench soak`,
/// which missed no tick with it.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
pub(crate) fn release_free_heap() {
    let started = std::time::Instant::now();
    // SAFETY: malloc_trim only returns free memory to the system, under the allocator's locks.
    unsafe {
        libc::malloc_trim(0);
    }
    log::debug!(
        "free heap returned in {:.3} ms",
        started.elapsed().as_secs_f64() * 1e3
    );
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
pub(crate) fn release_free_heap() {}
