//! The non-blocking UDP client around a [`Session`].

use std::collections::VecDeque;
use std::io;
use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, SocketAddr, ToSocketAddrs, UdpSocket};
use std::os::fd::{AsFd, AsRawFd, BorrowedFd, RawFd};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use colony_wire::{
    Packet, ParseError, Reply, Request, Subject, SubjectError, HUB_SUBJECT, MAX_PACKET,
};

use colony_sys::udp;
use colony_wire::batch;

use crate::session::{ClientConfig, HubState, Incoming, Session};

/// Datagrams and errors (and malformed packets of a batch) one receive call takes in before
/// it returns as if nothing were waiting: a flood of junk, replies or forged ICMP errors from the hub's
/// address, or one forged batch of thousands of junk packets, must not hold the application
/// here, away from its lease refreshes. The socket stays readable, and `wait` returns at once
/// while packets of a batch are still in hand.
const RECV_BUDGET: u32 = 256;

/// Something the client was asked to do that cannot be done.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// The name is not a subject.
    #[error(transparent)]
    Subject(#[from] SubjectError),
    /// The subject is the hub's own, which carries control requests only.
    #[error("`{0}` is reserved for requests to the hub itself")]
    Reserved(String),
    /// The packet does not parse; the source says where and why.
    #[error("refusing to publish a malformed packet")]
    Malformed(#[from] ParseError),
    /// The hub's address does not resolve, or cannot be reached from here.
    #[error("hub address `{addr}`")]
    Address {
        /// The address as given.
        addr: String,
        /// Why it cannot be used.
        source: io::Error,
    },
    /// The packet, signed, is longer than one datagram can carry.
    #[error("the packet signed is {len} bytes, more than a datagram's {max}")]
    TooLarge {
        /// Its length with the signature.
        len: usize,
        /// The most a datagram carries.
        max: usize,
    },
    /// The socket failed.
    #[error(transparent)]
    Io(#[from] io::Error),
}

/// No client could be made for the hub at an address: the address does not
/// resolve, or cannot be reached from here.
#[derive(Debug, thiserror::Error)]
#[error("cannot reach a hub at `{hub}`")]
pub struct ConnectError {
    /// The address as given.
    pub hub: String,
    /// Why.
    #[source]
    pub source: ClientError,
}

/// A hub client on a non-blocking UDP socket. It never blocks, never starts
/// a thread and never owns the loop: wait on its descriptor (it implements
/// [`AsFd`]) until [`next_deadline`](Self::next_deadline), then call
/// [`poll`](Self::poll) and [`recv`](Self::recv).
pub struct UdpClient {
    socket: UdpSocket,
    hub: SocketAddr,
    session: Session,
    buf: Box<[u8]>,
    /// The packets of the datagram in `buf` not yet handed out: more than
    /// one when the hub joined several ([`Request::Batch`]).
    pending: VecDeque<std::ops::Range<usize>>,
    /// The datagram in `buf` held several packets.
    in_batch: bool,
    malformed: u64,
    /// Datagrams lost to errors the network reported (see `udp::is_transient`).
    network_errors: AtomicU64,
}

impl UdpClient {
    /// A client of the hub at `hub` with the default timings.
    pub fn connect(hub: impl ToSocketAddrs + std::fmt::Debug) -> Result<UdpClient, ClientError> {
        UdpClient::with_config(hub, ClientConfig::default())
    }

    /// Like [`connect`](Self::connect), for an address given as text by a
    /// person, whose error names the address first.
    pub fn connect_to(hub: &str) -> Result<UdpClient, ConnectError> {
        UdpClient::connect(hub).map_err(|source| ConnectError {
            hub: hub.to_string(),
            source,
        })
    }

    /// A client of the hub at `hub` with these timings.
    pub fn with_config(
        hub: impl ToSocketAddrs + std::fmt::Debug,
        config: ClientConfig,
    ) -> Result<UdpClient, ClientError> {
        let describe = format!("{hub:?}").trim_matches('"').to_owned();
        let hub = hub
            .to_socket_addrs()
            .and_then(|mut a| {
                a.next()
                    .ok_or_else(|| io::Error::new(io::ErrorKind::NotFound, "no address found"))
            })
            .map_err(|source| ClientError::Address {
                addr: describe.clone(),
                source,
            })?;
        // Stay on loopback when the hub is local, so nothing else can reach us.
        let local: IpAddr = match (hub.ip().is_loopback(), hub) {
            (true, SocketAddr::V4(_)) => Ipv4Addr::LOCALHOST.into(),
            (true, SocketAddr::V6(_)) => Ipv6Addr::LOCALHOST.into(),
            (false, SocketAddr::V4(_)) => Ipv4Addr::UNSPECIFIED.into(),
            (false, SocketAddr::V6(_)) => Ipv6Addr::UNSPECIFIED.into(),
        };
        let socket = UdpSocket::bind((local, 0))?;
        // Connected: the kernel passes us datagrams from the hub only.
        socket.connect(hub).map_err(|source| ClientError::Address {
            addr: describe,
            source,
        })?;
        socket.set_nonblocking(true)?;
        Ok(UdpClient {
            socket,
            hub,
            session: Session::new(config, Instant::now()),
            buf: vec![0u8; MAX_PACKET + 1].into_boxed_slice(),
            pending: VecDeque::new(),
            in_batch: false,
            malformed: 0,
            network_errors: AtomicU64::new(0),
        })
    }

    /// The hub's address, resolved.
    pub fn hub_addr(&self) -> SocketAddr {
        self.hub
    }

    /// This client's own address.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.socket.local_addr()
    }

    /// The protocol state inside.
    pub fn session(&self) -> &Session {
        &self.session
    }

    /// Subscribes to a channel (or one subject of a subject set) and asks the hub now.
    pub fn subscribe(&mut self, subject: &str) -> Result<(), ClientError> {
        let subject = Subject::new(subject)?;
        if subject.as_str() == HUB_SUBJECT {
            return Err(ClientError::Reserved(subject.to_string()));
        }
        let now = Instant::now();
        self.session.subscribe(now, subject);
        self.poll(now)?;
        Ok(())
    }

    /// Drops a subscription and tells the hub now.
    pub fn unsubscribe(&mut self, subject: &str) -> Result<(), ClientError> {
        self.session.unsubscribe(&Subject::new(subject)?);
        self.flush()?;
        Ok(())
    }

    /// Drops every subscription and tells the hub now.
    pub fn unsubscribe_all(&mut self) -> io::Result<()> {
        self.session.unsubscribe_all();
        self.flush()
    }

    /// Sends control requests (status, minimum priority) to the hub.
    pub fn request(&mut self, requests: &[Request]) -> io::Result<()> {
        self.session.request(requests);
        self.flush()
    }

    /// Publishes a packet, checked first so that a bad one fails here with
    /// its position rather than being dropped silently by the hub.
    pub fn publish(&mut self, packet: &[u8]) -> Result<(), ClientError> {
        Packet::parse(packet)?;
        if self.session.signs() {
            let mut signed = packet.to_vec();
            self.session.sign(&mut signed);
            // Said here: the kernel's EMSGSIZE would be taken for a datagram the network lost.
            if signed.len() > MAX_PACKET {
                return Err(ClientError::TooLarge {
                    len: signed.len(),
                    max: MAX_PACKET,
                });
            }
            self.send(&signed)?;
        } else {
            self.send(packet)?;
        }
        Ok(())
    }

    /// Signs everything this client sends with `key` (see [`Session::set_key`]).
    pub fn set_key(&mut self, key: colony_wire::auth::Key) {
        self.session.set_key(key);
    }

    fn send(&self, datagram: &[u8]) -> io::Result<()> {
        match self.socket.send(datagram) {
            Ok(_) => Ok(()),
            // Datagrams are fire and forget: a hub that is down (refused), a
            // network briefly unreachable or a full buffer loses this one
            // packet, counted, and the session recovers.
            Err(e) if udp::is_transient(&e) => {
                self.count_network_error();
                Ok(())
            }
            Err(e) => Err(e),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        while let Some(d) = self.session.poll_transmit() {
            self.send(&d)?;
        }
        Ok(())
    }

    /// Does whatever is due by `now`: refreshes and resubscriptions.
    pub fn poll(&mut self, now: Instant) -> io::Result<()> {
        self.session.handle_timeout(now);
        self.flush()
    }

    /// When [`poll`](Self::poll) or [`recv`](Self::recv) next has work to
    /// do: now, while packets of a datagram already received wait, since the
    /// socket will not say so.
    pub fn next_deadline(&self) -> Option<Instant> {
        if !self.pending.is_empty() {
            return Some(Instant::now());
        }
        self.session.poll_timeout()
    }

    /// Whether the hub has been heard from lately.
    pub fn hub_state(&self) -> HubState {
        self.session.hub_state(Instant::now())
    }

    /// Datagrams received that did not parse and were skipped (the hub checks
    /// what it repeats, so this stays zero unless something else speaks from
    /// the hub's address).
    pub fn malformed_count(&self) -> u64 {
        self.malformed
    }

    /// Send and receive calls that failed for one datagram and were gone past: the hub
    /// down (refused), its host or network unreachable, a full buffer, and the like
    /// ([`colony_sys::udp::is_transient`]). Each is a datagram lost; a count that keeps
    /// growing says the network, not the program, is at fault.
    pub fn network_error_count(&self) -> u64 {
        self.network_errors.load(Ordering::Relaxed)
    }

    fn count_network_error(&self) {
        self.network_errors.fetch_add(1, Ordering::Relaxed);
    }

    /// The next packet published on a subscribed channel, or `None` when none
    /// is waiting. Replies from the hub are taken in along the way, and a
    /// datagram that does not parse is counted ([`malformed_count`](Self::malformed_count))
    /// and skipped: one bad datagram must not end a subscriber's loop. A
    /// datagram of several packets (which the hub sends a client that asked
    /// for them with [`Request::Batch`] among its standing requests) is
    /// handed out one packet per call, so call this until it returns `None`
    /// before waiting on the socket again ([`next_deadline`](Self::next_deadline)
    /// and [`wait`](Self::wait) say when packets are still in hand). A hub
    /// older than `batch` refuses the whole request packet that asks for it,
    /// standing requests and subscriptions with it.
    pub fn recv(&mut self) -> io::Result<Option<Packet<'_>>> {
        match self.next_datagram(false)? {
            Some(Ok(len)) => self.packet_at(len).map(Some),
            Some(Err(_)) | None => Ok(None),
        }
    }

    /// The next packet or reply, whichever comes first, for a program that
    /// wants both (a bridge reads status reports between data). Datagrams
    /// that do not parse are counted and skipped, as in [`recv`](Self::recv).
    pub fn recv_any(&mut self) -> io::Result<Option<Delivery<'_>>> {
        match self.next_datagram(true)? {
            Some(Ok(len)) => self.packet_at(len).map(|p| Some(Delivery::Packet(p))),
            Some(Err(reply)) => Ok(Some(Delivery::Reply(reply))),
            None => Ok(None),
        }
    }

    /// Where the next valid packet lies in `buf`, or (if `replies`) the
    /// next reply. The borrow checker will not let a packet borrowed from
    /// `buf` leave a loop that receives into `buf` again, so a valid packet
    /// is checked here and parsed once more by [`packet_at`](Self::packet_at)
    /// (about 0.8 us for a 478-byte vision packet).
    fn next_datagram(
        &mut self,
        replies: bool,
    ) -> io::Result<Option<Result<std::ops::Range<usize>, Reply>>> {
        let mut budget = RECV_BUDGET;
        loop {
            match self.recv_one(&mut budget)? {
                None => return Ok(None),
                Some(Received::Reply(r)) if replies => return Ok(Some(Err(r))),
                Some(Received::Reply(_)) => continue,
                Some(Received::Data(at)) if Packet::parse(&self.buf[at.clone()]).is_ok() => {
                    return Ok(Some(Ok(at)))
                }
                Some(Received::Data(_)) => {
                    if !self.count_malformed(&mut budget) {
                        return Ok(None);
                    }
                }
            }
        }
    }

    /// Counts a packet that did not parse; one of a batch is charged to the
    /// call's budget too (a datagram of one packet was charged as it came
    /// in). False when the budget is spent.
    fn count_malformed(&mut self, budget: &mut u32) -> bool {
        self.malformed += 1;
        if !self.in_batch {
            return true;
        }
        *budget = budget.saturating_sub(1);
        *budget > 0
    }

    fn packet_at(&mut self, at: std::ops::Range<usize>) -> io::Result<Packet<'_>> {
        let packet = Packet::parse(&self.buf[at])
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e))?;
        self.session.note_data(Instant::now(), &packet);
        Ok(packet)
    }

    /// Requests that describe this client, sent with every refresh (see
    /// [`Session::set_standing`]); a change goes out at once.
    pub fn set_standing(&mut self, requests: Vec<Request>) -> io::Result<()> {
        self.session.set_standing(requests);
        self.flush()
    }

    /// Like [`recv`](Self::recv), but also returns the hub's replies (status reports, leases).
    pub fn recv_reply(&mut self) -> io::Result<Option<Reply>> {
        let mut budget = RECV_BUDGET;
        loop {
            match self.recv_one(&mut budget)? {
                None => return Ok(None),
                Some(Received::Reply(r)) => return Ok(Some(r)),
                Some(Received::Data(_)) => continue,
            }
        }
    }

    /// The next packet, from the datagram in hand or else from the socket,
    /// spending `budget` (one per datagram or error taken in); `None` when
    /// nothing is waiting or the budget is spent.
    fn recv_one(&mut self, budget: &mut u32) -> io::Result<Option<Received>> {
        loop {
            let Some(at) = self.pending.pop_front() else {
                if !self.recv_datagram(budget)? {
                    return Ok(None);
                }
                continue;
            };
            let now = Instant::now();
            let data = &self.buf[at.clone()];
            // Only the hub's own replies need reading here; data is parsed once, by the caller.
            if !data.starts_with(b"@ <hub> ") {
                return Ok(Some(Received::Data(at)));
            }
            match self.session.handle_datagram(now, data) {
                Ok(Incoming::Reply(r)) => {
                    // A cookie makes the session ask again: send that now.
                    self.flush()?;
                    return Ok(Some(Received::Reply(r)));
                }
                Ok(Incoming::Packet(_)) => continue,
                Err(_) => {
                    if !self.count_malformed(budget) {
                        return Ok(None);
                    }
                }
            }
        }
    }

    /// Takes the next datagram into `buf` and its packets into `pending`;
    /// false when nothing is waiting or the budget is spent.
    fn recv_datagram(&mut self, budget: &mut u32) -> io::Result<bool> {
        loop {
            if *budget == 0 {
                return Ok(false);
            }
            *budget -= 1;
            let len = match self.socket.recv(&mut self.buf) {
                Ok(len) => len,
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => return Ok(false),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                // An error that came back for an earlier datagram (it comes out before
                // queued data): the hub's port was closed (it is down) or its network
                // unreachable. The session resubscribes once the hub answers again.
                Err(e) if udp::is_transient(&e) => {
                    self.count_network_error();
                    continue;
                }
                Err(e) => return Err(e),
            };
            match batch::split(&self.buf[..len]) {
                Ok(pieces) => {
                    self.pending.extend(pieces);
                    self.in_batch = self.pending.len() > 1;
                    return Ok(true);
                }
                // The datagram was charged to the budget already.
                Err(_) => self.malformed += 1,
            }
        }
    }

    /// Blocks until a datagram is waiting or `deadline` passes (`None`: no
    /// limit); returns at once while packets of a datagram already received
    /// wait. A convenience for programs without a loop of their own; the
    /// library itself never calls it.
    pub fn wait(&self, deadline: Option<Instant>) -> io::Result<bool> {
        if !self.pending.is_empty() {
            return Ok(true);
        }
        let timeout = deadline.map(|d| d.saturating_duration_since(Instant::now()));
        colony_sys::wait::wait_readable(&self.socket, timeout)
    }
}

/// A datagram from the hub: a packet on a subscribed channel, or the hub's own reply.
#[derive(Debug)]
pub enum Delivery<'a> {
    /// Published by a client.
    Packet(Packet<'a>),
    /// The hub's answer (a status report, a lease, a cookie).
    Reply(Reply),
}

enum Received {
    Data(std::ops::Range<usize>),
    Reply(Reply),
}

impl AsFd for UdpClient {
    fn as_fd(&self) -> BorrowedFd<'_> {
        self.socket.as_fd()
    }
}

impl AsRawFd for UdpClient {
    fn as_raw_fd(&self) -> RawFd {
        self.socket.as_raw_fd()
    }
}
