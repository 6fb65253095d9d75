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
//! Pools are kept once built, so there are as many as there were steps at once, each with
//! the thread count of the context that first needed it.

use std::sync::{Arc, Mutex, PoisonError};

use rayon::{ThreadPool, ThreadPoolBuildError};

/// Pools not lent at the moment.
pub(crate) struct Pools {
    idle: Mutex<Vec<Arc<ThreadPool>>>,
}

/// The pools every world in the process borrows from.
pub(crate) static SHARED: Pools = Pools::new();

impl Pools {
    const fn new() -> Pools {
        Pools {
            idle: Mutex::new(Vec::new()),
        }
    }

    /// A pool of as many threads as the caller's rayon context has (`RAYON_NUM_THREADS`, an
    /// enclosing `ThreadPool::install`, or one per core), with no step running in it.
    pub fn lend(&self) -> Result<Arc<ThreadPool>, ThreadPoolBuildError> {
        let threads = rayon::current_num_threads();
        {
            let mut idle = self.idle.lock().unwrap_or_else(PoisonError::into_inner);
            if let Some(i) = idle.iter().position(|p| p.current_num_threads() == threads) {
                return Ok(idle.swap_remove(i));
            }
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("colony-physics-{i}"))
            // Without a handler, a panic in a spawned task (rapier's tree pass) aborts the
            // process. Dropped here, it drops the pass's channel, and the step waiting for
            // it panics on its own thread as any other step would.
            .panic_handler(drop)
            .build()
            .map(Arc::new)
    }

    /// Puts a lent pool back for the next step.
    pub fn give_back(&self, pool: Arc<ThreadPool>) {
        self.idle
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push(pool);
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
        let (a, b) = (pools.lend().unwrap(), pools.lend().unwrap());
        assert!(!Arc::ptr_eq(&a, &b), "two steps at once need two pools");
        let a_ptr = Arc::as_ptr(&a);
        pools.give_back(a);
        let again = pools.lend().unwrap();
        assert_eq!(
            Arc::as_ptr(&again),
            a_ptr,
            "a pool given back is lent again"
        );
    }

    #[test]
    fn a_pool_has_the_thread_count_of_the_context_that_asks() {
        let pools = Pools::new();
        let one = in_pool(1, || pools.lend().unwrap());
        assert_eq!(one.current_num_threads(), 1);
        pools.give_back(one.clone());
        let three = in_pool(3, || pools.lend().unwrap());
        assert_eq!(three.current_num_threads(), 3);
        assert!(
            !Arc::ptr_eq(&one, &three),
            "a pool is only lent at its own size"
        );
    }

    #[test]
    fn a_panic_in_a_spawned_task_does_not_end_the_process() {
        let pool = Pools::new().lend().unwrap();
        let (tx, rx) = std::sync::mpsc::channel::<()>();
        pool.spawn(move || {
            let _tx = tx;
            panic!("a task that fails");
        });
        // The sender went with the unwinding task: the waiter hears of it, as rapier's
        // step does through its own channel.
        assert!(rx.recv().is_err());
    }
}
