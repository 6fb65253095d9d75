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

/// Kills (SIGKILL) every process of the process group `pgid`: a child
/// started with `process_group(0)` leads one of its own, and whatever it
/// started in the background ends with it.
pub fn kill_group(pgid: u32) {
    let Ok(pgid) = libc::pid_t::try_from(pgid) else {
        return;
    };
    // killpg(0 or 1, ..) would mean our own group or init's: never asked for.
    if pgid > 1 {
        // SAFETY: killpg takes plain integers and touches no memory; a group
        // that is already gone gives ESRCH, which is what we wanted anyway.
        unsafe {
            libc::killpg(pgid, libc::SIGKILL);
        }
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

    #[test]
    fn a_killed_group_takes_its_background_children_with_it() {
        use std::io::Read as _;
        let mut child = Command::new("sh")
            .args(["-c", "sleep 600 & echo started"])
            .process_group(0)
            .stdout(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let mut out = child.stdout.take().unwrap();
        let mut first = [0u8; 8];
        out.read_exact(&mut first).unwrap();
        assert!(child.wait().unwrap().success());
        // The background sleep still holds the pipe; killing the group closes it.
        kill_group(child.id());
        let mut rest = Vec::new();
        out.read_to_end(&mut rest).unwrap();
    }
}
