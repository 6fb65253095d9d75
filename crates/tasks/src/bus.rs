//! An in-memory hub on simulated time, for tests and batch experiments.

use std::cmp::Reverse;
use std::collections::{BTreeMap, BinaryHeap};
use std::time::Duration;

use colony_wire::Packet;

use crate::node::{receives, Node};
use crate::time::Time;

/// What the bus saw.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct BusStats {
    /// Packets published.
    pub sent: u64,
    /// Copies handed to nodes.
    pub delivered: u64,
    /// Published packets nobody was subscribed to.
    pub unrouted: u64,
    /// Published packets that did not parse, dropped as the hub drops them.
    pub malformed: u64,
    /// Packets published, by the label of their first line (`task`, `bid`, ...).
    pub by_label: BTreeMap<String, u64>,
}

/// Routes packets between [`Node`]s exactly as the hub does (a packet reaches
/// a node only if the node is subscribed to every one of its subjects), with a
/// fixed latency, and drives every node's timers on simulated time.
///
/// Nodes are passed to each call, so a caller can kill one (leave it out) or
/// start one between calls. Delivery order is deterministic: by time, then by
/// the order packets were sent, then by the node's place in the slice.
///
/// ```
/// use std::time::Duration;
/// use colony_tasks::{Agent, AgentConfig, Announcer, AuctionConfig, Bus, Node, TaskSpec, Time, Token};
/// let mut bus = Bus::new(Duration::from_millis(1));
/// let mut robot = Agent::new(Token::new("r1").unwrap(), "camera mobile".parse().unwrap(),
///     AgentConfig::default(), Time::ZERO);
/// let mut user = Announcer::new(Token::new("u").unwrap(), AuctionConfig::default());
/// let id = user.announce(Time::ZERO, TaskSpec::new("look", "camera".parse().unwrap())).unwrap();
/// bus.run_until(&mut [&mut robot, &mut user], Time::from_secs_f64(1.0));
/// assert_eq!(user.winner(id).map(|w| w.as_str()), Some("r1"));
/// ```
#[derive(Debug)]
pub struct Bus {
    latency: Duration,
    now: Time,
    seq: u64,
    queue: BinaryHeap<Reverse<(Time, u64, Vec<u8>)>>,
    stats: BusStats,
    record: Option<Vec<(Time, Vec<u8>)>>,
}

impl Bus {
    /// A bus that delivers each packet `latency` after it was sent.
    pub fn new(latency: Duration) -> Bus {
        Bus {
            latency,
            now: Time::ZERO,
            seq: 0,
            queue: BinaryHeap::new(),
            stats: BusStats::default(),
            record: None,
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

    /// Publishes a packet from outside any node.
    pub fn publish(&mut self, packet: Vec<u8>) {
        self.stats.sent += 1;
        match Packet::parse(&packet) {
            Ok(p) => {
                let label = p.lines().next().map_or("", |l| l.label());
                *self.stats.by_label.entry(label.to_owned()).or_default() += 1;
            }
            Err(_) => {
                self.stats.malformed += 1;
                return;
            }
        }
        if let Some(r) = &mut self.record {
            r.push((self.now, packet.clone()));
        }
        let at = self.now + self.latency;
        self.queue.push(Reverse((at, self.seq, packet)));
        self.seq += 1;
    }

    fn collect(&mut self, nodes: &mut [&mut dyn Node]) {
        for node in nodes.iter_mut() {
            while let Some(p) = node.poll_transmit() {
                self.publish(p);
            }
        }
    }

    /// Runs every delivery and timer due by `until`, in time order, and leaves
    /// the clock at `until`.
    pub fn run_until(&mut self, nodes: &mut [&mut dyn Node], until: Time) {
        // A node whose timer stays due after it ran would spin here for ever.
        let (mut last_timer, mut spins) = (None, 0u32);
        loop {
            self.collect(nodes);
            let next_packet = self.queue.peek().map(|Reverse((t, _, _))| *t);
            let next_timer = nodes.iter().filter_map(|n| n.poll_timeout()).min();
            let next = match (next_packet, next_timer) {
                (Some(p), Some(t)) => p.min(t),
                (Some(p), None) => p,
                (None, Some(t)) => t,
                (None, None) => break,
            };
            if next > until {
                break;
            }
            self.now = self.now.max(next);
            if next_packet.is_some_and(|p| p <= next) {
                if let Some(Reverse((_, _, bytes))) = self.queue.pop() {
                    self.deliver(nodes, &bytes);
                }
            } else {
                let now = self.now;
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
                for node in nodes.iter_mut() {
                    if node.poll_timeout().is_some_and(|t| t <= now) {
                        node.handle_timeout(now);
                    }
                }
            }
        }
        self.now = self.now.max(until);
    }

    fn deliver(&mut self, nodes: &mut [&mut dyn Node], bytes: &[u8]) {
        let Ok(packet) = Packet::parse(bytes) else {
            return;
        };
        let mut any = false;
        for node in nodes.iter_mut() {
            if receives(node.subscriptions(), packet.subjects()) {
                node.handle_packet(self.now, &packet);
                self.stats.delivered += 1;
                any = true;
            }
        }
        if !any {
            self.stats.unrouted += 1;
        }
    }
}
