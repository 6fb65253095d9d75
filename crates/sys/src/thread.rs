//! Threads and the clock: which CPUs a thread runs on, its kernel id, and the
//! unit the kernel counts CPU time in. The benchmarks use them to keep the
//! measured and the measuring apart and to read each side's CPU time.

use std::io;
use std::mem::{size_of, zeroed};

/// A thread's kernel id (what `/proc/self/task/` lists); 0 names the calling thread.
pub type Tid = libc::pid_t;

/// Runs thread `tid` (0: the calling thread) on these CPUs only.
///
/// # Panics
///
/// If a CPU index is past what `cpu_set_t` holds (1024 on Linux).
pub fn set_affinity(tid: Tid, cpus: &[usize]) -> io::Result<()> {
    // SAFETY: an all-zero cpu_set_t is the empty set (it is a plain bit array).
    let mut set: libc::cpu_set_t = unsafe { zeroed() };
    for &c in cpus {
        // SAFETY: CPU_SET sets one bit of `set`, indexing its bit array
        // with a bounds check, so an index past the set panics instead of
        // writing outside it.
        unsafe { libc::CPU_SET(c, &mut set) };
    }
    // SAFETY: `set` is a live cpu_set_t, the size passed is its size, and the
    // kernel only reads it.
    let r = unsafe { libc::sched_setaffinity(tid, size_of::<libc::cpu_set_t>(), &set) };
    if r != 0 {
        return Err(io::Error::last_os_error());
    }
    Ok(())
}

/// The calling thread's kernel id, for reading its CPU time from another thread.
pub fn current_tid() -> Tid {
    // SAFETY: gettid takes nothing, touches no memory of ours and cannot fail.
    unsafe { libc::gettid() }
}

/// How many clock ticks make a second: the unit of CPU times in `/proc`.
/// 100 if the system will not say.
pub fn clock_ticks_per_second() -> u64 {
    // SAFETY: sysconf only reads a configuration value.
    let hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
    if hz > 0 {
        hz as u64
    } else {
        100
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thread_may_be_kept_to_one_cpu_and_set_free_again() {
        let all: Vec<usize> =
            (0..std::thread::available_parallelism().map_or(1, |n| n.get())).collect();
        std::thread::spawn(move || {
            set_affinity(0, &[0]).unwrap();
            set_affinity(current_tid(), &all).unwrap();
        })
        .join()
        .unwrap();
    }

    #[test]
    fn threads_have_their_own_ids_and_the_clock_a_tick() {
        let here = current_tid();
        let there = std::thread::spawn(current_tid).join().unwrap();
        assert_ne!(here, there);
        assert!(clock_ticks_per_second() > 0);
    }
}
