//! Processes: who we run as, and children that do not outlive us.

use std::os::unix::process::CommandExt as _;
use std::process::Command;

/// Whether this process runs with root's privileges (effective uid 0).
pub fn is_root() -> bool {
    // SAFETY: geteuid only reads the caller's credentials and cannot fail.
    unsafe { libc::geteuid() == 0 }
}

/// Makes the child that `command` starts receive `signal` when this process
/// (more exactly: the thread that spawns it) ends, however it ends, so a
/// helper such as a broker never outlives the program that started it.
/// Changing its user id clears the setting, so the child must keep ours.
pub fn die_with_parent(command: &mut Command, signal: libc::c_int) {
    // SAFETY: the closure runs in the child between fork and exec, and only
    // calls prctl, which is async-signal-safe; it touches no lock and no
    // memory that another thread of the parent could have held at the fork.
    unsafe {
        command.pre_exec(move || {
            libc::prctl(libc::PR_SET_PDEATHSIG, signal);
            Ok(())
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_child_so_marked_still_starts() {
        let mut c = Command::new("true");
        die_with_parent(&mut c, libc::SIGTERM);
        assert!(c.status().unwrap().success());
        let _ = is_root();
    }
}
