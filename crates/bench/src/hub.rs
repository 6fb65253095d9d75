//! A colony hub (`colony_hub::Server`) on its own thread, and subscribing to it.

use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};
use std::sync::Arc;
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use colony_hub::{DropReason, HubConfig, Server};
use colony_wire::{Cookie, Packet, Reply, Request, Subject};

use crate::sys;

/// A hub serving on 127.0.0.1 from a thread of this process.
pub struct HubThread {
    pub addr: SocketAddr,
    tid: Arc<AtomicI32>,
    stop: Arc<AtomicBool>,
    handle: JoinHandle<io::Result<Server>>,
}

/// What the hub counted, read after it stopped.
#[derive(Default)]
pub struct HubDrops {
    pub send_failed: u64,
    pub send_full: u64,
    pub receive_overflow: u64,
    pub total: u64,
}

impl HubDrops {
    /// Adds another run's counts.
    pub fn add(&mut self, other: &HubDrops) {
        self.send_failed += other.send_failed;
        self.send_full += other.send_full;
        self.receive_overflow += other.receive_overflow;
        self.total += other.total;
    }
}

impl HubThread {
    /// Starts a hub on a thread of its own, kept on `cpu` if one is given.
    pub fn start(config: HubConfig, cpu: Option<usize>) -> anyhow::Result<HubThread> {
        let mut server = Server::bind("127.0.0.1:0", config).context("binding the hub")?;
        let addr = server.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let tid = Arc::new(AtomicI32::new(0));
        let handle = {
            let stop = stop.clone();
            let tid = tid.clone();
            thread::Builder::new().name("hub".into()).spawn(move || {
                let pinned = sys::pin_self(cpu.as_ref().map(std::slice::from_ref));
                tid.store(sys::gettid(), Ordering::SeqCst);
                pinned?;
                server.run(&stop)?;
                Ok(server)
            })?
        };
        while tid.load(Ordering::SeqCst) == 0 {
            thread::yield_now();
        }
        Ok(HubThread {
            addr,
            tid,
            stop,
            handle,
        })
    }

    /// CPU time the hub's thread has used so far.
    pub fn cpu(&self) -> Option<Duration> {
        sys::thread_cpu(self.tid.load(Ordering::SeqCst))
    }

    pub fn stop(self) -> anyhow::Result<HubDrops> {
        self.stop.store(true, Ordering::SeqCst);
        let server = self
            .handle
            .join()
            .map_err(|_| anyhow::anyhow!("hub thread panicked"))??;
        let hub = server.hub();
        Ok(HubDrops {
            send_failed: hub.drops(DropReason::SendFailed),
            send_full: hub.drops(DropReason::SendFull),
            receive_overflow: hub.drops(DropReason::ReceiveOverflow),
            total: DropReason::ALL.iter().map(|&r| hub.drops(r)).sum(),
        })
    }
}

/// Subscribes a UDP socket (connected to the hub) to `channel`, with the
/// cookie round trip, and waits for the lease. Leaves the socket blocking
/// with no read timeout.
pub fn subscribe_udp(sock: &UdpSocket, channel: &str) -> anyhow::Result<()> {
    subscribe_udp_with(sock, channel, &[])
}

/// Like [`subscribe_udp`], with further requests (`batch bytes N`) in the
/// subscribing packet.
pub fn subscribe_udp_with(
    sock: &UdpSocket,
    channel: &str,
    extra: &[Request],
) -> anyhow::Result<()> {
    let subject = Subject::new(channel)?;
    let mut cookie = Cookie::NONE;
    sock.set_nonblocking(false)?;
    sock.set_read_timeout(Some(Duration::from_millis(200)))?;
    let mut buf = [0u8; 2048];
    let deadline = Instant::now() + Duration::from_secs(3);
    'attempt: while Instant::now() < deadline {
        let mut requests = vec![Request::Cookie(cookie), Request::Subscribe(subject.clone())];
        requests.extend_from_slice(extra);
        let request = Request::to_packet(&requests);
        sock.send(&request)?;
        loop {
            match sock.recv(&mut buf) {
                Ok(n) => {
                    let Ok(p) = Packet::parse(&buf[..n]) else {
                        continue;
                    };
                    match Reply::parse(&p) {
                        Some(Ok(Reply::Lease { .. })) => {
                            sock.set_read_timeout(None)?;
                            return Ok(());
                        }
                        Some(Ok(Reply::Cookie(c))) => {
                            cookie = c;
                            continue 'attempt;
                        }
                        _ => {}
                    }
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                    ) =>
                {
                    continue 'attempt
                }
                Err(e) => return Err(e.into()),
            }
        }
    }
    bail!("the hub at {:?} sent no lease", sock.peer_addr().ok())
}
