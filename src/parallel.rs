//! Host-side work split over the CPU's cores with results in a fixed order, so that the
//! bytes do not depend on the number of threads or their timing (each item is computed
//! by one thread, alone, as a single thread would compute it).

/// `f(0), f(1), …, f(count - 1)` in index order, computed on up to
/// `std::thread::available_parallelism()` threads, each taking a contiguous run of indices.
pub fn ordered_map<T: Send>(count: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
    let threads = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
        .min(count.max(1));
    if threads <= 1 {
        return (0..count).map(&f).collect();
    }
    let per = count.div_ceil(threads);
    let f = &f;
    std::thread::scope(|scope| {
        let runs: Vec<_> = (0..threads)
            .map(|t| {
                let range = (t * per).min(count)..((t + 1) * per).min(count);
                scope.spawn(move || range.map(f).collect::<Vec<T>>())
            })
            .collect();
        runs.into_iter()
            // A panic in `f` is a bug; pass it on as the sequential map would.
            .flat_map(|run| run.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
            .collect()
    })
}

#[cfg(test)]
mod tests {
    use super::ordered_map;

    #[test]
    fn results_come_in_index_order_for_any_count() {
        for count in [0, 1, 2, 3, 7, 64, 1001] {
            let got = ordered_map(count, |i| i * i + 1);
            let want: Vec<usize> = (0..count).map(|i| i * i + 1).collect();
            assert_eq!(got, want, "count {count}");
        }
    }
}
