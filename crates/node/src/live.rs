//! Nodes over the real hub: a [`Link`] joins one [`Node`] to one
//! [`UdpClient`]; [`run`] drives one link on a thread of the caller's, and a
//! [`Mux`] serves many links from one mio loop. The caller owns the loop (and
//! the thread); nothing here starts one.

use std::borrow::BorrowMut;
use std::collections::BTreeSet;
use std::net::ToSocketAddrs;
use std::ops::ControlFlow;
use std::os::fd::AsRawFd;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use colony_client::{ClientError, UdpClient};
use colony_wire::Subject;

use crate::node::Node;
use crate::time::Time;

/// What can stop a live node.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    /// The hub client refused something.
    #[error(transparent)]
    Client(#[from] ClientError),
    /// The socket failed.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// The longest a [`run`] loop waits before it looks at its stop flag again.
const TICK: Duration = Duration::from_millis(50);

/// One node's connection to the hub: its client, the subscriptions the hub
/// holds for it, and the epoch its [`Time`] counts from.
///
/// A link owns its client (`Link<UdpClient>`, the default) or borrows one its
/// caller keeps (`Link<&mut UdpClient>`), so a caller can lend its client to a
/// node for a while and go on with it afterwards.
///
/// ```no_run
/// use std::time::Instant;
/// use colony_client::UdpClient;
/// use colony_node::{Link, Node};
/// fn serve(node: &mut dyn Node) -> Result<(), Box<dyn std::error::Error>> {
///     let mut link = Link::connect("127.0.0.1:7400", Instant::now())?;
///     loop {
///         link.wait(node, None)?;
///         link.pump(node)?;
///     }
/// }
/// # let _ = serve;
/// ```
pub struct Link<C = UdpClient> {
    client: C,
    applied: BTreeSet<Subject>,
    epoch: Instant,
    /// When the wait for the first cookie ends (set when the node first subscribes).
    first_contact: Option<Instant>,
}

/// How long, at most, a node's packets wait for the hub's first cookie (see [`Link::flush`]).
pub const FIRST_CONTACT: Duration = Duration::from_millis(500);

impl Link {
    /// A link over a new client of the hub at `hub`, its clock counting from `epoch`.
    pub fn connect(
        hub: impl ToSocketAddrs + std::fmt::Debug,
        epoch: Instant,
    ) -> Result<Link, LiveError> {
        Ok(Link::new(UdpClient::connect(hub)?, epoch))
    }
}

impl<C: BorrowMut<UdpClient>> Link<C> {
    /// A link over `client`, its clock counting from `epoch`.
    pub fn new(client: C, epoch: Instant) -> Link<C> {
        Link {
            client,
            applied: BTreeSet::new(),
            epoch,
            first_contact: None,
        }
    }

    /// The client underneath.
    pub fn client(&self) -> &UdpClient {
        self.client.borrow()
    }

    /// The client underneath, to publish or subscribe outside the protocol.
    pub fn client_mut(&mut self) -> &mut UdpClient {
        self.client.borrow_mut()
    }

    /// Now, on this link's clock.
    pub fn now(&self) -> Time {
        self.time_of(Instant::now())
    }

    /// An instant on this link's clock.
    pub fn time_of(&self, t: Instant) -> Time {
        Time::from_micros(t.saturating_duration_since(self.epoch).as_micros() as u64)
    }

    /// The instant a [`Time`] on this link's clock stands for.
    pub fn instant_of(&self, t: Time) -> Instant {
        self.epoch + Duration::from_micros(t.as_micros())
    }

    /// Makes the hub's subscriptions for this client equal to the node's.
    fn sync(&mut self, node: &dyn Node) -> Result<(), LiveError> {
        let want = node.subscriptions();
        if want == &self.applied {
            return Ok(());
        }
        if want.is_empty() {
            self.client_mut().unsubscribe_all()?;
            self.applied.clear();
            return Ok(());
        }
        let gone: Vec<Subject> = self.applied.difference(want).cloned().collect();
        for s in gone {
            self.client_mut().unsubscribe(s.as_str())?;
            self.applied.remove(&s);
        }
        let new: Vec<Subject> = want.difference(&self.applied).cloned().collect();
        for s in new {
            self.client_mut().subscribe(s.as_str())?;
            self.applied.insert(s);
        }
        Ok(())
    }

    /// Sends what the node wants sent, its subscriptions first (so a bidder is
    /// subscribed to a negotiation before its bid can be answered).
    ///
    /// Before the hub knows this address (no cookie yet), a subscription takes
    /// a round trip, and what the node publishes meanwhile could be answered
    /// before the subscription is in place (an announcement's bids, lost
    /// because the announcer is not subscribed yet): so it waits for the
    /// cookie, for at most [`FIRST_CONTACT`].
    pub fn flush(&mut self, node: &mut dyn Node) -> Result<(), LiveError> {
        self.sync(node)?;
        if self.holding(Instant::now()).is_some() {
            return Ok(());
        }
        while let Some(p) = node.poll_transmit() {
            self.client_mut().publish(&p)?;
        }
        Ok(())
    }

    /// Until when the node's packets wait for the first cookie, if they do now.
    fn holding(&mut self, now: Instant) -> Option<Instant> {
        let session = self.client().session();
        if session.cookie().is_some() || session.subscriptions().next().is_none() {
            return None;
        }
        let until = *self.first_contact.get_or_insert(now + FIRST_CONTACT);
        (now < until).then_some(until)
    }

    /// Does everything due now: hands the node every waiting packet, runs its
    /// timers and the client's, and sends what results. Never blocks.
    pub fn pump(&mut self, node: &mut dyn Node) -> Result<(), LiveError> {
        self.flush(node)?;
        let now = Instant::now();
        self.client_mut().poll(now)?;
        let epoch = self.epoch;
        while let Some(packet) = self.client.borrow_mut().recv()? {
            let t = Time::from_micros(epoch.elapsed().as_micros() as u64);
            node.handle_packet(t, &packet);
        }
        let t = self.now();
        if node.poll_timeout().is_some_and(|d| d <= t) {
            node.handle_timeout(t);
        }
        self.flush(node)
    }

    /// When the link next has work: the node's timer or the client's, or the
    /// end of a wait for the first cookie.
    pub fn next_deadline(&self, node: &dyn Node) -> Option<Instant> {
        let node_due = node.poll_timeout().map(|t| self.instant_of(t));
        // Only a wait still running: one that ran out must not wake the link for ever.
        let held = self
            .first_contact
            .filter(|t| *t > Instant::now() && self.client().session().cookie().is_none());
        [node_due, self.client().next_deadline(), held]
            .into_iter()
            .flatten()
            .min()
    }

    /// Blocks until a datagram arrives, the next deadline, or `at_most` passes.
    pub fn wait(&self, node: &dyn Node, at_most: Option<Duration>) -> Result<(), LiveError> {
        let cap = at_most.map(|d| Instant::now() + d);
        let until = match (self.next_deadline(node), cap) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        self.client().wait(until)?;
        Ok(())
    }
}

/// Runs `node` over `link` until `stop` is set or `each` breaks: one node on
/// one thread. `each` is called after every round, to read the node's events,
/// feed it from its owner, or end the run when the owner is done with it.
pub fn run<N: Node, C: BorrowMut<UdpClient>>(
    node: &mut N,
    link: &mut Link<C>,
    stop: &AtomicBool,
    mut each: impl FnMut(&mut N, Time) -> ControlFlow<()>,
) -> Result<(), LiveError> {
    while !stop.load(Ordering::Relaxed) {
        link.pump(node)?;
        let flow = each(node, link.now());
        link.flush(node)?;
        if flow.is_break() {
            break;
        }
        link.wait(node, Some(TICK))?;
    }
    Ok(())
}

/// Many nodes, each with its own hub client, served by one thread: a mio poll
/// over every client's socket. For a demo or a benchmark with hundreds of
/// robots on one machine.
pub struct Mux<N> {
    poll: mio::Poll,
    events: mio::Events,
    members: Vec<Option<(Link, N)>>,
    ready: Vec<bool>,
}

impl<N: Node> Mux<N> {
    /// No members yet.
    pub fn new() -> Result<Mux<N>, LiveError> {
        Ok(Mux {
            poll: mio::Poll::new()?,
            events: mio::Events::with_capacity(1024),
            members: Vec::new(),
            ready: Vec::new(),
        })
    }

    /// Adds a node on its link; returns its index.
    pub fn add(&mut self, link: Link, node: N) -> Result<usize, LiveError> {
        let i = self.members.len();
        let fd = link.client().as_raw_fd();
        self.poll.registry().register(
            &mut mio::unix::SourceFd(&fd),
            mio::Token(i),
            mio::Interest::READABLE,
        )?;
        self.members.push(Some((link, node)));
        // Pumped once at once, so it subscribes.
        self.ready.push(true);
        Ok(i)
    }

    /// Takes a member out (its socket closes as the link drops): a robot killed.
    pub fn remove(&mut self, i: usize) -> Option<(Link, N)> {
        let (link, node) = self.members.get_mut(i)?.take()?;
        let fd = link.client().as_raw_fd();
        let _ = self
            .poll
            .registry()
            .deregister(&mut mio::unix::SourceFd(&fd));
        Some((link, node))
    }

    /// A member's node, if it is still in.
    pub fn node(&self, i: usize) -> Option<&N> {
        self.members.get(i)?.as_ref().map(|(_, n)| n)
    }

    /// A member's node and link, to feed it or read its events.
    pub fn member_mut(&mut self, i: usize) -> Option<(&mut Link, &mut N)> {
        self.members.get_mut(i)?.as_mut().map(|(l, n)| (l, n))
    }

    /// Every member still in, with its index.
    pub fn iter_mut(&mut self) -> impl Iterator<Item = (usize, &mut Link, &mut N)> {
        self.members
            .iter_mut()
            .enumerate()
            .filter_map(|(i, m)| m.as_mut().map(|(l, n)| (i, l, n)))
    }

    /// Pumps every member with a datagram waiting or a deadline passed.
    pub fn pump(&mut self) -> Result<(), LiveError> {
        let now = Instant::now();
        for (i, m) in self.members.iter_mut().enumerate() {
            let Some((link, node)) = m else { continue };
            let due = link.next_deadline(node).is_some_and(|d| d <= now);
            if due || self.ready[i] {
                self.ready[i] = false;
                link.pump(node)?;
            }
        }
        Ok(())
    }

    /// Pumps every member, whether or not it has work (after its owner fed it).
    pub fn pump_all(&mut self) -> Result<(), LiveError> {
        for (link, node) in self.members.iter_mut().flatten() {
            link.pump(node)?;
        }
        Ok(())
    }

    /// Sends what every member wants sent, its subscriptions first; reads
    /// nothing, so it costs no system call for a member with nothing to send.
    pub fn flush_all(&mut self) -> Result<(), LiveError> {
        for (link, node) in self.members.iter_mut().flatten() {
            link.flush(node)?;
        }
        Ok(())
    }

    /// Waits until a member has a datagram or a deadline, or `at_most` passes.
    pub fn wait(&mut self, at_most: Duration) -> Result<(), LiveError> {
        let now = Instant::now();
        let next = self
            .members
            .iter()
            .flatten()
            .filter_map(|(l, n)| l.next_deadline(n))
            .min();
        let timeout = next.map_or(at_most, |d| d.saturating_duration_since(now).min(at_most));
        match self.poll.poll(&mut self.events, Some(timeout)) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e.into()),
        }
        for e in self.events.iter() {
            if let Some(r) = self.ready.get_mut(e.token().0) {
                *r = true;
            }
        }
        Ok(())
    }

    /// Serves every member until `stop` is set, calling `each` after every
    /// round (to read the members' events or feed them), then flushing every
    /// member so what `each` caused goes out at once.
    pub fn run(
        &mut self,
        stop: &AtomicBool,
        mut each: impl FnMut(&mut Mux<N>),
    ) -> Result<(), LiveError> {
        while !stop.load(Ordering::Relaxed) {
            self.pump()?;
            each(self);
            self.flush_all()?;
            self.wait(TICK)?;
        }
        Ok(())
    }
}
