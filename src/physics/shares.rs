//! Work over the cubature points split in two from a caller outside the thread pool (the
//! solver's thread, with the helper thread), or over the pool from within it (a scene's
//! objects stepped side by side, builds).

use super::helper;

/// `share` of each of the runs of `0..np`, in order: two runs from outside the thread pool,
/// the first on the calling thread and the second on the helper thread (`helper::join`); as
/// many as the pool has threads from within it, the first on the calling thread, the others
/// on the pool. From outside the pool, rayon woke a sleeping worker and the caller slept on a
/// latch: at 512 points and 17 handles an assembly's split that way cost 0.712-0.773 ms (its
/// median) against 1.250-1.384 ms with a parallel iterator (two workers to wake), and a force
/// evaluation's split cost more than it saved (see `helper`).
pub(crate) fn shared_out<T: Send>(
    np: usize,
    share: impl Fn(std::ops::Range<usize>) -> T + Sync,
) -> Vec<T> {
    if rayon::current_thread_index().is_none() {
        if np < 2 {
            return vec![share(0..np)];
        }
        let half = np.div_ceil(2);
        let (first, second) = helper::join(|| share(0..half), || share(half..np));
        return vec![first, second];
    }
    let per_run = np.div_ceil(rayon::current_num_threads().max(1)).max(1);
    let run = |r: usize| r * per_run..((r + 1) * per_run).min(np);
    let mut others: Vec<Option<T>> = (1..np.div_ceil(per_run)).map(|_| None).collect();
    let mut first = None;
    rayon::in_place_scope(|scope| {
        for (r, slot) in (1..).zip(others.iter_mut()) {
            let (share, run) = (&share, &run);
            scope.spawn(move |_| *slot = Some(share(run(r))));
        }
        first = Some(share(run(0)));
    });
    first
        .into_iter()
        .chain(others.into_iter().flatten())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every point's share once, in order, whatever the split: in two from this test's
    /// thread, over the pool from within it.
    #[test]
    fn shared_out_covers_every_point_once_in_order() {
        for np in [1, 2, 7, 1000] {
            let runs = shared_out(np, |run| run.collect::<Vec<usize>>());
            assert!(runs.len() <= rayon::current_num_threads().max(2));
            assert_eq!(runs.concat(), (0..np).collect::<Vec<_>>(), "{np} points");
            let pooled = rayon::scope(|_| shared_out(np, |run| run.collect::<Vec<usize>>()));
            assert_eq!(
                pooled.concat(),
                (0..np).collect::<Vec<_>>(),
                "{np} points, pooled"
            );
        }
    }
}
