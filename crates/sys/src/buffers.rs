//! A socket's kernel buffers: how many bytes of datagrams it may hold
//! before the kernel drops the next one.

use std::io;
use std::mem::size_of;
use std::os::fd::{AsFd, AsRawFd};

/// Which of a socket's two buffers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Buffer {
    /// What arrived and was not read yet (`SO_RCVBUF`).
    Receive,
    /// What was written and not sent yet (`SO_SNDBUF`).
    Send,
}

impl Buffer {
    fn option(self, force: bool) -> libc::c_int {
        match (self, force) {
            (Buffer::Receive, false) => libc::SO_RCVBUF,
            (Buffer::Send, false) => libc::SO_SNDBUF,
            #[cfg(target_os = "linux")]
            (Buffer::Receive, true) => libc::SO_RCVBUFFORCE,
            #[cfg(target_os = "linux")]
            (Buffer::Send, true) => libc::SO_SNDBUFFORCE,
            #[cfg(not(target_os = "linux"))]
            (b, true) => b.option(false),
        }
    }
}

/// Asks for a buffer of `bytes`. The kernel caps a plain request at
/// `net.core.rmem_max` (or `wmem_max`); with `force` (Linux's
/// `SO_*BUFFORCE`), a privileged process may pass that cap, and an
/// unprivileged one gets `PermissionDenied`.
pub fn set_size(sock: &impl AsFd, which: Buffer, bytes: usize, force: bool) -> io::Result<()> {
    let value = bytes.min(i32::MAX as usize) as libc::c_int;
    // SAFETY: `value` is a live c_int and the length passed is its size,
    // which is what these SOL_SOCKET options read; the descriptor is
    // borrowed, so it is open for the whole call.
    let r = unsafe {
        libc::setsockopt(
            sock.as_fd().as_raw_fd(),
            libc::SOL_SOCKET,
            which.option(force),
            (&value as *const libc::c_int).cast(),
            size_of::<libc::c_int>() as libc::socklen_t,
        )
    };
    if r == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

/// The buffer's size as the kernel reports it. Linux reports double the size
/// asked for (it counts its own bookkeeping in).
pub fn size(sock: &impl AsFd, which: Buffer) -> io::Result<usize> {
    let mut value: libc::c_int = 0;
    let mut len = size_of::<libc::c_int>() as libc::socklen_t;
    // SAFETY: `value` and `len` are live and `len` holds `value`'s size, as
    // getsockopt requires; it writes at most that many bytes. The descriptor
    // is borrowed, so it is open for the whole call.
    let r = unsafe {
        libc::getsockopt(
            sock.as_fd().as_raw_fd(),
            libc::SOL_SOCKET,
            which.option(false),
            (&mut value as *mut libc::c_int).cast(),
            &mut len,
        )
    };
    if r == 0 {
        Ok(value.max(0) as usize)
    } else {
        Err(io::Error::last_os_error())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::UdpSocket;

    #[test]
    fn a_plain_request_is_granted_up_to_the_cap() {
        let sock = UdpSocket::bind("127.0.0.1:0").unwrap();
        set_size(&sock, Buffer::Receive, 64 << 10, false).unwrap();
        // Linux doubles what it was asked for; other systems report it as is.
        assert!(size(&sock, Buffer::Receive).unwrap() >= 64 << 10);
        set_size(&sock, Buffer::Send, 64 << 10, false).unwrap();
        assert!(size(&sock, Buffer::Send).unwrap() >= 64 << 10);
    }
}
