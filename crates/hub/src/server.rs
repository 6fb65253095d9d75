//! The UDP runtime: a socket, a [`Hub`], and an optional traffic log.

use std::io;
use std::net::{SocketAddr, ToSocketAddrs, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant, SystemTime};

use crate::log::LogWriter;
use colony_sys::buffers::{self, Buffer};
use colony_sys::udp::{send_to_many, RecvBatch};
use colony_sys::wait::wait_readable;

use crate::{DropReason, Hub, HubConfig, Outcome};

/// The hub on a UDP socket. It owns its loop only inside [`Server::run`];
/// [`Server::poll`] does one round for a caller with a loop of its own.
pub struct Server {
    socket: UdpSocket,
    hub: Hub,
    log: Option<LogWriter>,
    batch: RecvBatch<BATCH>,
}

/// Datagrams taken per receive call.
const BATCH: usize = 32;
/// Room for the largest UDP payload, plus one byte to notice anything larger.
const SLOT: usize = colony_wire::MAX_PACKET + 1;

/// Socket buffer the hub asks for: about 4,000 small datagrams of burst.
const SOCKET_BUFFER: usize = 4 << 20;

/// The longest [`Server::run`] sleeps before it looks at its stop flag.
const STOP_CHECK: Duration = Duration::from_millis(100);

impl Server {
    /// Binds the hub's socket (use `127.0.0.1:7400` for a hub that only this machine reaches).
    pub fn bind(addr: impl ToSocketAddrs, config: HubConfig) -> io::Result<Server> {
        let socket = UdpSocket::bind(addr)?;
        socket.set_nonblocking(true)?;
        let got = enlarge_buffers(&socket, SOCKET_BUFFER);
        if got < SOCKET_BUFFER {
            tracing::warn!(
                bytes = got,
                wanted = SOCKET_BUFFER,
                "small socket buffer: raise net.core.rmem_max, or bursts will be dropped"
            );
        }
        Ok(Server {
            socket,
            hub: Hub::new(config, Instant::now()),
            log: None,
            batch: RecvBatch::new(SLOT),
        })
    }

    /// Records every accepted packet in this log.
    pub fn with_log(mut self, log: LogWriter) -> Server {
        self.log = Some(log);
        self
    }

    /// The address the hub listens on (with the port chosen, if 0 was asked for).
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.socket.local_addr()
    }

    /// The state machine inside, for its counters.
    pub fn hub(&self) -> &Hub {
        &self.hub
    }

    /// Serves until `stop` is set; then flushes the log.
    pub fn run(&mut self, stop: &AtomicBool) -> io::Result<()> {
        while !stop.load(Ordering::Relaxed) {
            self.poll(STOP_CHECK)?;
        }
        if let Some(log) = &mut self.log {
            log.flush()?;
        }
        Ok(())
    }

    /// Waits at most `max_wait` for datagrams, handles every one that is
    /// waiting, sends what they cause, and runs the hub's timers. Returns how
    /// many datagrams it handled.
    pub fn poll(&mut self, max_wait: Duration) -> io::Result<usize> {
        let mut handled = 0;
        loop {
            let n = self.batch.recv(&self.socket)?;
            if n == 0 {
                break;
            }
            handled += n;
            self.handle_batch();
        }
        if let Some(log) = &mut self.log {
            // One flush per round: a crash loses at most the round in hand,
            // and can only tear the record being written.
            if let Err(e) = log.flush() {
                tracing::error!(error = %e, "traffic log failed; serving on without it");
                self.log = None;
            }
        }
        let now = Instant::now();
        self.hub.handle_timeout(now);
        if handled == 0 {
            let wait = self
                .hub
                .poll_timeout()
                .saturating_duration_since(now)
                .min(max_wait);
            wait_readable(&self.socket, Some(wait))?;
        }
        Ok(handled)
    }

    fn handle_batch(&mut self) {
        let now = Instant::now();
        let wall = SystemTime::now();
        for (src, data) in self.batch.iter() {
            let outcome = self.hub.handle(now, src, data);
            if outcome.accepted() {
                if let Some(log) = &mut self.log {
                    if let Err(e) = log.append(wall, src, data) {
                        // Losing the log must not take the whole system down with it.
                        tracing::error!(error = %e, "traffic log failed; serving on without it");
                        self.log = None;
                    }
                }
            }
            let failed = match outcome {
                Outcome::Forward { len, dests } => send_to_many(&self.socket, &data[..len], dests),
                Outcome::Control | Outcome::Dropped(_) => 0,
            };
            if failed > 0 {
                self.hub.record_drops(DropReason::SendFailed, failed as u64);
            }
            while let Some(t) = self.hub.poll_transmit() {
                if send_to_many(&self.socket, &t.payload, &[t.dest]) > 0 {
                    self.hub.record_drops(DropReason::SendFailed, 1);
                }
            }
        }
    }
}

/// Asks for `bytes` of receive and send buffer: a hub takes bursts from many
/// publishers at once, and the default (about 208 KiB, some 200 small
/// datagrams) drops them at its own socket. The kernel caps the request at
/// `net.core.rmem_max`; a privileged process may exceed that cap, so that is
/// tried next. Returns the receive buffer size in force.
fn enlarge_buffers(sock: &UdpSocket, bytes: usize) -> usize {
    // Linux reports double the size asked for (it counts its bookkeeping).
    let size = |which| buffers::size(sock, which).map_or(0, |b| b / 2);
    for which in [Buffer::Receive, Buffer::Send] {
        // Refusals are fine: the size in force is what counts, and it is read back.
        let _ = buffers::set_size(sock, which, bytes, false);
        if size(which) < bytes {
            let _ = buffers::set_size(sock, which, bytes, true);
        }
    }
    size(Buffer::Receive)
}
