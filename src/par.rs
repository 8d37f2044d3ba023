//! Work shared between the calling thread and rayon's pool.
//!
//! A parallel iterator started on a thread outside rayon's pool (an application's main or
//! render thread, where `set` and `prepare` are called) hands all of its work to the pool and
//! blocks: nothing runs until a pool thread wakes, and the others join only as they wake in
//! turn. On the 2-core machine a sleeping pool thread took from 15 µs to over 1 ms to start
//! (docs/benchmarks-log.md, "The caller works too"), and a frame switch's rebuild often ran on one
//! pool thread while the other never woke. [`map`] starts on the calling thread at once and
//! lets pool threads take items as they wake, so the work never waits for a thread to wake,
//! only (at the end, as rayon's scopes do) for the helpers it asked for to have run.

use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};

thread_local! {
    /// Whether this thread is taking items of a [`map`] (the calling thread's part; a pool
    /// thread is known by its index).
    static IN_MAP: Cell<bool> = const { Cell::new(false) };
}

/// Whether work on this thread may be split over the pool: it is neither a pool thread nor
/// taking items of a [`map`]. A part of a parallel job (a crowd's rebuild, wherever it runs)
/// stays on its thread: the job is spread already.
pub(crate) fn may_split() -> bool {
    rayon::current_thread_index().is_none() && !IN_MAP.get()
}

/// Runs `f` with nothing in it split over the pool ([`may_split`] false): work on a thread of
/// its own that must leave the pool's threads, and the cores they run on, to the frame's.
pub(crate) fn alone<R>(f: impl FnOnce() -> R) -> R {
    let _restore = Restore(IN_MAP.replace(true));
    f()
}

/// Restores the calling thread's [`IN_MAP`] however the work that set it ends (a panic
/// unwinds through it).
struct Restore(bool);

impl Drop for Restore {
    fn drop(&mut self) {
        IN_MAP.set(self.0);
    }
}

/// `items.into_iter().map(f).collect()`, the items taken one at a time by the calling thread
/// and by up to `rayon::current_num_threads() - 1` pool threads, each taking the next item left
/// when it is free. The results are in item order. Each item should be worth waking a thread
/// for (tens of microseconds or more): the pieces of one large job, not the elements of a
/// slice.
///
/// Called from inside the pool it runs the same way, its helpers on the pool's other threads.
/// A panic in `f` is resumed on the calling thread once every helper has stopped.
pub(crate) fn map<T: Send, R: Send>(items: Vec<T>, f: impl Fn(T) -> R + Sync) -> Vec<R> {
    // The calling thread's items do not split again, however many helpers there are.
    let _restore = Restore(IN_MAP.replace(true));
    let n = items.len();
    let threads = rayon::current_num_threads();
    if n <= 1 || threads <= 1 {
        return items.into_iter().map(f).collect();
    }
    let shared = Shared {
        queue: Mutex::new(items.into_iter().enumerate()),
        results: Mutex::new(Vec::with_capacity(n)),
        helpers_left: AtomicUsize::new((threads - 1).min(n - 1)),
        f,
    };
    rayon::in_place_scope(|scope| shared.take_part(scope));
    let mut results = shared
        .results
        .into_inner()
        .unwrap_or_else(PoisonError::into_inner);
    results.sort_unstable_by_key(|&(i, _)| i);
    results.into_iter().map(|(_, r)| r).collect()
}

/// Pieces per thread that the parallel parts cut their work into: a few, so that pieces of
/// uneven cost (strips mostly empty, instances that switch frames) even out over the threads.
const PIECES_PER_THREAD: usize = 4;

/// The size of each piece when `total` units of work are cut into a few pieces a thread
/// ([`PIECES_PER_THREAD`]) for [`map`], but no smaller than `min` units (below it a piece
/// costs more to hand out than it evens out).
pub(crate) fn piece_len(total: usize, min: usize) -> usize {
    total
        .div_ceil(PIECES_PER_THREAD * rayon::current_num_threads())
        .max(min)
}

/// What the calling thread and its helpers of one [`map`] share.
struct Shared<I, R, F> {
    /// The items not taken yet, with their places.
    queue: Mutex<I>,
    /// The results with their items' places, in the order they were made.
    results: Mutex<Vec<(usize, R)>>,
    /// Helpers that may still be asked for.
    helpers_left: AtomicUsize,
    f: F,
}

impl<T: Send, R: Send, I, F> Shared<I, R, F>
where
    I: Iterator<Item = (usize, T)> + ExactSizeIterator + Send,
    F: Fn(T) -> R + Sync,
{
    /// One thread's part: asks for up to two more helpers while items are left (so that the
    /// helpers wake in a tree, not one after another, and the calling thread makes two
    /// requests, not one per thread), then takes items until none is left.
    fn take_part<'s>(&'s self, scope: &rayon::Scope<'s>) {
        for _ in 0..2 {
            if self.lock_queue().len() == 0 || !self.ask_helper() {
                break;
            }
            scope.spawn(move |scope| self.take_part(scope));
        }
        let mut made = Vec::new();
        loop {
            // The lock is let go before `f` runs: the others take items meanwhile.
            let next = self.lock_queue().next();
            let Some((i, item)) = next else { break };
            made.push((i, (self.f)(item)));
        }
        if !made.is_empty() {
            (self.results.lock())
                .unwrap_or_else(PoisonError::into_inner)
                .extend(made);
        }
    }

    fn lock_queue(&self) -> std::sync::MutexGuard<'_, I> {
        self.queue.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Takes one helper from the budget; false when it is spent.
    fn ask_helper(&self) -> bool {
        self.helpers_left
            .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |left| {
                left.checked_sub(1)
            })
            .is_ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;
    use std::sync::atomic::AtomicU64;

    #[test]
    fn results_are_in_item_order_and_each_item_runs_once() {
        for n in [0, 1, 2, 3, 17, 200] {
            let calls = AtomicU64::new(0);
            let out = map((0..n).collect(), |i: u64| {
                calls.fetch_add(1, Ordering::Relaxed);
                // Uneven items, so that threads finish out of order.
                std::thread::sleep(std::time::Duration::from_micros(i % 7 * 50));
                i * i
            });
            assert_eq!(out, (0..n).map(|i| i * i).collect::<Vec<_>>());
            assert_eq!(calls.load(Ordering::Relaxed), n);
        }
    }

    #[test]
    fn items_borrow_disjoint_parts_of_one_buffer() {
        let mut buffer = vec![0u32; 1000];
        let parts: Vec<(usize, &mut [u32])> = buffer.chunks_mut(64).enumerate().collect();
        let sums = map(parts, |(k, part)| {
            for (j, x) in part.iter_mut().enumerate() {
                *x = (64 * k + j) as u32;
            }
            part.len()
        });
        assert_eq!(sums.iter().sum::<usize>(), 1000);
        assert!(buffer.iter().enumerate().all(|(i, &x)| x == i as u32));
    }

    #[test]
    fn the_calling_thread_and_pool_threads_share_the_items() {
        if rayon::current_num_threads() < 2 {
            return;
        }
        let caller = std::thread::current().id();
        let seen = Mutex::new((false, false));
        // Every item waits until the caller and a pool thread have each taken one (the
        // pool may be busy with other tests for a while: a generous bound, not a timing).
        let ids = map((0..16).collect(), |_: u32| {
            let me = std::thread::current().id();
            let start = std::time::Instant::now();
            loop {
                {
                    let mut seen = seen.lock().unwrap();
                    seen.0 |= me == caller;
                    seen.1 |= rayon::current_thread_index().is_some();
                    if (seen.0 && seen.1) || start.elapsed().as_secs() > 60 {
                        break;
                    }
                }
                std::thread::sleep(std::time::Duration::from_micros(100));
            }
            (me, rayon::current_thread_index())
        });
        assert!(
            ids.iter().any(|&(id, _)| id == caller),
            "the caller took no item"
        );
        let helpers: HashSet<_> = ids.iter().filter_map(|&(_, pool)| pool).collect();
        assert!(!helpers.is_empty(), "no pool thread took an item");
    }

    #[test]
    fn items_do_not_split_again() {
        assert!(rayon::current_thread_index().is_some() || may_split());
        for n in [1, 8] {
            let splits = map((0..n).collect(), |_: u32| may_split());
            assert!(
                splits.iter().all(|&s| !s),
                "an item of {n} may split: {splits:?}"
            );
        }
        assert!(rayon::current_thread_index().is_some() || may_split());
        let _ = std::panic::catch_unwind(|| map(vec![0, 1], |i: u32| assert!(i == 0)));
        assert!(rayon::current_thread_index().is_some() || may_split());
    }

    #[test]
    fn inside_the_pool_it_runs_the_same() {
        let out = rayon::scope(|_| map((0..50u32).collect(), |i| i + 1));
        assert_eq!(out, (1..51).collect::<Vec<_>>());
    }

    #[test]
    fn a_panic_in_an_item_reaches_the_caller() {
        let result = std::panic::catch_unwind(|| {
            map((0..32).collect(), |i: u32| {
                assert!(i != 20, "item 20");
                i
            })
        });
        let message = result.expect_err("the panic was lost");
        let text = message
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| message.downcast_ref::<&str>().copied());
        assert_eq!(text, Some("item 20"));
    }
}
