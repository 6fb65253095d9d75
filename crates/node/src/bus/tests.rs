//! The bus's behaviour: routing, timing, order, counting, and the hub's rules.

use std::cell::RefCell;
use std::collections::{BTreeSet, VecDeque};
use std::rc::Rc;

use colony_wire::Subject;

use super::*;
use colony_client::ClientConfig;
use colony_hub::{DropReason, HubConfig};
use colony_wire::Priority;

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
    assert_eq!(
        bus.drops(DropReason::Malformed),
        1,
        "the hub counted it too"
    );
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

#[test]
fn a_packet_below_the_minimum_priority_is_dropped_and_counted_by_the_hub() {
    let log = Log::default();
    let mut p = Probe::new("p", "a", &log);
    let mut bus = Bus::new(Duration::from_millis(1));
    bus.set_min_priority(Priority(5));
    assert_eq!(bus.hub().min_priority(), Priority(5));
    bus.publish(b"@ <a> 4\nlow\n".to_vec());
    bus.publish(b"@ <a> 5\nhigh\n".to_vec());
    bus.run_until(&mut [&mut p], ms(10));
    assert_eq!(heard(&log), [(1, "p", "high".to_string())]);
    assert_eq!(bus.drops(DropReason::BelowMinPriority), 1);
    let s = bus.stats();
    assert_eq!((s.sent, s.delivered, s.unrouted), (2, 1, 0));
}

/// A bus whose hub grants one-second leases.
fn short_leases() -> Bus {
    let hub = HubConfig {
        lease: Duration::from_secs(1),
        ..HubConfig::default()
    };
    Bus::with_config(Duration::from_millis(1), hub, ClientConfig::default())
}

#[test]
fn the_sessions_keep_the_leases_of_a_node_that_hears_nothing_for_a_long_time() {
    let log = Log::default();
    let mut p = Probe::new("p", "a", &log);
    let mut bus = short_leases();
    bus.run_until(&mut [&mut p], ms(60_000));
    bus.publish(b"@ <a> 0\nstill\n".to_vec());
    bus.run_until(&mut [&mut p], ms(60_010));
    assert_eq!(heard(&log), [(60_001, "p", "still".to_string())]);
    assert_eq!(bus.hub().client_count(), 1);
}

#[test]
fn a_node_whose_lease_lapsed_hears_nothing_until_its_session_subscribes_again() {
    let log = Log::default();
    let mut talker = Probe::new("talker", "", &log);
    let mut ear = Probe::new("ear", "a", &log);
    let mut bus = short_leases();
    bus.run_until(&mut [&mut talker, &mut ear], ms(500));
    // Out of range: its refreshes are lost, so the hub lets its lease lapse.
    bus.set_reachable(1, false);
    bus.run_until(&mut [&mut talker, &mut ear], ms(3_010));
    assert_eq!(bus.hub().client_count(), 0, "the lease lapsed");
    // Back in range: one packet every 10 ms.
    bus.set_reachable(1, true);
    let mut sent = Vec::new();
    for i in 0..120u64 {
        let at = 3_010 + 10 * i;
        bus.publish(format!("@ <a> 0\nm{at}\n").into_bytes());
        sent.push(at);
        bus.run_until(&mut [&mut talker, &mut ear], ms(at + 10));
    }
    let heard = heard(&log);
    let first = heard.first().expect("it subscribed again").0 - 1;
    let missed = sent.iter().filter(|&&t| t < first).count();
    assert!(
        missed > 0,
        "the hub forwarded nothing to it before it resubscribed"
    );
    // It asks again at least every resubscribe interval (1 s), and from then
    // on it hears everything.
    assert!(first - 3_010 <= 1_000, "heard again only at {first} ms");
    assert_eq!(heard.len() + missed, sent.len());
    assert_eq!(bus.stats().unrouted as usize, missed);
}

#[test]
fn what_a_cut_node_publishes_is_lost_and_what_it_is_sent_does_not_reach_it() {
    let log = Log::default();
    let mut a = Probe::new("a", "a", &log);
    let mut b = Probe::new("b", "b", &log);
    let mut bus = Bus::new(Duration::from_millis(1));
    bus.set_reachable(0, false);
    bus.publish(b"@ <a> 0\nping\n".to_vec());
    b.outbox.push_back(b"@ <a> 0\nhello\n".to_vec());
    a.outbox.push_back(b"@ <b> 0\nfrom_a\n".to_vec());
    bus.run_until(&mut [&mut a, &mut b], ms(10));
    assert!(log.borrow().is_empty());
    let s = bus.stats();
    assert_eq!((s.sent, s.lost, s.delivered, s.unrouted), (3, 1, 0, 2));
}

#[test]
fn control_traffic_is_not_counted_as_the_nodes_packets() {
    let log = Log::default();
    let mut a = Probe::new("a", "a b c", &log);
    let mut bus = short_leases();
    bus.record();
    bus.run_until(&mut [&mut a], ms(30_000));
    assert_eq!(bus.stats(), &BusStats::default());
    assert!(bus.take_recorded().is_empty());
    assert_eq!(bus.hub().client_count(), 1);
}

#[test]
fn a_node_left_out_is_unsubscribed_at_once_and_the_next_takes_its_place() {
    let log = Log::default();
    let mut a = Probe::new("a", "x", &log);
    let mut b = Probe::new("b", "y", &log);
    let mut bus = Bus::new(Duration::from_millis(1));
    bus.run_until(&mut [&mut a, &mut b], ms(1));
    assert_eq!(bus.hub().client_count(), 2);
    // `a` killed: `b` now holds place 0, and place 1 is gone from the hub.
    bus.publish(b"@ <x> 0\nto_a\n".to_vec());
    bus.publish(b"@ <y> 0\nto_b\n".to_vec());
    bus.run_until(&mut [&mut b], ms(10));
    assert_eq!(heard(&log), [(2, "b", "to_b".to_string())]);
    assert_eq!(bus.hub().client_count(), 1);
    assert_eq!(bus.stats().unrouted, 1);
}

#[test]
fn a_subscription_taken_on_hearing_a_packet_holds_for_the_next_one() {
    /// Subscribes to `b` when it hears `a`.
    struct Joiner(BTreeSet<Subject>, Vec<String>);
    impl Node for Joiner {
        fn subscriptions(&self) -> &BTreeSet<Subject> {
            &self.0
        }
        fn handle_packet(&mut self, _: Time, packet: &Packet<'_>) {
            self.1.push(packet.subjects_text().to_string());
            self.0.insert(Subject::new("b").unwrap());
        }
        fn handle_timeout(&mut self, _: Time) {}
        fn poll_timeout(&self) -> Option<Time> {
            None
        }
        fn poll_transmit(&mut self) -> Option<Vec<u8>> {
            None
        }
    }
    let mut j = Joiner([Subject::new("a").unwrap()].into(), Vec::new());
    let mut bus = Bus::new(Duration::from_millis(1));
    bus.publish(b"@ <a> 0\nx\n".to_vec());
    bus.publish(b"@ <b> 0\nx\n".to_vec());
    bus.run_until(&mut [&mut j], ms(5));
    assert_eq!(j.1, ["<a>", "<b>"]);
}

#[test]
fn delivery_goes_by_place_whatever_order_the_hub_holds_its_subscribers_in() {
    let log = Log::default();
    let names = ["n0", "n1", "n2", "n3", "n4", "n5", "n6", "n7"];
    let mut probes: Vec<Probe> = names.iter().map(|n| Probe::new(n, "", &log)).collect();
    let mut bus = Bus::new(Duration::from_millis(1));
    // Subscribe in reverse order, and churn a few, so the hub's table is shuffled.
    for i in (0..names.len()).rev() {
        probes[i].subs.insert(Subject::new("a").unwrap());
        let mut nodes: Vec<&mut dyn Node> = probes.iter_mut().map(|p| p as &mut dyn Node).collect();
        bus.run_until(&mut nodes, bus.now());
    }
    for i in [5, 2, 6] {
        probes[i].subs.clear();
        let mut nodes: Vec<&mut dyn Node> = probes.iter_mut().map(|p| p as &mut dyn Node).collect();
        bus.run_until(&mut nodes, bus.now());
        probes[i].subs.insert(Subject::new("a").unwrap());
        let mut nodes: Vec<&mut dyn Node> = probes.iter_mut().map(|p| p as &mut dyn Node).collect();
        bus.run_until(&mut nodes, bus.now());
    }
    bus.publish(b"@ <a> 0\none\n".to_vec());
    bus.publish(b"@ <a> 0\ntwo\n".to_vec());
    let mut nodes: Vec<&mut dyn Node> = probes.iter_mut().map(|p| p as &mut dyn Node).collect();
    bus.run_until(&mut nodes, ms(5));
    let got: Vec<(&str, String)> = log
        .borrow()
        .iter()
        .map(|(_, n, b)| (*n, b.clone()))
        .collect();
    let want: Vec<(&str, String)> = ["one", "two"]
        .iter()
        .flat_map(|l| names.iter().map(|n| (*n, l.to_string())))
        .collect();
    assert_eq!(got, want);
}

#[test]
fn the_hub_limits_hold_on_the_bus() {
    let log = Log::default();
    let mut greedy = Probe::new("greedy", "a b c", &log);
    let hub = HubConfig {
        max_subscriptions: 2,
        ..HubConfig::default()
    };
    let mut bus = Bus::with_config(Duration::from_millis(1), hub, ClientConfig::default());
    bus.publish(b"@ <c> 0\nx\n".to_vec());
    bus.run_until(&mut [&mut greedy], ms(5));
    assert!(
        log.borrow().is_empty(),
        "its third subscription was refused"
    );
    assert!(bus.drops(DropReason::TooManySubscriptions) >= 1);
}
