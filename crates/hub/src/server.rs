//! The UDP runtime: a socket, a [`Hub`], and an optional traffic log.

use std::io;
use std::net::{SocketAddr, ToSocketAddrs, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant, SystemTime};

use crate::log::LogSink;
use colony_sys::buffers::{self, Buffer};
use colony_sys::udp::{self, Framing, RecvBatch, SendPlan, Sender};
use colony_wire::batch;

use crate::{is_bad_source, DropReason, Hub, HubConfig, Outcome, Transmit};

/// The hub on a UDP socket. It owns its loop only inside [`Server::run`];
/// [`Server::poll`] does one round for a caller with a loop of its own.
pub struct Server {
    socket: UdpSocket,
    hub: Hub,
    log: Option<Box<dyn LogSink>>,
    batch: RecvBatch<BATCH>,
    /// The address the socket is bound to: never a destination.
    local: SocketAddr,
    /// Where each datagram of the batch in hand goes; its deliveries leave
    /// in one `sendmmsg`.
    plan: SendPlan,
    sender: Sender,
    /// The hub's replies caused by the batch in hand; the plan names reply
    /// `i` as datagram `BATCH + i`.
    replies: Vec<Transmit>,
    /// One forward's destinations, checked.
    dests: Vec<SocketAddr>,
    /// How much of each datagram of the batch is forwarded.
    lens: [usize; BATCH],
    /// The kernel's count of receive-buffer drops at the last reading.
    kernel_drops: u32,
    /// The last round ended with the socket empty, so the next one waits.
    drained: bool,
    /// The socket's read timeout as last set.
    #[cfg(target_os = "linux")]
    read_timeout: Duration,
}

/// Datagrams taken per receive call; also the longest run one GSO send can
/// carry (the kernel takes 64 segments). The slots' memory is touched only
/// as far as datagrams fill it.
const BATCH: usize = 64;
/// Receive calls per [`Server::poll`]: after this many full batches (256
/// datagrams, well under a millisecond of work) the round ends, so the
/// log is flushed, leases expire and the stop flag is read however fast
/// datagrams arrive.
const BATCHES_PER_POLL: usize = 4;
/// Room for the largest UDP payload, plus one byte to notice anything larger.
const SLOT: usize = colony_wire::MAX_PACKET + 1;

/// Several packets in one datagram, for subscribers that ask.
const BATCH_FRAMING: Framing = Framing {
    base: batch::HEAD_BASE,
    per_part: batch::head_cost,
    write_head: batch::write_head,
};

/// Socket buffer the hub asks for: about 4,000 small datagrams of burst.
const SOCKET_BUFFER: usize = 4 << 20;

/// The longest [`Server::run`] sleeps before it looks at its stop flag.
const STOP_CHECK: Duration = Duration::from_millis(100);

impl Server {
    /// Binds the hub's socket (use `127.0.0.1:7400` for a hub that only this machine reaches).
    pub fn bind(addr: impl ToSocketAddrs, config: HubConfig) -> io::Result<Server> {
        let socket = UdpSocket::bind(addr)?;
        // On Linux the socket blocks (with a timeout) only where the hub
        // waits for datagrams; every other receive and every send says
        // MSG_DONTWAIT itself.
        socket.set_nonblocking(!cfg!(target_os = "linux"))?;
        let got = enlarge_buffers(&socket, SOCKET_BUFFER);
        if got < SOCKET_BUFFER {
            tracing::warn!(
                bytes = got,
                wanted = SOCKET_BUFFER,
                "small socket buffer: raise net.core.rmem_max, or bursts will be dropped"
            );
        }
        if let Err(e) = udp::count_kernel_drops(&socket) {
            tracing::warn!(error = %e, "the kernel will not count receive drops; status cannot show them");
        }
        let local = socket.local_addr()?;
        let mut hub = Hub::new(config, Instant::now());
        hub.set_local_addr(local);
        Ok(Server {
            socket,
            hub,
            log: None,
            batch: RecvBatch::new(SLOT),
            local,
            plan: SendPlan::new(),
            sender: Sender::new(true).with_framing(BATCH_FRAMING),
            replies: Vec::new(),
            dests: Vec::new(),
            lens: [0; BATCH],
            kernel_drops: 0,
            drained: true,
            #[cfg(target_os = "linux")]
            read_timeout: Duration::ZERO,
        })
    }

    /// Records every accepted packet in this log (a `.clog`
    /// [`LogWriter`](crate::log::LogWriter), or any other [`LogSink`]).
    pub fn with_log(mut self, log: impl LogSink + 'static) -> Server {
        self.log = Some(Box::new(log));
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

    /// Serves until `stop` is set; then finishes the log.
    pub fn run(&mut self, stop: &AtomicBool) -> io::Result<()> {
        while !stop.load(Ordering::Relaxed) {
            self.poll(STOP_CHECK)?;
        }
        self.finish_log()
    }

    /// Completes the traffic log (an MCAP writes its summary) and closes it;
    /// [`run`](Self::run) does this when it stops. A caller with a loop of its
    /// own calls it once it stops polling.
    pub fn finish_log(&mut self) -> io::Result<()> {
        match self.log.take() {
            Some(mut log) => log.finish(),
            None => Ok(()),
        }
    }

    /// Waits at most `max_wait` for datagrams, handles those waiting (at
    /// most a bounded number, so that a flood cannot hold the loop), sends
    /// what they cause, flushes the log and runs the hub's timers. Returns
    /// how many datagrams it handled.
    pub fn poll(&mut self, max_wait: Duration) -> io::Result<usize> {
        let mut handled = 0;
        for k in 0..BATCHES_PER_POLL {
            let n = if k == 0 && self.drained {
                self.recv_waiting(max_wait)?
            } else {
                self.batch.recv(&self.socket)?
            };
            self.count_kernel_drops();
            handled += n;
            if n > 0 {
                self.handle_batch();
            }
            // A short batch emptied the socket: the next round waits.
            self.drained = n < BATCH;
            if self.drained {
                break;
            }
        }
        if let Some(log) = &mut self.log {
            // One flush per round: a crash loses at most the round in hand,
            // and can only tear the record being written.
            if let Err(e) = log.end_round(Instant::now()) {
                tracing::error!(error = %e, "traffic log failed; serving on without it");
                self.log = None;
            }
        }
        self.hub.handle_timeout(Instant::now());
        Ok(handled)
    }

    /// Waits for datagrams at most `max_wait`, and no longer than the hub's
    /// next timer, and takes those waiting.
    fn recv_waiting(&mut self, max_wait: Duration) -> io::Result<usize> {
        let wait = self
            .hub
            .poll_timeout()
            .saturating_duration_since(Instant::now())
            .min(max_wait);
        if wait.is_zero() {
            return self.batch.recv(&self.socket);
        }
        #[cfg(target_os = "linux")]
        {
            // One blocking receive, as a plain UDP relay makes, rather than
            // a readiness wait and then a receive. The socket's timeout is
            // set only when it must shrink or has grown past twice the
            // wait: a timeout shorter than needed costs one early return.
            if wait < self.read_timeout || wait > self.read_timeout * 2 {
                self.socket.set_read_timeout(Some(wait))?;
                self.read_timeout = wait;
            }
            self.batch.recv_waiting(&self.socket)
        }
        #[cfg(not(target_os = "linux"))]
        {
            colony_sys::wait::wait_readable(&self.socket, Some(wait))?;
            self.batch.recv(&self.socket)
        }
    }

    /// Counts the datagrams the kernel dropped at the socket since the last
    /// reading.
    fn count_kernel_drops(&mut self) {
        if let Some(total) = self.batch.kernel_drops() {
            let new = total.wrapping_sub(self.kernel_drops);
            self.kernel_drops = total;
            if new > 0 {
                self.hub
                    .record_drops(DropReason::ReceiveOverflow, u64::from(new));
            }
        }
    }

    /// Hands each datagram of the batch to the hub, then sends everything
    /// the batch caused (forwards and replies) in one go, each destination
    /// getting its datagrams in the order they arrived.
    fn handle_batch(&mut self) {
        let now = Instant::now();
        let wall = SystemTime::now();
        self.plan.clear();
        self.replies.clear();
        let mut bad = 0u64;
        for i in 0..self.batch.len() {
            let Some(src) = self.batch.source(i) else {
                continue;
            };
            let data = self.batch.get(i);
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
            if let Outcome::Forward { len, dests } = outcome {
                // Less any authentication line, which the hub has checked.
                self.lens[i] = len;
                // Copied out of the hub (it reuses its list for the next
                // packet), leaving out any address that is no client.
                self.dests.clear();
                for d in dests {
                    if is_client_addr(*d, self.local) {
                        self.dests.push(*d);
                    } else {
                        bad += 1;
                    }
                }
                let hub = &self.hub;
                self.plan
                    .push_joining(i, &self.dests, |d| hub.batch_bytes(d));
            }
            while let Some(t) = self.hub.poll_transmit() {
                if !is_client_addr(t.dest, self.local) {
                    bad += 1;
                    continue;
                }
                let hub = &self.hub;
                self.plan
                    .push_joining(BATCH + self.replies.len(), &[t.dest], |d| {
                        hub.batch_bytes(d)
                    });
                self.replies.push(t);
            }
        }
        if bad > 0 {
            self.hub.record_drops(DropReason::BadSource, bad);
        }
        let (batch, replies, lens) = (&self.batch, &self.replies, &self.lens);
        let report = self.sender.send(&self.socket, &self.plan, |i| {
            if i < BATCH {
                &batch.get(i)[..lens[i]]
            } else {
                replies.get(i - BATCH).map_or(&[][..], |t| &t.payload[..])
            }
        });
        if report.full > 0 {
            self.hub
                .record_drops(DropReason::SendFull, report.full as u64);
        }
        if report.failed > 0 {
            self.hub
                .record_drops(DropReason::SendFailed, report.failed as u64);
        }
    }
}

/// Whether the hub may send to `dest`: never to its own socket (that would
/// feed its own output back to it, for ever), nor to an address that can be
/// no client. The hub's table should hold no such address; this is the last
/// line of defence.
fn is_client_addr(dest: SocketAddr, local: SocketAddr) -> bool {
    !is_bad_source(&dest, Some(&local))
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Subscribes `client` to `channel` through `server`, polling it by
    /// hand; answers a cookie challenge if the hub makes one.
    fn subscribe(server: &mut Server, client: &UdpSocket, channel: &str) {
        let hub = server.local_addr().unwrap();
        client
            .set_read_timeout(Some(Duration::from_millis(20)))
            .unwrap();
        let mut cookie = colony_wire::Cookie::NONE.to_string();
        for _ in 0..100 {
            let req = format!("@ <hub> 0\ncookie v {cookie}\nsubscribe ch {channel}\n");
            client.send_to(req.as_bytes(), hub).unwrap();
            server.poll(Duration::from_millis(10)).unwrap();
            let mut buf = [0; 2048];
            let Ok(n) = client.recv(&mut buf) else {
                continue;
            };
            let reply = String::from_utf8_lossy(&buf[..n]).into_owned();
            if reply.contains("lease") {
                return;
            }
            if let Some(c) = reply.split("cookie v ").nth(1) {
                c.trim().clone_into(&mut cookie);
            }
        }
        panic!("no lease for {channel}");
    }

    #[test]
    fn a_subscription_in_the_hubs_own_name_causes_no_storm() {
        let mut server = Server::bind("127.0.0.1:0", HubConfig::default()).unwrap();
        let hub = server.local_addr().unwrap();
        let sub = UdpSocket::bind("127.0.0.1:0").unwrap();
        subscribe(&mut server, &sub, "storm");
        // A forged subscription with the hub's own address as its source
        // (on a network, one spoofed datagram), put straight into the hub
        // whatever the hub's own checks make of it.
        let _ = server
            .hub
            .handle(Instant::now(), hub, b"@ <hub> 0\nsubscribe ch storm\n");
        let publisher = UdpSocket::bind("127.0.0.1:0").unwrap();
        publisher.send_to(b"@ <storm> 0\nx a 1\n", hub).unwrap();
        let mut handled = 0;
        let deadline = Instant::now() + Duration::from_millis(300);
        while Instant::now() < deadline {
            handled += server.poll(Duration::from_millis(10)).unwrap();
        }
        // The one published packet, and nothing the hub sent itself.
        assert_eq!(handled, 1);
        assert!(server.hub().drops(DropReason::BadSource) >= 1);
        let mut buf = [0; 64];
        let n = sub.recv(&mut buf).unwrap();
        assert_eq!(&buf[..n], b"@ <storm> 0\nx a 1\n");
        sub.set_nonblocking(true).unwrap();
        assert!(sub.recv(&mut buf).is_err(), "a second copy arrived");
    }

    #[test]
    fn the_hub_sends_to_no_address_that_can_be_no_client() {
        let local: SocketAddr = "127.0.0.1:7400".parse().unwrap();
        let any: SocketAddr = "0.0.0.0:7400".parse().unwrap();
        let ok = |d: &str, l| is_client_addr(d.parse().unwrap(), l);
        assert!(ok("127.0.0.1:5000", local));
        assert!(ok("[::1]:5000", local));
        assert!(!ok("127.0.0.1:7400", local));
        assert!(!ok("127.0.0.1:0", local));
        assert!(!ok("0.0.0.0:5000", local));
        assert!(!ok("255.255.255.255:5000", local));
        assert!(!ok("224.0.0.1:5000", local));
        assert!(!ok("[::]:5000", local));
        assert!(!ok("[ff02::1]:5000", local));
        assert!(!ok("127.0.0.1:7400", any));
        assert!(ok("127.0.0.1:7401", any));
    }
}
