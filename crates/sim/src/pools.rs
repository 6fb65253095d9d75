//! Thread pools lent to rapier's parallel physics steps (the `parallel-physics` feature).
//!
//! Rapier's parallel step hands its broad phase's deferred tree pass to the pool it runs in
//! (`rayon::spawn`) and later waits for it with a blocking channel `recv` on the stepping
//! thread. Worlds stepped together on one pool's workers, as trials and batches step them,
//! can leave every worker blocked in that wait, with the passes that would free them queued
//! behind them: the process hangs. So every step runs in a pool of its own, lent for the
//! length of the step. With one step in a pool, its stepping thread is the only one that
//! waits, and the pool's other threads run the pass; a pool of one thread runs the pass
//! inline (rapier checks `rayon::current_num_threads`).
//!
//! Pools are kept once built, so there are as many as there were steps at once, each with
//! the thread count of the context that first needed it.

use std::sync::{Arc, Mutex, PoisonError};

use rayon::ThreadPool;

/// Pools not lent at the moment.
static IDLE: Mutex<Vec<Arc<ThreadPool>>> = Mutex::new(Vec::new());

/// A pool of as many threads as the caller's rayon context has (`RAYON_NUM_THREADS`, an
/// enclosing `ThreadPool::install`, or one per core), no step running in it; `None` only when
/// the system refuses the threads.
pub(crate) fn lend() -> Option<Arc<ThreadPool>> {
    let threads = rayon::current_num_threads();
    {
        let mut idle = IDLE.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(i) = idle.iter().position(|p| p.current_num_threads() == threads) {
            return Some(idle.swap_remove(i));
        }
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("colony-physics-{i}"))
        .build()
        .ok()
        .map(Arc::new)
}

/// Puts a lent pool back for the next step.
pub(crate) fn give_back(pool: Arc<ThreadPool>) {
    IDLE.lock()
        .unwrap_or_else(PoisonError::into_inner)
        .push(pool);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pool_is_lent_to_one_step_at_a_time_and_reused() {
        // Five threads: a size no other test asks for, so no other test takes these pools.
        let five = rayon::ThreadPoolBuilder::new()
            .num_threads(5)
            .build()
            .unwrap();
        let (a, b) = five.install(|| (lend().unwrap(), lend().unwrap()));
        assert!(!Arc::ptr_eq(&a, &b), "two steps at once need two pools");
        let a_ptr = Arc::as_ptr(&a);
        give_back(a);
        let again = five.install(lend).unwrap();
        assert_eq!(
            Arc::as_ptr(&again),
            a_ptr,
            "a pool given back is lent again"
        );
        give_back(again);
        give_back(b);
    }

    #[test]
    fn a_pool_has_the_thread_count_of_the_context_that_asks() {
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let lent = one.install(lend).unwrap();
        assert_eq!(lent.current_num_threads(), 1);
        give_back(lent);
        let three = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        let lent = three.install(lend).unwrap();
        assert_eq!(lent.current_num_threads(), 3);
        give_back(lent);
    }
}
