//! Many datagrams per system call: `recvmmsg` and `sendmmsg` on Linux, one
//! datagram at a time elsewhere; UDP generic segmentation offload (a run of
//! equal-length datagrams for one destination, and a shorter one after it,
//! handed to the kernel as one send, split only where it is delivered); the
//! kernel's count of the datagrams it dropped because a socket's receive
//! buffer was full; and which socket errors concern one datagram only.

use std::io;
use std::net::{SocketAddr, UdpSocket};

mod send;
pub use send::{Framing, Loss, Repeater, SendPlan, SendReport, Sender};

/// The most messages one `sendmmsg` takes, and the most iovecs one message
/// may have (`UIO_MAXIOV`); more is `EINVAL`.
const MAX_VLEN: usize = 1024;
/// The largest UDP payload: an IPv4 datagram's limit.
const MAX_DATAGRAM: usize = 65_507;

/// Bytes of control-message room per received datagram: one `SO_RXQ_OVFL`
/// message (`CMSG_SPACE(4)`, 24 bytes on 64-bit Linux) with room to spare,
/// as 8-byte words so the buffer is aligned for a `cmsghdr`.
const CONTROL_WORDS: usize = 4;

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
    /// Each datagram's control messages (the kernel's drop counter).
    control: Vec<[u64; CONTROL_WORDS]>,
    kernel_drops: Option<u32>,
    #[cfg(target_os = "linux")]
    scratch: imp::RecvScratch,
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
            control: vec![[0; CONTROL_WORDS]; N],
            kernel_drops: None,
            #[cfg(target_os = "linux")]
            scratch: imp::RecvScratch::new(N),
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

    /// The source of datagram `i` of the last receive (`None` if it is no
    /// IP address, or `i` is past the batch).
    pub fn source(&self, i: usize) -> Option<SocketAddr> {
        if i < self.count {
            self.addrs[i]
        } else {
            None
        }
    }

    /// The datagrams of the last receive, with their sources (one whose
    /// source is not an IP address is left out).
    pub fn iter(&self) -> impl Iterator<Item = (SocketAddr, &[u8])> {
        (0..self.count).filter_map(move |i| Some((self.addrs[i]?, self.get(i))))
    }

    /// The socket's count of datagrams the kernel dropped for want of
    /// receive buffer, as it stood when the last datagram of the last
    /// receive was queued; `None` unless [`count_kernel_drops`] was turned on
    /// for the socket and the last receive took a datagram queued after the
    /// first drop (Linux leaves the count out while it is 0). The count is
    /// cumulative over the socket's life and wraps at `u32::MAX`: subtract
    /// the previous reading (with `wrapping_sub`) for the drops in between.
    pub fn kernel_drops(&self) -> Option<u32> {
        self.kernel_drops
    }

    /// Receives up to `N` waiting datagrams without blocking; returns how
    /// many (0 when none is waiting or a signal interrupted the call).
    pub fn recv(&mut self, sock: &UdpSocket) -> io::Result<usize> {
        self.count = 0;
        self.kernel_drops = None;
        let n = imp::recv(sock, self, false)?;
        self.count = n;
        Ok(n)
    }

    /// Like [`recv`](Self::recv), but waits for the first datagram as the
    /// socket says: a blocking socket with a read timeout
    /// ([`UdpSocket::set_read_timeout`]) waits at most that long, and then
    /// takes whatever else is waiting without waiting more (Linux's
    /// `MSG_WAITFORONE`). Returns 0 when the timeout passes or a signal comes.
    /// One system call where a readiness wait and a receive take two.
    #[cfg(target_os = "linux")]
    pub fn recv_waiting(&mut self, sock: &UdpSocket) -> io::Result<usize> {
        self.count = 0;
        self.kernel_drops = None;
        let n = imp::recv(sock, self, true)?;
        self.count = n;
        Ok(n)
    }
}

/// Asks the kernel to report, with each datagram received on `sock`, how
/// many it has dropped so far because the socket's receive buffer was full
/// (`SO_RXQ_OVFL`); [`RecvBatch::kernel_drops`] reads it. Linux only: other
/// systems answer `Unsupported`.
pub fn count_kernel_drops(sock: &UdpSocket) -> io::Result<()> {
    imp::count_kernel_drops(sock)
}

/// Whether an error from a connected UDP socket's `send` or `recv` concerns
/// one datagram rather than the socket: an ICMP error that came back for an
/// earlier datagram (port or protocol refused, host or network unreachable,
/// down or isolated, administratively prohibited, too big for the path, a
/// bad parameter), a full buffer, or a signal. The next datagram may well
/// pass, so a client that must outlive a hub restart or a Wi-Fi gap goes on
/// past it (and counts it). What remains is the socket's own fault (a closed
/// descriptor, a bad argument).
pub fn is_transient(err: &io::Error) -> bool {
    use io::ErrorKind::*;
    if matches!(
        err.kind(),
        ConnectionRefused
            | HostUnreachable
            | NetworkUnreachable
            | NetworkDown
            | WouldBlock
            | Interrupted
    ) {
        return true;
    }
    #[cfg(unix)]
    if matches!(
        err.raw_os_error(),
        Some(
            libc::ENOBUFS
                | libc::EHOSTDOWN
                | libc::EACCES
                | libc::EMSGSIZE
                | libc::EPROTO
                | libc::ENOPROTOOPT
        )
    ) {
        return true;
    }
    // Linux's "host isolated", which other systems do not have.
    #[cfg(any(target_os = "linux", target_os = "android"))]
    if err.raw_os_error() == Some(libc::ENONET) {
        return true;
    }
    false
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
    use std::os::fd::{AsRawFd, RawFd};

    pub(super) fn count_kernel_drops(sock: &UdpSocket) -> io::Result<()> {
        let on: libc::c_int = 1;
        // SAFETY: `on` is a live c_int and the length passed is its size, as
        // SO_RXQ_OVFL reads; the descriptor is borrowed, so it is open.
        let r = unsafe {
            libc::setsockopt(
                sock.as_raw_fd(),
                libc::SOL_SOCKET,
                libc::SO_RXQ_OVFL,
                (&on as *const libc::c_int).cast(),
                size_of::<libc::c_int>() as libc::socklen_t,
            )
        };
        if r == 0 {
            Ok(())
        } else {
            Err(io::Error::last_os_error())
        }
    }

    /// The C structures `recvmmsg` is handed, made (zeroed) once with the
    /// batch rather than on every call.
    pub(super) struct RecvScratch {
        names: Vec<libc::sockaddr_storage>,
        iovs: Vec<libc::iovec>,
        hdrs: Vec<libc::mmsghdr>,
    }

    // SAFETY: the raw pointers inside `iovs` and `hdrs` are set right before
    // each `recvmmsg` and used only by the kernel during it; between calls
    // nothing dereferences them, so moving the scratch to another thread
    // shares nothing.
    unsafe impl Send for RecvScratch {}

    impl RecvScratch {
        pub(super) fn new(n: usize) -> RecvScratch {
            // SAFETY: all-zero bytes are a valid value for these plain C
            // structs (null pointers and zero lengths).
            let (name, iov, hdr) = unsafe { (zeroed(), zeroed(), zeroed()) };
            RecvScratch {
                names: vec![name; n],
                iovs: vec![iov; n],
                hdrs: vec![hdr; n],
            }
        }
    }

    pub(super) fn recv<const N: usize>(
        sock: &UdpSocket,
        batch: &mut RecvBatch<N>,
        wait: bool,
    ) -> io::Result<usize> {
        let slot = batch.slot;
        let s = &mut batch.scratch;
        // Each vector holds N entries (made so in `new`); pointers into them
        // are taken once, and offset with wrapping_add inside them.
        let names = s.names.as_mut_ptr();
        let iovs = s.iovs.as_mut_ptr();
        let control = batch.control.as_mut_ptr();
        let buf = batch.buf.as_mut_ptr();
        for (i, iov) in s.iovs.iter_mut().enumerate().take(N) {
            iov.iov_base = buf.wrapping_add(i * slot).cast();
            iov.iov_len = slot;
        }
        for (i, m) in s.hdrs.iter_mut().enumerate().take(N) {
            // Every field the kernel reads or writes back is set again: the
            // name's and the control buffer's room, and the flags.
            m.msg_len = 0;
            let h = &mut m.msg_hdr;
            h.msg_name = names.wrapping_add(i).cast();
            h.msg_namelen = size_of::<libc::sockaddr_storage>() as libc::socklen_t;
            h.msg_iov = iovs.wrapping_add(i);
            h.msg_iovlen = 1;
            h.msg_control = control.wrapping_add(i).cast();
            h.msg_controllen = CONTROL_WORDS * 8;
            h.msg_flags = 0;
        }
        let count = N.min(s.hdrs.len());
        // SAFETY: `hdrs` holds `count` headers, each pointing at its own
        // iovec (`slot` bytes inside `batch.buf`, which is `slot * N` long),
        // its own sockaddr_storage with its true size and its own control
        // buffer of `CONTROL_WORDS * 8` bytes; all of them live in `batch`,
        // which outlives the call, and no other reference to those buffers
        // exists while it runs. The socket is borrowed, so its descriptor is
        // open.
        let r = unsafe {
            libc::recvmmsg(
                sock.as_raw_fd(),
                s.hdrs.as_mut_ptr(),
                count as libc::c_uint,
                if wait {
                    libc::MSG_WAITFORONE
                } else {
                    libc::MSG_DONTWAIT
                },
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
        let n = (r as usize).min(count);
        let (hdrs, names) = (&s.hdrs, &s.names);
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
            if let Some(d) = drop_counter(&hdrs[i].msg_hdr) {
                batch.kernel_drops = Some(d);
            }
        }
        Ok(n)
    }

    /// The `SO_RXQ_OVFL` count among a received message's control messages.
    fn drop_counter(msg: &libc::msghdr) -> Option<u32> {
        if msg.msg_flags & libc::MSG_CTRUNC != 0 {
            return None;
        }
        // SAFETY: `msg` is a header the kernel filled in: `msg_control` points
        // at this datagram's buffer (CONTROL_WORDS * 8 bytes, aligned for a
        // cmsghdr) and `msg_controllen` says how much of it the kernel wrote,
        // so CMSG_FIRSTHDR and CMSG_NXTHDR return headers inside it or null;
        // the counter is a u32 right after its header, read unaligned.
        unsafe {
            let mut c = libc::CMSG_FIRSTHDR(msg);
            while !c.is_null() {
                if (*c).cmsg_level == libc::SOL_SOCKET
                    && (*c).cmsg_type == libc::SO_RXQ_OVFL
                    && (*c).cmsg_len as usize >= libc::CMSG_LEN(4) as usize
                {
                    return Some(std::ptr::read_unaligned(libc::CMSG_DATA(c).cast::<u32>()));
                }
                c = libc::CMSG_NXTHDR(msg, c);
            }
        }
        None
    }

    /// The one `sendmmsg` loop: sends every header of `hdrs`, at most
    /// `UIO_MAXIOV` per call, retrying a call a signal interrupted. When the
    /// kernel refuses the first message of a call, `on_error` is given its
    /// index, the header and the error; it answers whether to go on with the
    /// next (the refused one is then skipped). Returns how many headers were
    /// dealt with: all of them, or the index of the one it stopped at.
    pub(super) fn send_all(
        fd: RawFd,
        hdrs: &mut [libc::mmsghdr],
        mut on_error: impl FnMut(usize, &libc::mmsghdr, io::Error) -> bool,
    ) -> usize {
        let mut start = 0;
        while start < hdrs.len() {
            let vlen = (hdrs.len() - start).min(MAX_VLEN);
            // SAFETY: headers `start..start + vlen` lie inside `hdrs`; the
            // caller made each point at live names, iovecs, payloads and
            // control buffers that outlive this call, which the kernel only
            // reads (sendmmsg writes nothing but each header's `msg_len`,
            // inside `hdrs`, which is borrowed mutably).
            let r = unsafe {
                libc::sendmmsg(
                    fd,
                    hdrs.as_mut_ptr().add(start),
                    vlen as libc::c_uint,
                    libc::MSG_DONTWAIT,
                )
            };
            if r > 0 {
                start += r as usize;
                continue;
            }
            let e = if r == 0 {
                // Never seen for vlen > 0; a refusal rather than a spin.
                io::Error::from(io::ErrorKind::WriteZero)
            } else {
                io::Error::last_os_error()
            };
            if e.kind() == io::ErrorKind::Interrupted {
                continue;
            }
            if !on_error(start, &hdrs[start], e) {
                return start;
            }
            start += 1;
        }
        start
    }

    pub(super) fn send_connected(sock: &UdpSocket, msgs: &[&[u8]]) -> io::Result<usize> {
        let mut iovs: Vec<libc::iovec> = msgs
            .iter()
            .map(|m| libc::iovec {
                iov_base: m.as_ptr() as *mut libc::c_void,
                iov_len: m.len(),
            })
            .collect();
        // SAFETY: all-zero is a valid mmsghdr (null pointers, zero lengths);
        // a null name sends to the connected peer.
        let mut hdrs: Vec<libc::mmsghdr> = vec![unsafe { zeroed() }; msgs.len()];
        let base = iovs.as_mut_ptr();
        for (i, h) in hdrs.iter_mut().enumerate() {
            h.msg_hdr.msg_iov = base.wrapping_add(i);
            h.msg_hdr.msg_iovlen = 1;
        }
        let mut error = None;
        let sent = send_all(sock.as_raw_fd(), &mut hdrs, |_, _, e| {
            if e.kind() != io::ErrorKind::WouldBlock {
                error = Some(e);
            }
            false
        });
        drop(iovs);
        match error {
            Some(e) if sent == 0 => Err(e),
            _ => Ok(sent),
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

    pub(super) fn sockaddr_in6(a: &SocketAddrV6) -> libc::sockaddr_in6 {
        libc::sockaddr_in6 {
            sin6_family: libc::AF_INET6 as libc::sa_family_t,
            sin6_port: a.port().to_be(),
            sin6_flowinfo: a.flowinfo(),
            sin6_addr: libc::in6_addr {
                s6_addr: a.ip().octets(),
            },
            sin6_scope_id: a.scope_id(),
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

    pub(super) fn count_kernel_drops(_sock: &UdpSocket) -> io::Result<()> {
        Err(io::Error::from(io::ErrorKind::Unsupported))
    }

    pub(super) fn recv<const N: usize>(
        sock: &UdpSocket,
        batch: &mut RecvBatch<N>,
        _wait: bool,
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
    fn errors_about_one_datagram_are_transient_and_the_rest_are_not() {
        let e = io::Error::from_raw_os_error;
        for n in [
            libc::ECONNREFUSED,
            libc::EHOSTUNREACH,
            libc::ENETUNREACH,
            libc::EHOSTDOWN,
            libc::ENETDOWN,
            libc::EACCES,
            libc::EMSGSIZE,
            libc::EPROTO,
            libc::ENOPROTOOPT,
            libc::ENOBUFS,
            libc::EAGAIN,
            libc::EINTR,
        ] {
            assert!(is_transient(&e(n)), "{}", e(n));
        }
        #[cfg(target_os = "linux")]
        assert!(is_transient(&e(libc::ENONET)));
        for n in [
            libc::EBADF,
            libc::ENOTSOCK,
            libc::EINVAL,
            libc::EFAULT,
            libc::ENOTCONN,
        ] {
            assert!(!is_transient(&e(n)), "{}", e(n));
        }
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

    #[cfg(target_os = "linux")]
    #[test]
    fn a_waiting_receive_ends_at_the_timeout_or_takes_all_that_waits() {
        let a = UdpSocket::bind("127.0.0.1:0").unwrap();
        let b = UdpSocket::bind("127.0.0.1:0").unwrap();
        b.set_read_timeout(Some(Duration::from_millis(20))).unwrap();
        let mut batch = RecvBatch::<8>::new(16);
        assert_eq!(batch.recv_waiting(&b).unwrap(), 0);
        let to = b.local_addr().unwrap();
        for d in [&b"one"[..], b"two", b"three"] {
            a.send_to(d, to).unwrap();
        }
        // Loopback queues each datagram before send_to returns: the first
        // is waited for, the rest are taken with it.
        assert_eq!(batch.recv_waiting(&b).unwrap(), 3);
        assert_eq!(batch.get(2), b"three");
    }

    #[test]
    fn nothing_waiting_is_an_empty_batch() {
        let (_a, b) = pair();
        let mut batch = RecvBatch::<2>::new(16);
        assert_eq!(batch.recv(&b).unwrap(), 0);
        assert!(batch.is_empty());
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

    #[test]
    fn the_kernel_reports_datagrams_dropped_for_want_of_buffer() {
        let (a, b) = pair();
        count_kernel_drops(&b).unwrap();
        crate::buffers::set_size(&b, crate::buffers::Buffer::Receive, 4096, false).unwrap();
        let to = b.local_addr().unwrap();
        // Far more than a 4 KiB buffer holds, and nobody reading.
        for _ in 0..200 {
            a.send_to(&[1; 100], to).unwrap();
        }
        let mut batch = RecvBatch::<64>::new(128);
        recv_all(&b, &mut batch, 1);
        while batch.recv(&b).unwrap() > 0 {}
        // The count comes with datagrams queued after the drops.
        a.send_to(&[1; 100], to).unwrap();
        recv_all(&b, &mut batch, 1);
        let before = batch.kernel_drops().unwrap();
        assert!(before > 0, "nothing dropped");
        a.send_to(&[1; 100], to).unwrap();
        recv_all(&b, &mut batch, 1);
        // Nothing was dropped since: the count stands where it stood.
        assert_eq!(batch.kernel_drops(), Some(before));
    }
}
