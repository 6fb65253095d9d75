//! Many datagrams per system call: `recvmmsg` and `sendmmsg` on Linux, one
//! datagram at a time elsewhere; and, for the benchmarks' UDP floor, UDP
//! generic segmentation offload (a run of datagrams handed to the kernel as
//! one and split where it is delivered).

use std::io;
use std::net::{SocketAddr, UdpSocket};

/// Buffers for one batch of up to `N` received datagrams, each given `slot`
/// bytes. A datagram longer than its slot comes back `slot` bytes long (its
/// tail cut off), so make the slot one byte longer than the longest datagram
/// you accept and reject anything that fills it.
pub struct RecvBatch<const N: usize> {
    slot: usize,
    buf: Vec<u8>,
    lens: [usize; N],
    addrs: [Option<SocketAddr>; N],
    count: usize,
}

impl<const N: usize> RecvBatch<N> {
    /// Buffers for `N` datagrams of `slot` bytes each.
    pub fn new(slot: usize) -> Self {
        RecvBatch {
            slot,
            buf: vec![0; slot * N],
            lens: [0; N],
            addrs: [None; N],
            count: 0,
        }
    }

    /// How many datagrams the last receive took.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether the last receive took none.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Datagram `i` of the last receive.
    ///
    /// # Panics
    ///
    /// If `i` is not below `N`.
    pub fn get(&self, i: usize) -> &[u8] {
        &self.buf[i * self.slot..i * self.slot + self.lens[i]]
    }

    /// The datagrams of the last receive, with their sources (one whose
    /// source is not an IP address is left out).
    pub fn iter(&self) -> impl Iterator<Item = (SocketAddr, &[u8])> {
        (0..self.count).filter_map(move |i| Some((self.addrs[i]?, self.get(i))))
    }

    /// Receives up to `N` waiting datagrams without blocking; returns how
    /// many (0 when none is waiting or a signal interrupted the call).
    pub fn recv(&mut self, sock: &UdpSocket) -> io::Result<usize> {
        self.count = 0;
        let n = imp::recv(sock, self)?;
        self.count = n;
        Ok(n)
    }
}

/// Sends `payload` to every destination, without blocking; returns how many
/// could not be sent (a full buffer, an unreachable address): each of those
/// is dropped, and the rest still go.
pub fn send_to_many(sock: &UdpSocket, payload: &[u8], dests: &[SocketAddr]) -> usize {
    imp::send_to_many(sock, payload, dests)
}

/// Sends each datagram of `msgs` on a connected socket, in as few calls as
/// the kernel allows. Returns how many were taken: it stops at the first that
/// would block.
pub fn send_connected(sock: &UdpSocket, msgs: &[&[u8]]) -> io::Result<usize> {
    imp::send_connected(sock, msgs)
}

#[cfg(target_os = "linux")]
mod imp {
    use super::*;
    use std::mem::{size_of, zeroed};
    use std::net::{Ipv4Addr, Ipv6Addr, SocketAddrV4, SocketAddrV6};
    use std::os::fd::AsRawFd;

    /// The most datagrams one `sendmmsg` call is given.
    const SEND_CHUNK: usize = 64;

    pub(super) fn recv<const N: usize>(
        sock: &UdpSocket,
        batch: &mut RecvBatch<N>,
    ) -> io::Result<usize> {
        let slot = batch.slot;
        // SAFETY: all-zero bytes are a valid value for these plain C structs
        // (null pointers and zero lengths), and every pointer is set below
        // before the kernel reads it.
        let mut names: [libc::sockaddr_storage; N] = unsafe { zeroed() };
        // SAFETY: as above.
        let mut iovs: [libc::iovec; N] = unsafe { zeroed() };
        // SAFETY: as above.
        let mut hdrs: [libc::mmsghdr; N] = unsafe { zeroed() };
        for (i, chunk) in batch.buf.chunks_exact_mut(slot).enumerate() {
            iovs[i] = libc::iovec {
                iov_base: chunk.as_mut_ptr().cast(),
                iov_len: slot,
            };
            hdrs[i].msg_hdr.msg_name = (&mut names[i] as *mut libc::sockaddr_storage).cast();
            hdrs[i].msg_hdr.msg_namelen = size_of::<libc::sockaddr_storage>() as libc::socklen_t;
            hdrs[i].msg_hdr.msg_iov = &mut iovs[i];
            hdrs[i].msg_hdr.msg_iovlen = 1;
        }
        // SAFETY: `hdrs` holds N headers, each pointing at its own iovec
        // (`slot` bytes inside `batch.buf`, which is `slot * N` long) and its
        // own sockaddr_storage with its true size; all of them live on this
        // stack frame or in `batch`, which outlive the call, and no other
        // reference to those buffers exists while it runs. The socket is
        // borrowed, so its descriptor is open.
        let r = unsafe {
            libc::recvmmsg(
                sock.as_raw_fd(),
                hdrs.as_mut_ptr(),
                N as libc::c_uint,
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
            // A datagram longer than its slot keeps `slot` bytes, so the
            // reader sees it is too long and rejects it.
            batch.lens[i] = if truncated {
                slot
            } else {
                (hdrs[i].msg_len as usize).min(slot)
            };
            batch.addrs[i] = from_sockaddr(&names[i]);
        }
        Ok(n)
    }

    pub(super) fn send_to_many(sock: &UdpSocket, payload: &[u8], dests: &[SocketAddr]) -> usize {
        let mut failed = 0;
        for chunk in dests.chunks(SEND_CHUNK) {
            // SAFETY: all-zero is valid for these C structs, as in `recv`.
            let mut names: [libc::sockaddr_storage; SEND_CHUNK] = unsafe { zeroed() };
            let mut iov = libc::iovec {
                iov_base: payload.as_ptr() as *mut libc::c_void,
                iov_len: payload.len(),
            };
            // SAFETY: as above.
            let mut hdrs: [libc::mmsghdr; SEND_CHUNK] = unsafe { zeroed() };
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
                // payload, so casting its pointer to *mut is harmless), and all
                // of them outlive the call.
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
                    failed += 1;
                    start += 1;
                } else {
                    start += r as usize;
                }
            }
        }
        failed
    }

    pub(super) fn send_connected(sock: &UdpSocket, msgs: &[&[u8]]) -> io::Result<usize> {
        let mut sent = 0;
        for chunk in msgs.chunks(SEND_CHUNK) {
            // SAFETY: all-zero is valid for these C structs, as in `recv`.
            let mut iovs: [libc::iovec; SEND_CHUNK] = unsafe { zeroed() };
            // SAFETY: as above.
            let mut hdrs: [libc::mmsghdr; SEND_CHUNK] = unsafe { zeroed() };
            for (i, m) in chunk.iter().enumerate() {
                iovs[i] = libc::iovec {
                    iov_base: m.as_ptr() as *mut libc::c_void,
                    iov_len: m.len(),
                };
                hdrs[i].msg_hdr.msg_iov = &mut iovs[i];
                hdrs[i].msg_hdr.msg_iovlen = 1;
            }
            let mut start = 0;
            while start < chunk.len() {
                // SAFETY: headers `start..chunk.len()` point at live iovecs
                // that point at the caller's buffers; the kernel only reads
                // them, and a null name sends to the connected peer.
                let r = unsafe {
                    libc::sendmmsg(
                        sock.as_raw_fd(),
                        hdrs.as_mut_ptr().add(start),
                        (chunk.len() - start) as libc::c_uint,
                        0,
                    )
                };
                if r < 0 {
                    let e = io::Error::last_os_error();
                    match e.kind() {
                        io::ErrorKind::Interrupted => continue,
                        io::ErrorKind::WouldBlock => return Ok(sent),
                        _ => return Err(e),
                    }
                }
                start += r as usize;
                sent += r as usize;
            }
        }
        Ok(sent)
    }

    pub(super) fn to_sockaddr(
        addr: &SocketAddr,
        out: &mut libc::sockaddr_storage,
    ) -> libc::socklen_t {
        match addr {
            SocketAddr::V4(a) => {
                let sin = sockaddr_in(a);
                // SAFETY: sockaddr_storage is larger than and aligned for every
                // sockaddr type, which is what it exists for, and `out` is a
                // live, exclusive reference.
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

    pub(super) fn sockaddr_in(a: &SocketAddrV4) -> libc::sockaddr_in {
        libc::sockaddr_in {
            sin_family: libc::AF_INET as libc::sa_family_t,
            sin_port: a.port().to_be(),
            sin_addr: libc::in_addr {
                s_addr: u32::from_ne_bytes(a.ip().octets()),
            },
            sin_zero: [0; 8],
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

    pub(super) fn recv<const N: usize>(
        sock: &UdpSocket,
        batch: &mut RecvBatch<N>,
    ) -> io::Result<usize> {
        let mut n = 0;
        while n < N {
            let slot = batch.slot;
            match sock.recv_from(&mut batch.buf[n * slot..(n + 1) * slot]) {
                Ok((len, addr)) => {
                    batch.lens[n] = len;
                    batch.addrs[n] = Some(addr);
                    n += 1;
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
                    ) =>
                {
                    break
                }
                Err(e) if n == 0 => return Err(e),
                Err(_) => break,
            }
        }
        Ok(n)
    }

    pub(super) fn send_to_many(sock: &UdpSocket, payload: &[u8], dests: &[SocketAddr]) -> usize {
        dests
            .iter()
            .filter(|d| sock.send_to(payload, d).is_err())
            .count()
    }

    pub(super) fn send_connected(sock: &UdpSocket, msgs: &[&[u8]]) -> io::Result<usize> {
        let mut sent = 0;
        for m in msgs {
            match sock.send(m) {
                Ok(_) => sent += 1,
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                Err(e) => return Err(e),
            }
        }
        Ok(sent)
    }
}

#[cfg(target_os = "linux")]
mod segments;
#[cfg(target_os = "linux")]
pub use segments::Repeater;

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn pair() -> (UdpSocket, UdpSocket) {
        let a = UdpSocket::bind("127.0.0.1:0").unwrap();
        let b = UdpSocket::bind("127.0.0.1:0").unwrap();
        b.set_nonblocking(true).unwrap();
        (a, b)
    }

    fn recv_all<const N: usize>(sock: &UdpSocket, batch: &mut RecvBatch<N>, want: usize) {
        for _ in 0..500 {
            crate::wait::wait_readable(sock, Some(Duration::from_millis(10))).unwrap();
            if batch.recv(sock).unwrap() >= want {
                return;
            }
        }
        panic!("fewer than {want} datagrams arrived");
    }

    #[test]
    fn a_batch_holds_each_datagram_with_its_source() {
        let (a, b) = pair();
        let to = b.local_addr().unwrap();
        a.send_to(b"one", to).unwrap();
        a.send_to(b"two", to).unwrap();
        let mut batch = RecvBatch::<8>::new(16);
        recv_all(&b, &mut batch, 2);
        let got: Vec<(SocketAddr, &[u8])> = batch.iter().collect();
        let from = a.local_addr().unwrap();
        assert_eq!(got, [(from, &b"one"[..]), (from, &b"two"[..])]);
    }

    #[test]
    fn a_datagram_longer_than_its_slot_fills_the_slot() {
        let (a, b) = pair();
        a.send_to(&[7; 40], b.local_addr().unwrap()).unwrap();
        let mut batch = RecvBatch::<2>::new(16);
        recv_all(&b, &mut batch, 1);
        assert_eq!(batch.get(0), [7; 16]);
    }

    #[test]
    fn nothing_waiting_is_an_empty_batch() {
        let (_a, b) = pair();
        let mut batch = RecvBatch::<2>::new(16);
        assert_eq!(batch.recv(&b).unwrap(), 0);
        assert!(batch.is_empty());
    }

    #[test]
    fn one_payload_goes_to_every_destination() {
        let (a, b) = pair();
        let (c, d) = pair();
        let dests = [b.local_addr().unwrap(), d.local_addr().unwrap()];
        assert_eq!(send_to_many(&a, b"hi", &dests), 0);
        for s in [&b, &d] {
            let mut batch = RecvBatch::<2>::new(16);
            recv_all(s, &mut batch, 1);
            assert_eq!(batch.get(0), b"hi");
        }
        drop(c);
    }

    #[test]
    fn a_connected_socket_sends_a_batch_in_order() {
        let (a, b) = pair();
        a.connect(b.local_addr().unwrap()).unwrap();
        let msgs: Vec<Vec<u8>> = (0..100u8).map(|i| vec![i; 3]).collect();
        let refs: Vec<&[u8]> = msgs.iter().map(Vec::as_slice).collect();
        assert_eq!(send_connected(&a, &refs).unwrap(), 100);
        let mut seen = Vec::new();
        let mut batch = RecvBatch::<64>::new(16);
        while seen.len() < 100 {
            recv_all(&b, &mut batch, 1);
            seen.extend((0..batch.len()).map(|i| batch.get(i)[0]));
        }
        assert_eq!(seen, (0..100).collect::<Vec<u8>>());
    }
}
