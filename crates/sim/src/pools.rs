//! Thread pools lent to rapier's parallel physics (the `parallel-physics` feature).
//!
//! Rapier's parallel step hands its broad phase's deferred tree pass to the pool it runs in
//! (`rayon::spawn`) and later waits for it with a blocking channel `recv` on the stepping
//! thread. Worlds stepped together on one pool's workers, as trials and batches step them,
//! can leave every worker blocked in that wait, with the passes that would free them queued
//! behind them: the process hangs. So each control step's physics runs in a pool lent to
//! that world alone until the step ends. With one step in a pool, its stepping thread is the
//! only one that waits, and the pool's other threads run the pass; a pool of one thread runs
//! the pass inline (rapier checks `rayon::current_num_threads`).
//!
//! The caller's rayon context's threads (`RAYON_NUM_THREADS`, an enclosing
//! `ThreadPool::install`, or one per core) are shared among the steps in flight: one world
//! alone gets them all, two trials stepped at once get half each. Giving every trial all of
//! them would make the square of the core count in threads, all spinning at rapier's stage
//! barriers. The thread count cannot change a result, so neither can this share.
//!
//! Pools are kept once built, so there are as many as there were steps at once, of each size.

use std::ops::Deref;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

use rayon::{ThreadPool, ThreadPoolBuildError};

/// Pools, those not lent at the moment and a count of those that are.
pub(crate) struct Pools {
    idle: Mutex<Vec<Arc<ThreadPool>>>,
    lent: AtomicUsize,
}

/// The pools every world in the process borrows from.
pub(crate) static SHARED: Pools = Pools::new();

/// A pool lent to one step; dropping it gives it back, after a panic too.
pub(crate) struct Lent<'a> {
    pools: &'a Pools,
    pool: Arc<ThreadPool>,
}

impl Pools {
    const fn new() -> Pools {
        Pools {
            idle: Mutex::new(Vec::new()),
            lent: AtomicUsize::new(0),
        }
    }

    /// A pool with no step running in it, of the caller's rayon context's threads divided
    /// among the steps in flight with this one (at least one).
    pub fn lend(&self) -> Result<Lent<'_>, ThreadPoolBuildError> {
        let in_flight = self.lent.fetch_add(1, Ordering::SeqCst) + 1;
        let threads = (rayon::current_num_threads() / in_flight).max(1);
        match self.idle_or_new(threads) {
            Ok(pool) => Ok(Lent { pools: self, pool }),
            Err(e) => {
                self.lent.fetch_sub(1, Ordering::SeqCst);
                Err(e)
            }
        }
    }

    fn idle_or_new(&self, threads: usize) -> Result<Arc<ThreadPool>, ThreadPoolBuildError> {
        let mut idle = self.idle.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(i) = idle.iter().position(|p| p.current_num_threads() == threads) {
            return Ok(idle.swap_remove(i));
        }
        drop(idle);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("colony-physics-{i}"))
            // Without a handler, a panic in a spawned task (rapier's tree pass) aborts the
            // process. With one, only the task ends: its unwinding drops the pass's channel,
            // and the step waiting on it panics on its own thread as any other step would.
            .panic_handler(drop)
            .build()?;
        Ok(Arc::new(pool))
    }
}

impl Deref for Lent<'_> {
    type Target = ThreadPool;

    fn deref(&self) -> &ThreadPool {
        &self.pool
    }
}

impl Drop for Lent<'_> {
    fn drop(&mut self) {
        // The step is over: the pool may be lent again while this handle still points to it.
        self.pools
            .idle
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push(Arc::clone(&self.pool));
        self.pools.lent.fetch_sub(1, Ordering::SeqCst);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(f)
    }

    #[test]
    fn a_pool_is_lent_to_one_step_at_a_time_and_reused() {
        let pools = Pools::new();
        let a = pools.lend().unwrap();
        let a_ptr: *const ThreadPool = &*a;
        drop(a);
        let (b, c) = (pools.lend().unwrap(), pools.lend().unwrap());
        assert!(!std::ptr::eq(&*b, &*c), "two steps at once need two pools");
        drop((b, c));
        let again = pools.lend().unwrap();
        assert!(
            std::ptr::eq(&*again, a_ptr),
            "a pool given back is lent again"
        );
    }

    #[test]
    fn the_steps_in_flight_share_the_contexts_threads() {
        let pools = Pools::new();
        let (first, second, third) = in_pool(4, || {
            let first = pools.lend().unwrap();
            let second = pools.lend().unwrap();
            let third = pools.lend().unwrap();
            (first, second, third)
        });
        assert_eq!(first.current_num_threads(), 4, "a step alone has all four");
        assert_eq!(second.current_num_threads(), 2, "two steps have two each");
        assert_eq!(
            third.current_num_threads(),
            1,
            "three steps have one each, at least"
        );
        drop((first, second, third));
        assert_eq!(
            in_pool(4, || pools.lend().unwrap().current_num_threads()),
            4
        );
        assert_eq!(
            in_pool(1, || pools.lend().unwrap().current_num_threads()),
            1
        );
    }

    #[test]
    fn a_panic_in_a_spawned_task_does_not_end_the_process() {
        // One thread, so the job below runs only once that thread has dealt with the
        // panic: without the handler, rayon aborts the test binary before it.
        let pools = Pools::new();
        let pool = in_pool(1, || pools.lend().unwrap());
        let (tx, rx) = std::sync::mpsc::channel::<()>();
        pool.spawn(move || {
            let _tx = tx;
            panic!("a task that fails");
        });
        // The sender went with the unwinding task: the waiter hears of it, as rapier's
        // step does through its own channel.
        assert!(rx.recv().is_err());
        assert_eq!(pool.install(|| 7), 7, "the pool goes on after the panic");
    }
}
