//! Readiness waits: sleep until a socket has something to read.

use std::io;
use std::os::fd::{AsFd, AsRawFd};
use std::time::Duration;

/// Waits until `sock` is readable or `timeout` passes (`None`: no limit).
/// Returns true if it is readable; a wait cut short by a signal returns
/// false, as a timeout does, so callers simply look again.
pub fn wait_readable(sock: &impl AsFd, timeout: Option<Duration>) -> io::Result<bool> {
    let mut pfd = libc::pollfd {
        fd: sock.as_fd().as_raw_fd(),
        events: libc::POLLIN,
        revents: 0,
    };
    // Rounded up: a deadline 0.4 ms away must sleep, not return at once and
    // have the caller spin until it passes.
    let ms = timeout.map_or(-1, |t| {
        t.as_nanos().div_ceil(1_000_000).min(i32::MAX as u128) as libc::c_int
    });
    // SAFETY: `pfd` is one valid, initialised pollfd that outlives the call,
    // and the count passed is 1, matching it; its descriptor is borrowed, so
    // it stays open while poll runs.
    let r = unsafe { libc::poll(&mut pfd, 1, ms) };
    if r < 0 {
        let e = io::Error::last_os_error();
        return if e.kind() == io::ErrorKind::Interrupted {
            Ok(false)
        } else {
            Err(e)
        };
    }
    Ok(r > 0)
}

/// An epoll set of descriptors watched for reading, each named by a token.
#[cfg(target_os = "linux")]
pub struct Epoll {
    fd: std::os::fd::OwnedFd,
    events: Vec<libc::epoll_event>,
}

#[cfg(target_os = "linux")]
impl Epoll {
    /// An empty set.
    pub fn new() -> io::Result<Epoll> {
        use std::os::fd::FromRawFd;
        // SAFETY: epoll_create1 takes only flags and touches no memory of ours.
        let fd = unsafe { libc::epoll_create1(libc::EPOLL_CLOEXEC) };
        if fd < 0 {
            return Err(io::Error::last_os_error());
        }
        // SAFETY: `fd` was just opened by epoll_create1 and nothing else owns
        // it, so the OwnedFd is its only owner and closes it once.
        let fd = unsafe { std::os::fd::OwnedFd::from_raw_fd(fd) };
        Ok(Epoll {
            fd,
            events: Vec::new(),
        })
    }

    /// Watches `source` for reading (level-triggered), reported as `token`.
    /// The set keeps only the descriptor's number: a source closed while
    /// watched leaves the set on its own (the kernel drops it).
    pub fn add(&mut self, source: &impl AsFd, token: usize) -> io::Result<()> {
        let mut ev = libc::epoll_event {
            events: libc::EPOLLIN as u32,
            u64: token as u64,
        };
        // SAFETY: `ev` is a live epoll_event the kernel only reads; both
        // descriptors are open (ours is owned, `source`'s is borrowed).
        let r = unsafe {
            libc::epoll_ctl(
                self.fd.as_raw_fd(),
                libc::EPOLL_CTL_ADD,
                source.as_fd().as_raw_fd(),
                &mut ev,
            )
        };
        if r != 0 {
            return Err(io::Error::last_os_error());
        }
        self.events.push(libc::epoll_event { events: 0, u64: 0 });
        Ok(())
    }

    /// Waits up to `timeout` and returns the tokens of the readable sources
    /// (none if a signal cut the wait short).
    pub fn wait(&mut self, timeout: Duration) -> io::Result<impl Iterator<Item = usize> + '_> {
        let ms = timeout.as_millis().min(i32::MAX as u128) as libc::c_int;
        if self.events.is_empty() {
            self.events.push(libc::epoll_event { events: 0, u64: 0 });
        }
        // SAFETY: `events` holds as many epoll_events as the length passed
        // (at least one), and the kernel writes at most that many.
        let r = unsafe {
            libc::epoll_wait(
                self.fd.as_raw_fd(),
                self.events.as_mut_ptr(),
                self.events.len() as libc::c_int,
                ms,
            )
        };
        let n = if r < 0 {
            let e = io::Error::last_os_error();
            if e.kind() != io::ErrorKind::Interrupted {
                return Err(e);
            }
            0
        } else {
            r as usize
        };
        Ok(self.events[..n].iter().map(|e| e.u64 as usize))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::UdpSocket;

    #[test]
    fn a_waiting_datagram_makes_the_socket_readable() {
        let a = UdpSocket::bind("127.0.0.1:0").unwrap();
        let b = UdpSocket::bind("127.0.0.1:0").unwrap();
        assert!(!wait_readable(&a, Some(Duration::from_millis(1))).unwrap());
        b.send_to(b"x", a.local_addr().unwrap()).unwrap();
        assert!(wait_readable(&a, Some(Duration::from_secs(5))).unwrap());
    }

    #[test]
    fn a_wait_shorter_than_a_millisecond_still_waits() {
        let a = UdpSocket::bind("127.0.0.1:0").unwrap();
        let t = std::time::Instant::now();
        assert!(!wait_readable(&a, Some(Duration::from_micros(300))).unwrap());
        assert!(
            t.elapsed() >= Duration::from_micros(300),
            "{:?}",
            t.elapsed()
        );
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn epoll_names_the_readable_socket_by_its_token() {
        let a = UdpSocket::bind("127.0.0.1:0").unwrap();
        let b = UdpSocket::bind("127.0.0.1:0").unwrap();
        let mut set = Epoll::new().unwrap();
        set.add(&a, 7).unwrap();
        set.add(&b, 9).unwrap();
        assert_eq!(set.wait(Duration::from_millis(1)).unwrap().count(), 0);
        a.send_to(b"x", b.local_addr().unwrap()).unwrap();
        let ready: Vec<usize> = set.wait(Duration::from_secs(5)).unwrap().collect();
        assert_eq!(ready, [9]);
    }
}
