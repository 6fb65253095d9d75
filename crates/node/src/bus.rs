//! An in-memory hub on simulated time, for tests and batch experiments, that
//! routes through the real sans-IO [`Hub`].

use std::cmp::Reverse;
use std::collections::{BTreeMap, BinaryHeap};
use std::net::SocketAddr;
use std::time::{Duration, Instant};

use colony_client::ClientConfig;
use colony_hub::{DropReason, Hub, HubConfig};
use colony_wire::{Packet, Priority, Request};

use crate::node::Node;
use crate::ports::{address_of, Ports, Routed, CONSOLE};
use crate::time::Time;

/// What the bus carried of the nodes' own packets (and of
/// [`Bus::publish`]'s). Control traffic (subscriptions, leases) is not
/// counted here; the hub's own counters are in [`Bus::hub`].
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct BusStats {
    /// Packets published.
    pub sent: u64,
    /// Copies handed to nodes.
    pub delivered: u64,
    /// Packets the hub forwarded to no node (nobody was subscribed, or only
    /// nodes whose link is cut).
    pub unrouted: u64,
    /// Published packets that did not parse, dropped as the hub drops them.
    pub malformed: u64,
    /// Packets published, by the label of their first line (`task`, `bid`, ...).
    pub by_label: BTreeMap<String, u64>,
    /// Packets published by a node whose link was cut
    /// ([`Bus::set_reachable`]): they never reached the hub.
    pub lost: u64,
}

/// One packet on its way to the hub.
type InFlight = Reverse<(Time, u64, SocketAddr, Vec<u8>)>;

/// Routes packets between [`Node`]s through the real [`Hub`] on simulated
/// time, with a fixed latency, and drives every node's timers.
///
/// Each node is a client of the hub at a synthetic address of its own, with a
/// real client [`Session`](colony_client::Session) that keeps the hub's
/// subscriptions equal to [`Node::subscriptions`]: the hub's subject-set
/// routing, leases, limits, minimum priority and drop counters are the live
/// system's. That control traffic crosses at once and no node sees it; a
/// published packet reaches the hub `latency` after it was sent and is
/// forwarded to its subscribers from there at once, so it reaches a node if
/// the node is subscribed when it arrives.
///
/// [`Bus::new`] gives the hub its default limits (10 s leases) and the
/// sessions [`quiet_client`](Bus::quiet_client) timings; the sessions'
/// refreshes are served on the hub's lease-sweep ticks. Its one fault is a
/// cut link ([`set_reachable`](Bus::set_reachable)); a console's minimum
/// priority is [`set_min_priority`](Bus::set_min_priority).
///
/// Nodes are passed to each call, so a caller can kill one (leave it out) or
/// start one between calls. A node is known to the hub by its place in the
/// slice: leaving one out moves the later ones up, and the places no node
/// fills any more are unsubscribed at once. Delivery order is deterministic:
/// by time, then by the order packets were sent, then by the node's place in
/// the slice.
///
/// ```
/// use std::collections::BTreeSet;
/// use std::time::Duration;
/// use colony_node::{Bus, Node, Time};
/// use colony_wire::{Packet, Subject};
///
/// /// Counts the packets on `greetings`.
/// struct Ear(BTreeSet<Subject>, u32);
/// impl Node for Ear {
///     fn subscriptions(&self) -> &BTreeSet<Subject> { &self.0 }
///     fn handle_packet(&mut self, _: Time, _: &Packet<'_>) { self.1 += 1 }
///     fn handle_timeout(&mut self, _: Time) {}
///     fn poll_timeout(&self) -> Option<Time> { None }
///     fn poll_transmit(&mut self) -> Option<Vec<u8>> { None }
/// }
///
/// let mut ear = Ear([Subject::new("greetings").unwrap()].into(), 0);
/// let mut bus = Bus::new(Duration::from_millis(1));
/// bus.run_until(&mut [&mut ear], Time::ZERO); // it subscribes
/// bus.publish(b"@ <greetings> 0\nhello\n".to_vec());
/// bus.run_until(&mut [&mut ear], Time::from_secs_f64(1.0));
/// assert_eq!(ear.1, 1);
/// assert_eq!(bus.stats().delivered, 1);
/// ```
#[derive(Debug)]
pub struct Bus {
    latency: Duration,
    now: Time,
    seq: u64,
    queue: BinaryHeap<InFlight>,
    stats: BusStats,
    record: Option<Vec<(Time, Vec<u8>)>>,
    ports: Ports,
    /// Reused for every packet's destinations.
    places: Vec<usize>,
}

impl Bus {
    /// A bus that delivers each packet `latency` after it was sent, through a
    /// hub with the default limits, and [`quiet_client`](Bus::quiet_client)
    /// sessions.
    pub fn new(latency: Duration) -> Bus {
        Bus::with_config(latency, HubConfig::default(), Bus::quiet_client())
    }

    /// The client timings [`Bus::new`] gives every node: the defaults, but a
    /// silent channel is subscribed again only at the refresh pace. The fast
    /// resubscription is for a hub that restarted, which the bus's never
    /// does; without it a long batch run carries a third of the control
    /// traffic, and a lapsed lease is still taken again within a refresh.
    pub fn quiet_client() -> ClientConfig {
        let live = ClientConfig::default();
        ClientConfig {
            resubscribe_after: live.refresh,
            ..live
        }
    }

    /// A bus whose hub has these limits (a short lease, a few clients) and
    /// whose nodes' sessions these timings.
    pub fn with_config(latency: Duration, hub: HubConfig, client: ClientConfig) -> Bus {
        Bus {
            latency,
            now: Time::ZERO,
            seq: 0,
            queue: BinaryHeap::new(),
            stats: BusStats::default(),
            record: None,
            ports: Ports::new(hub, client),
            places: Vec::new(),
        }
    }

    /// Keeps a copy of every packet published from now on, with its time.
    pub fn record(&mut self) {
        self.record.get_or_insert_with(Vec::new);
    }

    /// The packets recorded since [`record`](Bus::record) (or the last take).
    pub fn take_recorded(&mut self) -> Vec<(Time, Vec<u8>)> {
        self.record.as_mut().map(std::mem::take).unwrap_or_default()
    }

    /// The bus's clock: the time of the last thing it did.
    pub fn now(&self) -> Time {
        self.now
    }

    /// What it has carried so far.
    pub fn stats(&self) -> &BusStats {
        &self.stats
    }

    /// The hub itself: its drop counters ([`Hub::drops`]), its minimum
    /// priority, its clients and channels ([`Hub::status`], at
    /// [`instant_of`](Bus::instant_of) the bus's time).
    pub fn hub(&self) -> &Hub {
        self.ports.hub()
    }

    /// How many datagrams the hub dropped for this reason.
    pub fn drops(&self, reason: DropReason) -> u64 {
        self.hub().drops(reason)
    }

    /// The instant a simulated time stands for on the hub's clock.
    pub fn instant_of(&self, t: Time) -> Instant {
        self.ports.instant_of(t)
    }

    /// The synthetic address the hub knows the node at `place` by.
    pub fn address_of(&self, place: usize) -> SocketAddr {
        address_of(place)
    }

    /// Sets the hub's minimum priority, as a console does with `min_priority`:
    /// from now on, packets below `p` are dropped (and counted under
    /// [`DropReason::BelowMinPriority`]) for one lease, as on a live hub; call
    /// it again within the lease to keep it.
    pub fn set_min_priority(&mut self, p: Priority) {
        self.ports.console(self.now, &[Request::MinPriority(p)]);
    }

    /// Cuts (`false`) or mends (`true`) the link of the node at `place`: while
    /// it is cut, what the node publishes is lost ([`BusStats::lost`]), and so
    /// are the packets and lease replies the hub sends it and the refreshes its
    /// session sends, so its leases run out as a live client's do when it
    /// drives out of range.
    pub fn set_reachable(&mut self, place: usize, reachable: bool) {
        self.ports.set_reachable(place, reachable);
    }

    /// Publishes a packet from outside any node (from the console's address).
    pub fn publish(&mut self, packet: Vec<u8>) {
        self.send(CONSOLE, packet, false);
    }

    fn send(&mut self, src: SocketAddr, packet: Vec<u8>, lost: bool) {
        self.stats.sent += 1;
        match Packet::parse(&packet) {
            Ok(p) => {
                let label = p.lines().next().map_or("", |l| l.label());
                *self.stats.by_label.entry(label.to_owned()).or_default() += 1;
            }
            Err(_) => {
                self.stats.malformed += 1;
                if !lost {
                    // The hub counts it too, as a live one would.
                    self.ports.route(self.now, src, &packet, &mut self.places);
                }
                return;
            }
        }
        if let Some(r) = &mut self.record {
            r.push((self.now, packet.clone()));
        }
        if lost {
            self.stats.lost += 1;
            return;
        }
        let at = self.now + self.latency;
        self.queue.push(Reverse((at, self.seq, src, packet)));
        self.seq += 1;
    }

    fn collect(&mut self, nodes: &mut [&mut dyn Node]) {
        for (place, node) in nodes.iter_mut().enumerate() {
            while let Some(p) = node.poll_transmit() {
                let lost = self.ports.is_cut(place);
                self.send(address_of(place), p, lost);
            }
        }
    }

    /// Runs every delivery and timer due by `until`, in time order, and leaves
    /// the clock at `until`.
    pub fn run_until(&mut self, nodes: &mut [&mut dyn Node], until: Time) {
        self.ports.fit(nodes.len(), self.now);
        for (place, node) in nodes.iter().enumerate() {
            self.ports.sync(place, node.subscriptions(), self.now);
        }
        // A node whose timer stays due after it ran would spin here for ever.
        let (mut last_timer, mut spins) = (None, 0u32);
        // The nodes' next timer, kept while only the hub's side works: no
        // node is called then, so none has anything new to send and no
        // node's timer moves.
        let mut nodes_timer: Option<Option<Time>> = None;
        loop {
            if nodes_timer.is_none() {
                self.collect(nodes);
            }
            let next_control = self.ports.poll_timeout();
            let next_packet = self.queue.peek().map(|Reverse((t, ..))| *t);
            let next_timer = *nodes_timer
                .get_or_insert_with(|| nodes.iter().filter_map(|n| n.poll_timeout()).min());
            let next = [next_packet, next_timer]
                .into_iter()
                .flatten()
                .fold(next_control, Time::min);
            if next > until {
                break;
            }
            self.now = self.now.max(next);
            let now = self.now;
            // The hub's and the sessions' timers first, so a packet meets the
            // leases as they stand at its time; they never wake a node.
            if next_control <= next {
                self.ports.handle_timeout(now);
                continue;
            }
            nodes_timer = None;
            if next_packet.is_some_and(|p| p <= next) {
                if let Some(Reverse((_, _, src, bytes))) = self.queue.pop() {
                    self.deliver(nodes, src, &bytes);
                }
            } else {
                spins = if last_timer == Some(now) {
                    spins + 1
                } else {
                    0
                };
                last_timer = Some(now);
                if spins > 100_000 {
                    tracing::error!(%now, "a node's timer does not advance; stopping the bus here");
                    break;
                }
                for (place, node) in nodes.iter_mut().enumerate() {
                    if node.poll_timeout().is_some_and(|t| t <= now) {
                        node.handle_timeout(now);
                        self.ports.sync(place, node.subscriptions(), now);
                    }
                }
            }
        }
        self.now = self.now.max(until);
    }

    fn deliver(&mut self, nodes: &mut [&mut dyn Node], src: SocketAddr, bytes: &[u8]) {
        let mut places = std::mem::take(&mut self.places);
        if self.ports.route(self.now, src, bytes, &mut places) == Routed::Forward {
            // The hub forwarded it, so it parses.
            if let Ok(packet) = Packet::parse(bytes) {
                for &place in &places {
                    let node = &mut nodes[place];
                    node.handle_packet(self.now, &packet);
                    self.ports.note_data(place, self.now, &packet);
                    self.ports.sync(place, node.subscriptions(), self.now);
                    self.stats.delivered += 1;
                }
            }
            if places.is_empty() {
                self.stats.unrouted += 1;
            }
        }
        self.places = places;
    }
}

#[cfg(test)]
mod tests;
