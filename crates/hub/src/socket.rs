//! Batched UDP socket calls: many datagrams per system call where the
//! platform allows it (`recvmmsg`/`sendmmsg` on Linux), one at a time elsewhere.

use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::os::fd::AsRawFd;
use std::time::Duration;

/// Datagrams taken per receive call.
pub(crate) const BATCH: usize = 32;
/// Room for the largest UDP payload, plus one byte to notice anything larger.
const SLOT: usize = colony_wire::MAX_PACKET + 1;

/// Buffers for one batch of received datagrams.
pub(crate) struct RecvBatch {
    buf: Vec<u8>,
    lens: [usize; BATCH],
    addrs: [Option<SocketAddr>; BATCH],
    count: usize,
}

impl RecvBatch {
    pub(crate) fn new() -> Self {
        RecvBatch {
            buf: vec![0; SLOT * BATCH],
            lens: [0; BATCH],
            addrs: [None; BATCH],
            count: 0,
        }
    }

    /// The datagrams of the last receive, with their sources.
    pub(crate) fn iter(&self) -> impl Iterator<Item = (SocketAddr, &[u8])> {
        (0..self.count).filter_map(move |i| {
            let addr = self.addrs[i]?;
            Some((addr, &self.buf[i * SLOT..i * SLOT + self.lens[i]]))
        })
    }
}

/// Asks for `bytes` of receive and send buffer: a hub takes bursts from many
/// publishers at once, and the default (about 208 KiB, some 200 small
/// datagrams) drops them at its own socket. The kernel caps the request at
/// `net.core.rmem_max`; a privileged process may exceed that cap, so that is
/// tried next. Returns the receive buffer size in force.
pub(crate) fn enlarge_buffers(sock: &UdpSocket, bytes: usize) -> usize {
    let set = |opt: libc::c_int, value: libc::c_int| {
        // SAFETY: `value` is a live c_int and the length passed is its size,
        // which is what these SOL_SOCKET options read.
        unsafe {
            libc::setsockopt(
                sock.as_raw_fd(),
                libc::SOL_SOCKET,
                opt,
                (&value as *const libc::c_int).cast(),
                std::mem::size_of::<libc::c_int>() as libc::socklen_t,
            ) == 0
        }
    };
    let want = bytes.min(i32::MAX as usize) as libc::c_int;
    for (plain, forced) in [
        (libc::SO_RCVBUF, libc::SO_RCVBUFFORCE),
        (libc::SO_SNDBUF, libc::SO_SNDBUFFORCE),
    ] {
        set(plain, want);
        if buffer_size(sock, plain) < bytes {
            set(forced, want);
        }
    }
    buffer_size(sock, libc::SO_RCVBUF)
}

fn buffer_size(sock: &UdpSocket, opt: libc::c_int) -> usize {
    let mut value: libc::c_int = 0;
    let mut len = std::mem::size_of::<libc::c_int>() as libc::socklen_t;
    // SAFETY: `value` and `len` are live and `len` holds `value`'s size, as
    // getsockopt requires; it writes at most that many bytes.
    let r = unsafe {
        libc::getsockopt(
            sock.as_raw_fd(),
            libc::SOL_SOCKET,
            opt,
            (&mut value as *mut libc::c_int).cast(),
            &mut len,
        )
    };
    // Linux reports double the size asked for (it counts its bookkeeping).
    if r == 0 {
        (value.max(0) as usize) / 2
    } else {
        0
    }
}

/// Waits until the socket is readable or `timeout` passes; true if readable.
pub(crate) fn wait_readable(sock: &UdpSocket, timeout: Duration) -> io::Result<bool> {
    let mut pfd = libc::pollfd {
        fd: sock.as_raw_fd(),
        events: libc::POLLIN,
        revents: 0,
    };
    let ms = timeout.as_millis().min(i32::MAX as u128) as libc::c_int;
    // SAFETY: `pfd` is a valid, initialised pollfd that outlives the call, and
    // the count passed is 1, matching the single element.
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

#[cfg(target_os = "linux")]
mod imp {
    use super::*;
    use std::mem::{size_of, zeroed};
    use std::net::{Ipv4Addr, Ipv6Addr, SocketAddrV4, SocketAddrV6};

    /// Receives up to [`BATCH`] datagrams without waiting; returns how many.
    pub(crate) fn recv_batch(sock: &UdpSocket, batch: &mut RecvBatch) -> io::Result<usize> {
        batch.count = 0;
        // SAFETY: all-zero bytes are a valid value for these plain C structs
        // (null pointers and zero lengths), and every pointer is set below
        // before the kernel reads it.
        let mut names: [libc::sockaddr_storage; BATCH] = unsafe { zeroed() };
        let mut iovs: [libc::iovec; BATCH] = unsafe { zeroed() };
        let mut hdrs: [libc::mmsghdr; BATCH] = unsafe { zeroed() };
        for (i, chunk) in batch.buf.chunks_exact_mut(SLOT).enumerate() {
            iovs[i] = libc::iovec {
                iov_base: chunk.as_mut_ptr().cast(),
                iov_len: SLOT,
            };
            hdrs[i].msg_hdr.msg_name = (&mut names[i] as *mut libc::sockaddr_storage).cast();
            hdrs[i].msg_hdr.msg_namelen = size_of::<libc::sockaddr_storage>() as libc::socklen_t;
            hdrs[i].msg_hdr.msg_iov = &mut iovs[i];
            hdrs[i].msg_hdr.msg_iovlen = 1;
        }
        // SAFETY: `hdrs` holds BATCH headers, each pointing at its own iovec
        // (SLOT bytes inside `batch.buf`) and its own sockaddr_storage; all of
        // them live on this stack frame or in `batch`, which outlive the call,
        // and no other reference to those buffers exists while it runs.
        let r = unsafe {
            libc::recvmmsg(
                sock.as_raw_fd(),
                hdrs.as_mut_ptr(),
                BATCH as libc::c_uint,
                libc::MSG_DONTWAIT,
                std::ptr::null_mut(),
            )
        };
        if r < 0 {
            let e = io::Error::last_os_error();
            return match e.kind() {
                io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted => Ok(0),
                _ => Err(e),
            };
        }
        let n = r as usize;
        for i in 0..n {
            let truncated = hdrs[i].msg_hdr.msg_flags & libc::MSG_TRUNC != 0;
            // A datagram longer than a packet may be: keep SLOT bytes so the parser rejects it.
            batch.lens[i] = if truncated {
                SLOT
            } else {
                (hdrs[i].msg_len as usize).min(SLOT)
            };
            batch.addrs[i] = from_sockaddr(&names[i]);
        }
        batch.count = n;
        Ok(n)
    }

    /// Sends `payload` to every destination; returns how many could not be sent.
    pub(crate) fn send_to_many(sock: &UdpSocket, payload: &[u8], dests: &[SocketAddr]) -> usize {
        const CHUNK: usize = 64;
        let mut failed = 0;
        for chunk in dests.chunks(CHUNK) {
            // SAFETY: as in `recv_batch`, all-zero is valid for these C structs.
            let mut names: [libc::sockaddr_storage; CHUNK] = unsafe { zeroed() };
            let mut iov = libc::iovec {
                iov_base: payload.as_ptr() as *mut libc::c_void,
                iov_len: payload.len(),
            };
            let mut hdrs: [libc::mmsghdr; CHUNK] = unsafe { zeroed() };
            for (i, dest) in chunk.iter().enumerate() {
                let len = to_sockaddr(dest, &mut names[i]);
                hdrs[i].msg_hdr.msg_name = (&mut names[i] as *mut libc::sockaddr_storage).cast();
                hdrs[i].msg_hdr.msg_namelen = len;
                hdrs[i].msg_hdr.msg_iov = &mut iov;
                hdrs[i].msg_hdr.msg_iovlen = 1;
            }
            let mut start = 0;
            while start < chunk.len() {
                // SAFETY: headers `start..chunk.len()` are initialised above and
                // point at `names` and at `iov`, which points at `payload`; the
                // kernel only reads through them (sendmmsg never writes to the
                // payload), and all of them outlive the call.
                let r = unsafe {
                    libc::sendmmsg(
                        sock.as_raw_fd(),
                        hdrs.as_mut_ptr().add(start),
                        (chunk.len() - start) as libc::c_uint,
                        libc::MSG_DONTWAIT,
                    )
                };
                if r < 0 {
                    let e = io::Error::last_os_error();
                    if e.kind() == io::ErrorKind::Interrupted {
                        continue;
                    }
                    // The first datagram failed (buffer full, unreachable
                    // address): drop it and go on with the rest.
                    tracing::trace!(error = %e, dest = %chunk[start], "send failed");
                    failed += 1;
                    start += 1;
                } else {
                    start += r as usize;
                }
            }
        }
        failed
    }

    fn to_sockaddr(addr: &SocketAddr, out: &mut libc::sockaddr_storage) -> libc::socklen_t {
        match addr {
            SocketAddr::V4(a) => {
                let sin = libc::sockaddr_in {
                    sin_family: libc::AF_INET as libc::sa_family_t,
                    sin_port: a.port().to_be(),
                    sin_addr: libc::in_addr {
                        s_addr: u32::from_ne_bytes(a.ip().octets()),
                    },
                    sin_zero: [0; 8],
                };
                // SAFETY: sockaddr_storage is larger than and aligned for every
                // sockaddr type, which is what it exists for.
                unsafe { std::ptr::write((out as *mut libc::sockaddr_storage).cast(), sin) };
                size_of::<libc::sockaddr_in>() as libc::socklen_t
            }
            SocketAddr::V6(a) => {
                let sin6 = libc::sockaddr_in6 {
                    sin6_family: libc::AF_INET6 as libc::sa_family_t,
                    sin6_port: a.port().to_be(),
                    sin6_flowinfo: a.flowinfo(),
                    sin6_addr: libc::in6_addr {
                        s6_addr: a.ip().octets(),
                    },
                    sin6_scope_id: a.scope_id(),
                };
                // SAFETY: as above.
                unsafe { std::ptr::write((out as *mut libc::sockaddr_storage).cast(), sin6) };
                size_of::<libc::sockaddr_in6>() as libc::socklen_t
            }
        }
    }

    fn from_sockaddr(ss: &libc::sockaddr_storage) -> Option<SocketAddr> {
        match ss.ss_family as libc::c_int {
            libc::AF_INET => {
                // SAFETY: the family says the kernel wrote a sockaddr_in, and
                // sockaddr_storage is large enough and aligned for it.
                let sin: &libc::sockaddr_in =
                    unsafe { &*(ss as *const libc::sockaddr_storage).cast() };
                let ip = Ipv4Addr::from(sin.sin_addr.s_addr.to_ne_bytes());
                Some(SocketAddr::V4(SocketAddrV4::new(
                    ip,
                    u16::from_be(sin.sin_port),
                )))
            }
            libc::AF_INET6 => {
                // SAFETY: as above, for sockaddr_in6.
                let sin6: &libc::sockaddr_in6 =
                    unsafe { &*(ss as *const libc::sockaddr_storage).cast() };
                let ip = Ipv6Addr::from(sin6.sin6_addr.s6_addr);
                Some(SocketAddr::V6(SocketAddrV6::new(
                    ip,
                    u16::from_be(sin6.sin6_port),
                    sin6.sin6_flowinfo,
                    sin6.sin6_scope_id,
                )))
            }
            _ => None,
        }
    }
}

#[cfg(not(target_os = "linux"))]
mod imp {
    use super::*;

    pub(crate) fn recv_batch(sock: &UdpSocket, batch: &mut RecvBatch) -> io::Result<usize> {
        batch.count = 0;
        while batch.count < BATCH {
            let i = batch.count;
            match sock.recv_from(&mut batch.buf[i * SLOT..(i + 1) * SLOT]) {
                Ok((len, addr)) => {
                    batch.lens[i] = len;
                    batch.addrs[i] = Some(addr);
                    batch.count += 1;
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
                    ) =>
                {
                    break
                }
                Err(e) if batch.count == 0 => return Err(e),
                Err(_) => break,
            }
        }
        Ok(batch.count)
    }

    pub(crate) fn send_to_many(sock: &UdpSocket, payload: &[u8], dests: &[SocketAddr]) -> usize {
        dests
            .iter()
            .filter(|d| sock.send_to(payload, d).is_err())
            .count()
    }
}

pub(crate) use imp::{recv_batch, send_to_many};
