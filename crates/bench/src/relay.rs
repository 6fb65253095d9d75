//! The UDP floor for throughput: a relay thread that repeats every datagram
//! to a fixed list of subscribers with the fewest system calls Linux allows
//! (`recvmmsg` for a batch, then one `sendmmsg` for batch × subscribers).
//! No parsing, no routing table: what a perfect UDP hub could reach.
//!
//! Optionally (`--relay-gso`) it also shows what UDP generic segmentation
//! offload would give: a run of equal-length datagrams for one destination
//! goes through the stack once and is split only where it is delivered.

use std::io;
use std::mem::{size_of, zeroed};
use std::net::{SocketAddr, UdpSocket};
use std::os::fd::AsRawFd;
use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};
use std::sync::Arc;
use std::thread::{self, JoinHandle};
use std::time::Duration;

use crate::sys::{self, RecvBatch, BATCH};

/// The most messages one `sendmmsg` takes (`UIO_MAXIOV`).
const MAX_VLEN: usize = 1024;

pub struct RelayThread {
    pub addr: SocketAddr,
    tid: Arc<AtomicI32>,
    stop: Arc<AtomicBool>,
    handle: JoinHandle<io::Result<()>>,
}

impl RelayThread {
    /// Starts a relay to `dests` (IPv4 only), kept on `cpu` if one is given.
    /// With `gso`, runs of equal-length datagrams go out as one UDP GSO send
    /// (`UDP_SEGMENT`) per destination.
    pub fn start(dests: Vec<SocketAddr>, cpu: Option<usize>, gso: bool) -> io::Result<RelayThread> {
        let sock = UdpSocket::bind("127.0.0.1:0")?;
        sock.set_nonblocking(true)?;
        let addr = sock.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let tid = Arc::new(AtomicI32::new(0));
        let handle = {
            let (stop, tid) = (stop.clone(), tid.clone());
            thread::Builder::new().name("relay".into()).spawn(move || {
                let pinned = sys::pin_self(cpu.as_ref().map(std::slice::from_ref));
                tid.store(sys::gettid(), Ordering::SeqCst);
                pinned?;
                relay(&sock, &dests, gso, &stop)
            })?
        };
        while tid.load(Ordering::SeqCst) == 0 {
            thread::yield_now();
        }
        Ok(RelayThread {
            addr,
            tid,
            stop,
            handle,
        })
    }

    pub fn cpu(&self) -> Option<Duration> {
        sys::thread_cpu(self.tid.load(Ordering::SeqCst))
    }

    pub fn stop(self) -> io::Result<()> {
        self.stop.store(true, Ordering::SeqCst);
        self.handle
            .join()
            .map_err(|_| io::Error::other("relay thread panicked"))?
    }
}

fn sockaddr_in(addr: &SocketAddr) -> io::Result<libc::sockaddr_in> {
    match addr {
        SocketAddr::V4(a) => Ok(libc::sockaddr_in {
            sin_family: libc::AF_INET as libc::sa_family_t,
            sin_port: a.port().to_be(),
            sin_addr: libc::in_addr {
                s_addr: u32::from_ne_bytes(a.ip().octets()),
            },
            sin_zero: [0; 8],
        }),
        SocketAddr::V6(_) => Err(io::Error::new(
            io::ErrorKind::Unsupported,
            "the relay is IPv4 only",
        )),
    }
}

/// Bytes of the control message that carries `UDP_SEGMENT` (a u16).
const CMSG_BYTES: usize = 24;
/// `UDP_SEGMENT` from linux/udp.h.
const UDP_SEGMENT: libc::c_int = 103;
/// The most segments one GSO send may carry (`UDP_MAX_SEGMENTS` is 64 on older kernels).
const MAX_SEGMENTS: usize = 64;

/// Writes a `UDP_SEGMENT` control message for segments of `size` bytes.
fn set_segment_size(buf: &mut [u64; 4], size: usize) {
    // SAFETY: CMSG_SPACE is a pure computation.
    debug_assert_eq!(unsafe { libc::CMSG_SPACE(2) } as usize, CMSG_BYTES);
    // SAFETY: `buf` is 32 bytes, 8-byte aligned, which holds one cmsghdr
    // (16 bytes) and its 2 data bytes; the header is written through the
    // pointer CMSG_FIRSTHDR gives for a msghdr describing exactly `buf`.
    unsafe {
        let mut msg: libc::msghdr = zeroed();
        msg.msg_control = buf.as_mut_ptr().cast();
        msg.msg_controllen = CMSG_BYTES;
        let c = libc::CMSG_FIRSTHDR(&msg);
        (*c).cmsg_level = libc::SOL_UDP;
        (*c).cmsg_type = UDP_SEGMENT;
        (*c).cmsg_len = libc::CMSG_LEN(2) as usize;
        std::ptr::write_unaligned(libc::CMSG_DATA(c).cast::<u16>(), size as u16);
    }
}

fn relay(sock: &UdpSocket, dests: &[SocketAddr], gso: bool, stop: &AtomicBool) -> io::Result<()> {
    let mut names = dests
        .iter()
        .map(sockaddr_in)
        .collect::<io::Result<Vec<_>>>()?;
    let mut batch = RecvBatch::new();
    let mut epoll = sys::Epoll::new()?;
    epoll.add(sock.as_raw_fd(), 0)?;
    let mut iovs: Vec<libc::iovec> = Vec::with_capacity(BATCH);
    let mut units: Vec<(usize, usize)> = Vec::with_capacity(BATCH);
    let mut cmsgs = vec![[0u64; 4]; BATCH];
    // SAFETY: all-zero is a valid mmsghdr (null pointers, zero lengths).
    let mut hdrs: Vec<libc::mmsghdr> = vec![unsafe { zeroed() }; BATCH * dests.len()];
    while !stop.load(Ordering::Relaxed) {
        let n = batch.recv(sock.as_raw_fd())?;
        if n == 0 {
            let _ = epoll.wait(Duration::from_millis(100))?.count();
            continue;
        }
        iovs.clear();
        for i in 0..n {
            let d = batch.get(i);
            iovs.push(libc::iovec {
                iov_base: d.as_ptr() as *mut libc::c_void,
                iov_len: d.len(),
            });
        }
        // Units to send: one datagram each, or with GSO a run of datagrams
        // of equal length sent as one, which the kernel splits at the end.
        units.clear();
        let mut i = 0;
        while i < n {
            let len = iovs[i].iov_len;
            let mut end = i + 1;
            if gso {
                while end < n && iovs[end].iov_len == len && end - i < MAX_SEGMENTS {
                    end += 1;
                }
            }
            units.push((i, end));
            i = end;
        }
        let mut count = 0;
        for (u, &(first, end)) in units.iter().enumerate() {
            let segments = end - first;
            if segments > 1 {
                set_segment_size(&mut cmsgs[u], iovs[first].iov_len);
            }
            for name in names.iter_mut() {
                let h = &mut hdrs[count].msg_hdr;
                h.msg_name = (name as *mut libc::sockaddr_in).cast();
                h.msg_namelen = size_of::<libc::sockaddr_in>() as libc::socklen_t;
                h.msg_iov = &mut iovs[first];
                h.msg_iovlen = segments;
                if segments > 1 {
                    h.msg_control = cmsgs[u].as_mut_ptr().cast();
                    h.msg_controllen = CMSG_BYTES;
                } else {
                    h.msg_control = std::ptr::null_mut();
                    h.msg_controllen = 0;
                }
                count += 1;
            }
        }
        let mut start = 0;
        while start < count {
            let vlen = (count - start).min(MAX_VLEN);
            // SAFETY: headers `start..start + vlen` were set above and point at
            // `names` and `iovs`, which point at `batch`; all outlive the call.
            let r = unsafe {
                libc::sendmmsg(
                    sock.as_raw_fd(),
                    hdrs.as_mut_ptr().add(start),
                    vlen as libc::c_uint,
                    libc::MSG_DONTWAIT,
                )
            };
            if r < 0 {
                let e = io::Error::last_os_error();
                if e.kind() == io::ErrorKind::Interrupted {
                    continue;
                }
                start += 1; // drop the one that failed, as the hub does
            } else {
                start += r as usize;
            }
        }
    }
    Ok(())
}
