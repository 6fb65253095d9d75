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

#[cfg(test)]
mod tests {
    use std::cell::RefCell;
    use std::collections::{BTreeSet, VecDeque};
    use std::rc::Rc;

    use colony_wire::Subject;

    use super::*;

    type Log = Rc<RefCell<Vec<(Time, &'static str, String)>>>;

    /// A node that logs what it hears, answers `ping` with `pong`, and can
    /// carry one timer.
    struct Probe {
        name: &'static str,
        subs: BTreeSet<Subject>,
        log: Log,
        outbox: VecDeque<Vec<u8>>,
        timer: Option<Time>,
        timeouts: Vec<Time>,
        /// Leaves its timer where it is when it fires.
        stuck: bool,
    }

    impl Probe {
        fn new(name: &'static str, subs: &str, log: &Log) -> Probe {
            Probe {
                name,
                subs: subs
                    .split_whitespace()
                    .map(|s| Subject::new(s).unwrap())
                    .collect(),
                log: log.clone(),
                outbox: VecDeque::new(),
                timer: None,
                timeouts: Vec::new(),
                stuck: false,
            }
        }
    }

    impl Node for Probe {
        fn subscriptions(&self) -> &BTreeSet<Subject> {
            &self.subs
        }
        fn handle_packet(&mut self, now: Time, packet: &Packet<'_>) {
            let body = packet.lines().next().map_or("", |l| l.label()).to_owned();
            if body == "ping" {
                self.outbox.push_back(b"@ <b> 0\npong\n".to_vec());
            }
            self.log.borrow_mut().push((now, self.name, body));
        }
        fn handle_timeout(&mut self, now: Time) {
            self.timeouts.push(now);
            if !self.stuck {
                self.timer = None;
            }
        }
        fn poll_timeout(&self) -> Option<Time> {
            self.timer
        }
        fn poll_transmit(&mut self) -> Option<Vec<u8>> {
            self.outbox.pop_front()
        }
    }

    fn ms(v: u64) -> Time {
        Time::from_micros(v * 1000)
    }

    fn heard(log: &Log) -> Vec<(u64, &'static str, String)> {
        log.borrow()
            .iter()
            .map(|(t, n, b)| (t.as_micros() / 1000, *n, b.clone()))
            .collect()
    }

    #[test]
    fn a_packet_reaches_only_nodes_subscribed_to_all_its_subjects() {
        let log = Log::default();
        let mut both = Probe::new("both", "a b", &log);
        let mut only_a = Probe::new("only_a", "a", &log);
        let mut more = Probe::new("more", "a b c", &log);
        let mut none = Probe::new("none", "", &log);
        let mut bus = Bus::new(Duration::from_millis(1));
        bus.publish(b"@ <a> <b> 0\nhello\n".to_vec());
        bus.run_until(&mut [&mut both, &mut only_a, &mut more, &mut none], ms(10));
        let names: Vec<&str> = log.borrow().iter().map(|(_, n, _)| *n).collect();
        assert_eq!(names, ["both", "more"]);
        assert_eq!(bus.stats().delivered, 2);
        assert_eq!(bus.stats().unrouted, 0);
    }

    #[test]
    fn a_packet_arrives_exactly_one_latency_after_it_was_sent() {
        let log = Log::default();
        let mut p = Probe::new("p", "a", &log);
        let mut bus = Bus::new(Duration::from_millis(5));
        bus.publish(b"@ <a> 0\nhello\n".to_vec());
        bus.run_until(&mut [&mut p], ms(4));
        assert!(log.borrow().is_empty());
        assert_eq!(bus.now(), ms(4));
        bus.run_until(&mut [&mut p], ms(20));
        assert_eq!(heard(&log), [(5, "p", "hello".to_string())]);
    }

    #[test]
    fn a_reply_leaves_at_the_moment_its_cause_arrived() {
        let log = Log::default();
        let mut a = Probe::new("a", "a", &log);
        let mut b = Probe::new("b", "b", &log);
        let mut bus = Bus::new(Duration::from_millis(3));
        bus.publish(b"@ <a> 0\nping\n".to_vec());
        bus.run_until(&mut [&mut a, &mut b], ms(100));
        assert_eq!(
            heard(&log),
            [(3, "a", "ping".to_string()), (6, "b", "pong".to_string())]
        );
    }

    #[test]
    fn simultaneous_packets_go_in_send_order_then_node_order() {
        let log = Log::default();
        let mut first = Probe::new("first", "a", &log);
        let mut second = Probe::new("second", "a", &log);
        let mut bus = Bus::new(Duration::from_millis(1));
        for label in ["one", "two", "three"] {
            bus.publish(format!("@ <a> 0\n{label}\n").into_bytes());
        }
        bus.run_until(&mut [&mut first, &mut second], ms(5));
        let got: Vec<(&str, String)> = log
            .borrow()
            .iter()
            .map(|(_, n, b)| (*n, b.clone()))
            .collect();
        let want: Vec<(&str, String)> = ["one", "two", "three"]
            .iter()
            .flat_map(|l| [("first", l.to_string()), ("second", l.to_string())])
            .collect();
        assert_eq!(got, want);
    }

    #[test]
    fn a_packet_nobody_wants_is_counted_unrouted() {
        let log = Log::default();
        let mut p = Probe::new("p", "a", &log);
        let mut bus = Bus::new(Duration::from_millis(1));
        bus.publish(b"@ <a> <z> 0\nhello\n".to_vec());
        bus.run_until(&mut [&mut p], ms(5));
        assert!(log.borrow().is_empty());
        assert_eq!(bus.stats().unrouted, 1);
        assert_eq!(bus.stats().delivered, 0);
    }

    #[test]
    fn a_malformed_packet_is_counted_and_dropped_unrecorded() {
        let log = Log::default();
        let mut p = Probe::new("p", "a", &log);
        let mut bus = Bus::new(Duration::from_millis(1));
        bus.record();
        bus.publish(b"not a packet".to_vec());
        bus.publish(b"@ <a> 0\nbid x 1\n".to_vec());
        bus.publish(b"@ <a> 0\nbid x 2\n".to_vec());
        bus.run_until(&mut [&mut p], ms(5));
        let s = bus.stats();
        assert_eq!((s.sent, s.malformed, s.delivered), (3, 1, 2));
        assert_eq!(s.by_label.get("bid"), Some(&2));
        assert_eq!(s.by_label.len(), 1);
        assert_eq!(bus.take_recorded().len(), 2);
    }

    #[test]
    fn recording_keeps_each_packet_with_its_send_time_once() {
        let log = Log::default();
        let mut a = Probe::new("a", "a", &log);
        let mut b = Probe::new("b", "b", &log);
        let mut bus = Bus::new(Duration::from_millis(2));
        bus.publish(b"@ <a> 0\nbefore\n".to_vec());
        bus.record();
        bus.publish(b"@ <a> 0\nping\n".to_vec());
        bus.run_until(&mut [&mut a, &mut b], ms(10));
        let rec = bus.take_recorded();
        let times: Vec<u64> = rec.iter().map(|(t, _)| t.as_micros() / 1000).collect();
        assert_eq!(times, [0, 2]);
        assert_eq!(rec[1].1, b"@ <b> 0\npong\n");
        assert!(bus.take_recorded().is_empty());
    }

    #[test]
    fn without_record_nothing_is_kept() {
        let mut bus = Bus::new(Duration::from_millis(1));
        bus.publish(b"@ <a> 0\nhello\n".to_vec());
        assert!(bus.take_recorded().is_empty());
    }

    #[test]
    fn timers_fire_at_their_time_and_not_past_the_horizon() {
        let log = Log::default();
        let mut early = Probe::new("early", "", &log);
        early.timer = Some(ms(7));
        let mut late = Probe::new("late", "", &log);
        late.timer = Some(ms(50));
        let mut bus = Bus::new(Duration::from_millis(1));
        bus.run_until(&mut [&mut early, &mut late], ms(20));
        assert_eq!(early.timeouts, [ms(7)]);
        assert!(late.timeouts.is_empty());
        assert_eq!(bus.now(), ms(20));
    }

    #[test]
    fn a_timer_that_never_advances_stops_the_bus_instead_of_hanging() {
        let log = Log::default();
        let mut stuck = Probe::new("stuck", "", &log);
        stuck.timer = Some(ms(1));
        stuck.stuck = true;
        let mut bus = Bus::new(Duration::from_millis(1));
        bus.run_until(&mut [&mut stuck], ms(10));
        assert!(stuck.timeouts.len() > 100_000);
        assert!(stuck.timeouts.iter().all(|t| *t == ms(1)));
        assert_eq!(bus.now(), ms(10));
    }

    #[test]
    fn the_clock_never_goes_back() {
        let mut bus = Bus::new(Duration::from_millis(1));
        bus.run_until(&mut [], ms(10));
        bus.run_until(&mut [], ms(3));
        assert_eq!(bus.now(), ms(10));
    }
}
