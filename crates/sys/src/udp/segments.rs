//! Repeating a received batch to fixed destinations with the fewest system
//! calls Linux allows, optionally with UDP generic segmentation offload:
//! what a perfect UDP hub could reach, for the benchmarks' floor.

use std::io;
use std::mem::{size_of, zeroed};
use std::net::{SocketAddr, UdpSocket};
use std::os::fd::AsRawFd;

use super::imp::sockaddr_in;
use super::RecvBatch;

/// The most messages one `sendmmsg` takes (`UIO_MAXIOV`).
const MAX_VLEN: usize = 1024;
/// Bytes of the control message that carries `UDP_SEGMENT` (a u16):
/// `CMSG_SPACE(2)` on 64-bit Linux.
const CMSG_BYTES: usize = 24;
/// `UDP_SEGMENT` from linux/udp.h.
const UDP_SEGMENT: libc::c_int = 103;
/// The most segments one GSO send may carry (`UDP_MAX_SEGMENTS` is 64 on older kernels).
const MAX_SEGMENTS: usize = 64;

/// Repeats every datagram of a [`RecvBatch`] to a fixed list of IPv4
/// destinations in one `sendmmsg` per batch. With `gso`, each run of
/// equal-length datagrams goes out as one send per destination
/// (`UDP_SEGMENT`), which the kernel splits only where it delivers it.
///
/// It keeps its buffers from batch to batch; they point into the batch while
/// a send runs, so a `Repeater` stays on the thread that made it.
pub struct Repeater {
    names: Vec<libc::sockaddr_in>,
    gso: bool,
    iovs: Vec<libc::iovec>,
    units: Vec<(usize, usize)>,
    cmsgs: Vec<[u64; 4]>,
    hdrs: Vec<libc::mmsghdr>,
}

impl Repeater {
    /// A repeater to `dests`, which must be IPv4 addresses.
    pub fn new(dests: &[SocketAddr], gso: bool) -> io::Result<Repeater> {
        let names = dests
            .iter()
            .map(|d| match d {
                SocketAddr::V4(a) => Ok(sockaddr_in(a)),
                SocketAddr::V6(_) => Err(io::Error::new(
                    io::ErrorKind::Unsupported,
                    "the relay is IPv4 only",
                )),
            })
            .collect::<io::Result<Vec<_>>>()?;
        Ok(Repeater {
            names,
            gso,
            iovs: Vec::new(),
            units: Vec::new(),
            cmsgs: Vec::new(),
            hdrs: Vec::new(),
        })
    }

    /// Sends the batch's datagrams to every destination, without blocking;
    /// a datagram the kernel refuses is dropped, as the hub does.
    pub fn repeat<const N: usize>(&mut self, sock: &UdpSocket, batch: &RecvBatch<N>) {
        let n = batch.len();
        self.iovs.clear();
        for i in 0..n {
            let d = batch.get(i);
            self.iovs.push(libc::iovec {
                iov_base: d.as_ptr() as *mut libc::c_void,
                iov_len: d.len(),
            });
        }
        // Units to send: one datagram each, or with GSO a run of datagrams
        // of equal length sent as one, which the kernel splits at the end.
        self.units.clear();
        let mut i = 0;
        while i < n {
            let len = self.iovs[i].iov_len;
            let mut end = i + 1;
            if self.gso {
                while end < n && self.iovs[end].iov_len == len && end - i < MAX_SEGMENTS {
                    end += 1;
                }
            }
            self.units.push((i, end));
            i = end;
        }
        let wanted = self.units.len() * self.names.len();
        if self.hdrs.len() < wanted {
            // SAFETY: all-zero is a valid mmsghdr (null pointers, zero lengths).
            self.hdrs.resize(wanted, unsafe { zeroed() });
        }
        if self.cmsgs.len() < self.units.len() {
            self.cmsgs.resize(self.units.len(), [0; 4]);
        }
        let mut count = 0;
        for (u, &(first, end)) in self.units.iter().enumerate() {
            let segments = end - first;
            if segments > 1 {
                set_segment_size(&mut self.cmsgs[u], self.iovs[first].iov_len);
            }
            for name in self.names.iter_mut() {
                let h = &mut self.hdrs[count].msg_hdr;
                h.msg_name = (name as *mut libc::sockaddr_in).cast();
                h.msg_namelen = size_of::<libc::sockaddr_in>() as libc::socklen_t;
                // Derived from the whole array, not one element: the kernel reads
                // `segments` iovecs from here.
                h.msg_iov = self.iovs[first..end].as_mut_ptr();
                h.msg_iovlen = segments;
                if segments > 1 {
                    h.msg_control = self.cmsgs[u].as_mut_ptr().cast();
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
            // SAFETY: headers `start..start + vlen` were set above and point
            // at `names`, `cmsgs` and runs of `iovs` (each run inside the
            // vector: `first + segments <= n`), which point at `batch`'s
            // buffers; none of these vectors is resized until the call
            // returns, all outlive it, and the kernel only reads them.
            let r = unsafe {
                libc::sendmmsg(
                    sock.as_raw_fd(),
                    self.hdrs.as_mut_ptr().add(start),
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
}

/// Writes a `UDP_SEGMENT` control message for segments of `size` bytes.
fn set_segment_size(buf: &mut [u64; 4], size: usize) {
    // SAFETY: CMSG_SPACE is a pure computation.
    debug_assert_eq!(unsafe { libc::CMSG_SPACE(2) } as usize, CMSG_BYTES);
    // SAFETY: `buf` is 32 bytes, 8-byte aligned, which holds one cmsghdr
    // (16 bytes) and its 2 data bytes; the header is written through the
    // pointer CMSG_FIRSTHDR gives for a msghdr describing exactly `buf`
    // (never null: CMSG_BYTES is at least a cmsghdr), and the data with an
    // unaligned write.
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn a_batch_is_repeated_to_every_destination() {
        for gso in [false, true] {
            let relay = UdpSocket::bind("127.0.0.1:0").unwrap();
            relay.set_nonblocking(true).unwrap();
            let subs: Vec<UdpSocket> = (0..2)
                .map(|_| UdpSocket::bind("127.0.0.1:0").unwrap())
                .collect();
            let dests: Vec<SocketAddr> = subs.iter().map(|s| s.local_addr().unwrap()).collect();
            let source = UdpSocket::bind("127.0.0.1:0").unwrap();
            for i in 0..3u8 {
                source
                    .send_to(&[i; 10], relay.local_addr().unwrap())
                    .unwrap();
            }
            let mut batch = RecvBatch::<8>::new(32);
            let mut got = 0;
            while got < 3 {
                crate::wait::wait_readable(&relay, Some(Duration::from_secs(5))).unwrap();
                got += batch.recv(&relay).unwrap();
            }
            let mut repeater = Repeater::new(&dests, gso).unwrap();
            repeater.repeat(&relay, &batch);
            for s in &subs {
                s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
                for i in 0..3u8 {
                    let mut buf = [0; 32];
                    let n = s.recv(&mut buf).unwrap();
                    assert_eq!(&buf[..n], &[i; 10], "gso {gso}");
                }
            }
        }
    }
}
