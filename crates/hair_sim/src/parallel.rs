//! Baking work split over the machine's cores with scoped threads: every item is computed
//! on its own, so the result is the same, in the same order, however many cores run it.

/// `f(0)`, …, `f(n - 1)`, computed in contiguous runs, one per available core.
pub(crate) fn map<T: Send>(n: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
    let threads = std::thread::available_parallelism().map_or(1, |t| t.get()).min(n.max(1));
    if threads <= 1 {
        return (0..n).map(f).collect();
    }
    let run = n.div_ceil(threads);
    let f = &f;
    std::thread::scope(|scope| {
        let runs: Vec<_> = (0..n)
            .step_by(run)
            .map(|start| scope.spawn(move || (start..(start + run).min(n)).map(f).collect::<Vec<T>>()))
            .collect();
        runs.into_iter().flat_map(|r| r.join().expect("a bake thread panicked")).collect()
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn keeps_order_and_count() {
        for n in [0, 1, 2, 7, 1000] {
            assert_eq!(super::map(n, |i| i * 3), (0..n).map(|i| i * 3).collect::<Vec<_>>());
        }
    }
}
