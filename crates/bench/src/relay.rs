//! The UDP floor for throughput: a relay thread that repeats every datagram
//! to a fixed list of subscribers with the fewest system calls Linux allows
//! (`recvmmsg` for a batch, then one `sendmmsg` for batch × subscribers).
//! No parsing, no routing table: what a perfect UDP hub could reach.
//!
//! Optionally (`--relay-gso`) it also shows what UDP generic segmentation
//! offload would give: a run of equal-length datagrams (and a shorter one
//! after it) for one destination goes through the stack once and is split only where it is delivered.

use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};
use std::sync::Arc;
use std::thread::{self, JoinHandle};
use std::time::Duration;

use colony_sys::udp::Repeater;

use crate::sys::{self, RecvBatch, SLOT};

pub struct RelayThread {
    pub addr: SocketAddr,
    tid: Arc<AtomicI32>,
    stop: Arc<AtomicBool>,
    handle: JoinHandle<io::Result<()>>,
}

impl RelayThread {
    /// Starts a relay to `dests` (IPv4 only), kept on `cpu` if one is given.
    /// With `gso`, runs of equal-length datagrams (and a shorter one after
    /// each) go out as one UDP GSO send (`UDP_SEGMENT`) per destination.
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

fn relay(sock: &UdpSocket, dests: &[SocketAddr], gso: bool, stop: &AtomicBool) -> io::Result<()> {
    let mut repeater = Repeater::new(dests, gso);
    let mut batch = RecvBatch::new(SLOT);
    let mut epoll = sys::Epoll::new()?;
    epoll.add(sock, 0)?;
    while !stop.load(Ordering::Relaxed) {
        let n = batch.recv(sock)?;
        if n == 0 {
            let _ = epoll.wait(Duration::from_millis(100))?.count();
            continue;
        }
        repeater.repeat(sock, &batch);
    }
    Ok(())
}
