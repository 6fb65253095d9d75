//! The hub against a hostile network, as a state machine: each test is one
//! of the ways a forged or flooding source could hurt the system.

use std::net::SocketAddr;
use std::time::{Duration, Instant, SystemTime};

use colony_hub::{DropReason, Hub, HubConfig, Outcome};
use colony_wire::auth::{unix_micros, Key};
use colony_wire::{Cookie, Packet, Reply, StatusReport};

fn addr(port: u16) -> SocketAddr {
    SocketAddr::from(([127, 0, 0, 1], port))
}

const HUB: u16 = 7400;

fn hub_with(config: HubConfig, now: Instant) -> Hub {
    let mut hub = Hub::new(config, now);
    hub.set_local_addr(addr(HUB));
    hub
}

fn replies(hub: &mut Hub) -> Vec<(SocketAddr, Vec<u8>)> {
    std::iter::from_fn(|| hub.poll_transmit())
        .map(|t| (t.dest, t.payload))
        .collect()
}

/// What a well-behaved client does: ask, take the cookie, ask again with it.
fn join(hub: &mut Hub, now: Instant, who: SocketAddr, lines: &str) -> Cookie {
    let first = format!("@ <hub> 0\ncookie v {}\n{lines}", Cookie::NONE);
    hub.handle(now, who, first.as_bytes());
    let cookie = replies(hub)
        .into_iter()
        .find_map(|(dest, p)| match Reply::parse(&Packet::parse(&p).ok()?) {
            Some(Ok(Reply::Cookie(c))) if dest == who => Some(c),
            _ => None,
        })
        .expect("a cookie for a new address");
    let again = format!("@ <hub> 0\ncookie v {cookie}\n{lines}");
    assert_eq!(hub.handle(now, who, again.as_bytes()), Outcome::Control);
    cookie
}

fn forwarded(hub: &mut Hub, now: Instant, from: SocketAddr, packet: &[u8]) -> Vec<SocketAddr> {
    match hub.handle(now, from, packet) {
        Outcome::Forward { dests, .. } => dests.to_vec(),
        other => panic!("expected a forward, got {other:?}"),
    }
}

#[test]
fn a_subscribe_forged_from_the_hubs_own_address_subscribes_nothing_and_is_not_answered() {
    let now = Instant::now();
    let mut hub = hub_with(HubConfig::default(), now);
    let forged = format!("@ <hub> 0\ncookie v {}\nsubscribe ch loop\n", Cookie::NONE);
    for src in [
        addr(HUB),
        SocketAddr::from(([127, 0, 0, 2], HUB)),
        addr(0),
        "255.255.255.255:9".parse().unwrap(),
    ] {
        assert_eq!(
            hub.handle(now, src, forged.as_bytes()),
            Outcome::Dropped(DropReason::BadSource)
        );
    }
    assert!(replies(&mut hub).is_empty(), "nothing is sent to itself");
    assert_eq!(hub.client_count(), 0);
    // The hub's own cookie, reflected back to it, is no request either.
    assert_eq!(
        hub.handle(now, addr(HUB), b"@ <hub> 0\ncookie v 0123456789abcdef\n"),
        Outcome::Dropped(DropReason::BadSource)
    );
    assert!(forwarded(&mut hub, now, addr(5), b"@ <loop> 0\nx a 1\n").is_empty());
}

#[test]
fn a_forged_subscribe_sends_the_victim_at_most_one_cookie_no_larger_than_the_request() {
    let now = Instant::now();
    let mut hub = hub_with(HubConfig::default(), now);
    let victim = addr(5000);
    for request in [
        format!("@ <hub> 0\ncookie v {}\nsubscribe ch video\n", Cookie::NONE),
        "@ <hub> 0\nsubscribe ch video\n".to_owned(),
        "@ <hub> 0\ncookie v 0123456789abcdef\nsubscribe ch video\nstatus\n".to_owned(),
        "@ <hub> 0\nstatus\n".to_owned(),
    ] {
        hub.handle(now, victim, request.as_bytes());
        let sent = replies(&mut hub);
        assert!(sent.len() <= 1);
        for (dest, payload) in sent {
            assert_eq!(dest, victim);
            assert!(
                payload.len() <= request.len(),
                "{} > {}",
                payload.len(),
                request.len()
            );
            let p = Packet::parse(&payload).unwrap();
            assert!(matches!(Reply::parse(&p), Some(Ok(Reply::Cookie(_)))));
        }
    }
    assert_eq!(hub.client_count(), 0, "no lease without the cookie back");
    assert!(forwarded(&mut hub, now, addr(9), b"@ <video> 0\nframe n 1\n").is_empty());
    assert_eq!(hub.drops(DropReason::BadCookie), 1);
}

#[test]
fn a_client_already_leased_cannot_be_given_more_streams_by_a_forger() {
    let now = Instant::now();
    let mut hub = hub_with(HubConfig::default(), now);
    let victim = addr(5000);
    join(&mut hub, now, victim, "subscribe ch small\n");
    // Holding a lease is no proof for a packet that carries no cookie.
    hub.handle(now, victim, b"@ <hub> 0\nsubscribe ch video\n");
    assert!(forwarded(&mut hub, now, addr(9), b"@ <video> 0\nframe n 1\n").is_empty());
    hub.handle(now, victim, b"@ <hub> 0\nunsubscribe_all\n");
    assert_eq!(
        forwarded(&mut hub, now, addr(9), b"@ <small> 0\nx a 1\n"),
        [victim]
    );
}

fn console_hub(now: Instant) -> Hub {
    hub_with(
        HubConfig {
            consoles: vec!["127.0.0.1:7000".parse().unwrap()],
            lease: Duration::from_secs(2),
            ..HubConfig::default()
        },
        now,
    )
}

#[test]
fn min_priority_from_a_source_that_is_no_console_is_refused_and_counted() {
    let now = Instant::now();
    let mut hub = console_hub(now);
    join(&mut hub, now, addr(1), "subscribe ch radio\n");
    join(&mut hub, now, addr(6666), "min_priority value 2147483647\n");
    assert_eq!(hub.drops(DropReason::NotConsole), 1);
    assert_eq!(
        forwarded(&mut hub, now, addr(9), b"@ <radio> 0\ncmd id 1\n"),
        [addr(1)]
    );
    // Nor from the console's address without its cookie (forged).
    hub.handle(
        now,
        addr(7000),
        b"@ <hub> 0\nmin_priority value 2147483647\n",
    );
    assert_eq!(
        forwarded(&mut hub, now, addr(9), b"@ <radio> 0\ncmd id 1\n"),
        [addr(1)]
    );
    let report = hub.status(now);
    assert!(report.drops.contains(&("not_console".to_owned(), 1)));
}

#[test]
fn a_consoles_raised_minimum_lapses_after_its_lease_unless_renewed() {
    let t0 = Instant::now();
    let mut hub = console_hub(t0);
    join(&mut hub, t0, addr(1), "subscribe ch radio\n");
    let console = addr(7000);
    let cookie = join(&mut hub, t0, console, "min_priority value 10\n");
    assert_eq!(hub.min_priority().0, 10);
    // Renewed a second later: still in force at 2.5 s.
    let t1 = t0 + Duration::from_secs(1);
    let renew = format!("@ <hub> 0\ncookie v {cookie}\nmin_priority value 10\n");
    hub.handle(t1, console, renew.as_bytes());
    let t2 = t0 + Duration::from_millis(2500);
    hub.handle_timeout(t2);
    assert_eq!(hub.min_priority().0, 10);
    assert_eq!(
        hub.handle(t2, addr(9), b"@ <radio> 0\ncmd id 1\n"),
        Outcome::Dropped(DropReason::BelowMinPriority)
    );
    // The console died: one lease after its last renewal, the robots are back.
    let t3 = t1 + Duration::from_millis(2100);
    hub.handle_timeout(t3);
    assert_eq!(hub.min_priority().0, i32::MIN);
    join(&mut hub, t3, addr(1), "subscribe ch radio\n"); // its own lease, renewed
    assert_eq!(
        forwarded(&mut hub, t3, addr(9), b"@ <radio> 0\ncmd id 1\n"),
        [addr(1)]
    );
}

fn key() -> Key {
    Key::new(b"the lab's shared key, 32 bytes!!").unwrap()
}

fn signed(lines: &str, cookie: Cookie, n: u64) -> Vec<u8> {
    let mut p = format!("@ <hub> 0\ncookie v {cookie}\n{lines}").into_bytes();
    key().sign(&mut p, n);
    p
}

#[test]
fn a_signed_request_makes_any_address_a_console_once_and_only_once() {
    let now = Instant::now();
    let mut hub = hub_with(
        HubConfig {
            key: Some(key()),
            ..HubConfig::default()
        },
        now,
    );
    let console = addr(4321);
    let cookie = join(&mut hub, now, console, "status\n");
    replies(&mut hub);
    let n = unix_micros(SystemTime::now());
    let request = signed("min_priority value 3\n", cookie, n);
    hub.handle(now, console, &request);
    assert_eq!(hub.min_priority().0, 3);
    // The same packet again is a replay.
    hub.handle(
        now,
        console,
        &signed("min_priority value -2147483648\n", cookie, n),
    );
    assert_eq!(hub.drops(DropReason::BadAuth), 1);
    assert_eq!(hub.min_priority().0, 3);
    // A wrong key, or a counter far from the clock, is refused.
    let mut forged = format!("@ <hub> 0\ncookie v {cookie}\nmin_priority value 9\n").into_bytes();
    Key::new(b"not the lab's key, but long enough")
        .unwrap()
        .sign(&mut forged, n + 1);
    assert_eq!(
        hub.handle(now, console, &forged),
        Outcome::Dropped(DropReason::BadAuth)
    );
    let stale = signed("min_priority value 9\n", cookie, n - 3_600_000_000);
    assert_eq!(
        hub.handle(now, console, &stale),
        Outcome::Dropped(DropReason::BadAuth)
    );
    assert_eq!(hub.min_priority().0, 3);
    // Unsigned, the same address is no console.
    join(&mut hub, now, console, "min_priority value 9\n");
    assert_eq!(hub.drops(DropReason::NotConsole), 1);
}

#[test]
fn with_every_packet_authenticated_an_unsigned_publish_is_dropped_and_a_signed_one_forwarded_bare()
{
    let now = Instant::now();
    let mut hub = hub_with(
        HubConfig {
            key: Some(key()),
            auth_all: true,
            ..HubConfig::default()
        },
        now,
    );
    let sub = addr(1);
    let mut n = unix_micros(SystemTime::now());
    let ask = signed("subscribe ch radio\n", Cookie::NONE, n);
    hub.handle(now, sub, &ask);
    let cookie = replies(&mut hub)
        .into_iter()
        .find_map(|(_, p)| match Reply::parse(&Packet::parse(&p).ok()?) {
            Some(Ok(Reply::Cookie(c))) => Some(c),
            _ => None,
        })
        .unwrap();
    n += 1;
    hub.handle(now, sub, &signed("subscribe ch radio\n", cookie, n));
    assert_eq!(
        hub.handle(now, addr(2), b"@ <radio> 0\ncmd id 1\n"),
        Outcome::Dropped(DropReason::BadAuth)
    );
    let body = b"@ <radio> 0\ncmd id 1\n";
    let mut p = body.to_vec();
    key().sign(&mut p, n);
    match hub.handle(now, addr(2), &p) {
        Outcome::Forward { len, dests } => {
            assert_eq!(dests, [sub]);
            assert_eq!(&p[..len], body, "forwarded without its auth line");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_table_full_of_unverified_sources_still_takes_a_new_client() {
    let now = Instant::now();
    let mut hub = hub_with(
        HubConfig {
            max_clients: 64,
            ..HubConfig::default()
        },
        now,
    );
    for port in 10_000..10_000 + 4096u16 {
        let forged = format!("@ <hub> 0\ncookie v {}\nsubscribe ch x\n", Cookie::NONE);
        hub.handle(now, addr(port), forged.as_bytes());
    }
    replies(&mut hub);
    assert_eq!(hub.client_count(), 0, "unverified sources hold no place");
    join(&mut hub, now, addr(1), "subscribe ch x\n");
    assert_eq!(hub.client_count(), 1);
}

#[test]
fn a_table_full_of_idle_clients_makes_room_and_one_in_use_keeps_its_place() {
    let t0 = Instant::now();
    let mut hub = hub_with(
        HubConfig {
            max_clients: 8,
            ..HubConfig::default()
        },
        t0,
    );
    for port in 100..108 {
        join(&mut hub, t0, addr(port), "subscribe ch x\n");
    }
    // One renews its lease as a live client does; the others fall silent for
    // more than half a lease. Publishing is no renewal: anyone can forge it.
    let t1 = t0 + Duration::from_secs(6);
    join(&mut hub, t1, addr(100), "subscribe ch x\n");
    for port in 101..108 {
        hub.handle(t1, addr(port), b"@ <x> 0\nalive a 1\n");
    }
    join(&mut hub, t1, addr(1), "subscribe ch x\n");
    let dests = forwarded(&mut hub, t1, addr(9), b"@ <x> 0\nx a 1\n");
    assert!(dests.contains(&addr(1)), "the newcomer got in");
    assert!(
        dests.contains(&addr(100)),
        "the client in use kept its place"
    );
    assert_eq!(hub.client_count(), 8);
    // With every client renewing, a newcomer from the same host is turned away...
    for port in (100..108).chain([1]) {
        join(&mut hub, t1, addr(port), "subscribe ch x\n");
    }
    let before = hub.drops(DropReason::TooManyClients);
    join(&mut hub, t1, addr(2), "subscribe ch x\n");
    assert_eq!(hub.drops(DropReason::TooManyClients), before + 1);
    // ...but one from another host takes a place of the host that holds them all.
    let robot = SocketAddr::from(([10, 0, 0, 7], 5000));
    join(&mut hub, t1, robot, "subscribe ch x\n");
    assert!(forwarded(&mut hub, t1, addr(9), b"@ <x> 0\nx a 1\n").contains(&robot));
    assert_eq!(hub.client_count(), 8);
}

#[test]
fn a_forger_cannot_spend_a_real_clients_rate() {
    let now = Instant::now();
    let mut hub = hub_with(HubConfig::default(), now);
    let robot = addr(4000);
    let cookie = join(&mut hub, now, robot, "subscribe ch radio\n");
    for _ in 0..10_000 {
        hub.handle(now, robot, b"@ <hub> 0\nstatus\n");
        hub.handle(
            now,
            robot,
            b"@ <hub> 0\ncookie v 0123456789abcdef\nstatus\n",
        );
    }
    replies(&mut hub);
    // The robot's own refreshes, with its cookie, still go through.
    let before = hub.drops(DropReason::RateLimited);
    let refresh = format!("@ <hub> 0\ncookie v {cookie}\nsubscribe ch radio\n");
    for _ in 0..10 {
        hub.handle(now, robot, refresh.as_bytes());
    }
    assert_eq!(hub.drops(DropReason::RateLimited), before);
    assert_eq!(replies(&mut hub).len(), 10, "a lease for each");
    assert_eq!(
        forwarded(&mut hub, now, addr(9), b"@ <radio> 0\ncmd id 1\n"),
        [robot]
    );
}

#[test]
fn one_packet_gets_one_status_report_however_many_lines_ask() {
    let now = Instant::now();
    let mut hub = hub_with(HubConfig::default(), now);
    let who = addr(4000);
    let cookie = join(&mut hub, now, who, "subscribe ch radio\n");
    replies(&mut hub);
    let mut ask = format!("@ <hub> 0\ncookie v {cookie}\n");
    for _ in 0..1000 {
        ask.push_str("status\n");
    }
    hub.handle(now, who, ask.as_bytes());
    assert_eq!(replies(&mut hub).len(), 1);
    // And a packet of more requests than any client sends does nothing at all.
    let mut flood = format!("@ <hub> 0\ncookie v {cookie}\n");
    for i in 0..2000 {
        flood.push_str(&format!("subscribe ch c{i}\n"));
    }
    assert_eq!(
        hub.handle(now, who, flood.as_bytes()),
        Outcome::Dropped(DropReason::BadControl)
    );
}

#[test]
fn control_requests_beyond_a_sources_rate_are_dropped_and_counted() {
    let now = Instant::now();
    let mut hub = hub_with(HubConfig::default(), now);
    let flood = format!("@ <hub> 0\ncookie v {}\nsubscribe ch x\n", Cookie::NONE);
    for _ in 0..10_000 {
        hub.handle(now, addr(3), flood.as_bytes());
    }
    let cookies = replies(&mut hub).len() as f64;
    assert!(
        cookies <= HubConfig::default().control_burst,
        "{cookies} cookies"
    );
    assert!(hub.drops(DropReason::RateLimited) >= 9_000);
    // Other sources are not held back by it.
    join(&mut hub, now, addr(4), "subscribe ch x\n");
    assert_eq!(hub.client_count(), 1);
}

#[test]
fn status_with_4096_clients_of_256_subscriptions_costs_one_datagram_of_work() {
    let now = Instant::now();
    let mut hub = hub_with(HubConfig::default(), now);
    let subs: String = (0..256)
        .map(|i| format!("subscribe ch channel_{i:03}\n"))
        .collect();
    for port in 0..4096u16 {
        join(&mut hub, now, addr(20_000 + port), &subs);
    }
    replies(&mut hub);
    assert_eq!(hub.client_count(), 4096);
    let report = hub.status(now);
    assert_eq!(report.client_count, 4096);
    assert!(report.truncated);
    // Only what fits one datagram is built, so its cost does not grow with the table.
    let built: usize = report.clients.iter().map(|c| c.subscriptions.len()).sum();
    assert!(built < 256 * 32, "{built} subscriptions formatted");
    let packet = report.to_packet();
    assert!(packet.len() <= colony_wire::MAX_PACKET);
    let back = StatusReport::from_packet(&Packet::parse(&packet).unwrap()).unwrap();
    assert_eq!(back.client_count, 4096);
}
