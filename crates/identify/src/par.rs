//! Work on every core: the cores of this process (looked up once) and an ordered parallel
//! map over scoped threads, each thread taking the next task when it is done with one.

use std::sync::OnceLock;

/// The cores this process may use, looked up once (`available_parallelism` reads the
/// cgroup files on every call), at most 8.
pub(crate) fn cores() -> usize {
    static CORES: OnceLock<usize> = OnceLock::new();
    *CORES.get_or_init(|| std::thread::available_parallelism().map_or(1, |n| n.get().min(8)))
}

/// The result of a scoped thread (its panic, if any, carried on in the caller).
pub(crate) fn join<R>(h: std::thread::ScopedJoinHandle<'_, R>) -> R {
    h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))
}

/// `f` over `items` on up to as many threads as there are cores ([`par_map_n`]); the
/// results in the order of `items`.
pub(crate) fn par_map<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    par_map_n(items.len(), |i| f(&items[i]))
}

/// `f(0), …, f(n − 1)` on up to as many threads as there are cores, each thread taking the
/// next index when it is done with one (tasks of very different cost keep every core
/// busy); the results in index order. A panic in `f` is carried on in the caller.
pub(crate) fn par_map_n<R: Send>(n: usize, f: impl Fn(usize) -> R + Sync) -> Vec<R> {
    let threads = cores().min(n);
    if threads <= 1 {
        return (0..n).map(f).collect();
    }
    let next = std::sync::atomic::AtomicUsize::new(0);
    let work = || {
        let mut done = Vec::new();
        loop {
            let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            if i >= n {
                return done;
            }
            done.push((i, f(i)));
        }
    };
    let mut slots: Vec<Option<R>> = (0..n).map(|_| None).collect();
    std::thread::scope(|s| {
        let others: Vec<_> = (1..threads).map(|_| s.spawn(work)).collect();
        for (i, r) in work().into_iter().chain(others.into_iter().flat_map(join)) {
            slots[i] = Some(r);
        }
    });
    slots.into_iter().flatten().collect()
}

#[cfg(test)]
mod tests {
    /// Every index once, in order, for task counts around the core count; uneven costs.
    #[test]
    fn par_map_n_gives_every_result_in_order() {
        for n in [0, 1, 2, 3, 7, 40] {
            let got = super::par_map_n(n, |i| {
                if i % 3 == 0 {
                    std::thread::sleep(std::time::Duration::from_millis(2));
                }
                i * i
            });
            assert_eq!(got, (0..n).map(|i| i * i).collect::<Vec<_>>());
        }
    }
}
