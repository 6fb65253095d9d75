//! The hub as a state machine: no sockets, time driven by hand.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use colony_hub::{DropReason, Hub, HubConfig, Outcome};
use colony_wire::{Cookie, Packet, Reply, StatusReport};

fn addr(port: u16) -> SocketAddr {
    SocketAddr::from(([127, 0, 0, 1], port))
}

/// The cookie the hub gives `who` now (by asking as a new client would).
fn cookie(hub: &mut Hub, now: Instant, who: SocketAddr) -> Cookie {
    while hub.poll_transmit().is_some() {} // answers to earlier requests
    let ask = format!("@ <hub> 0\ncookie v {}\nstatus\n", Cookie::NONE);
    assert_eq!(hub.handle(now, who, ask.as_bytes()), Outcome::Control);
    let reply = hub.poll_transmit().expect("a cookie for a new address");
    assert_eq!(reply.dest, who);
    match Reply::parse(&Packet::parse(&reply.payload).unwrap()) {
        Some(Ok(Reply::Cookie(c))) => c,
        other => panic!("expected a cookie, got {other:?}"),
    }
}

/// Sends control lines from `who` with the cookie the hub gave it.
fn control(hub: &mut Hub, now: Instant, who: SocketAddr, lines: &str) {
    let c = cookie(hub, now, who);
    let text = format!("@ <hub> 0\ncookie v {c}\n{lines}");
    assert_eq!(hub.handle(now, who, text.as_bytes()), Outcome::Control);
}

fn subscribe(hub: &mut Hub, now: Instant, who: SocketAddr, subjects: &[&str]) {
    let lines: String = subjects
        .iter()
        .map(|s| format!("subscribe ch {s}\n"))
        .collect();
    control(hub, now, who, &lines);
}

fn forwarded(hub: &mut Hub, now: Instant, from: SocketAddr, packet: &str) -> Vec<SocketAddr> {
    match hub.handle(now, from, packet.as_bytes()) {
        Outcome::Forward { dests, .. } => {
            let mut d = dests.to_vec();
            d.sort();
            d
        }
        other => panic!("expected a forward, got {other:?}"),
    }
}

fn replies(hub: &mut Hub) -> Vec<(SocketAddr, Vec<u8>)> {
    std::iter::from_fn(|| hub.poll_transmit())
        .map(|t| (t.dest, t.payload))
        .collect()
}

#[test]
fn a_published_packet_reaches_every_subscriber_of_its_channel() {
    let now = Instant::now();
    let mut hub = Hub::new(HubConfig::default(), now);
    for p in 1..=3 {
        subscribe(&mut hub, now, addr(p), &["vision"]);
    }
    subscribe(&mut hub, now, addr(4), &["radio"]);
    assert_eq!(
        forwarded(&mut hub, now, addr(9), "@ <vision> 0\nball x 1\n"),
        [addr(1), addr(2), addr(3)]
    );
    assert_eq!(
        forwarded(&mut hub, now, addr(9), "@ <radio> 0\ncmd id 1\n"),
        [addr(4)]
    );
    assert_eq!(
        forwarded(&mut hub, now, addr(9), "@ <nobody> 0\nx a 1\n"),
        Vec::<SocketAddr>::new()
    );
}

#[test]
fn a_subject_set_reaches_only_clients_subscribed_to_all_of_it() {
    let now = Instant::now();
    let mut hub = Hub::new(HubConfig::default(), now);
    subscribe(&mut hub, now, addr(1), &["mobile", "camera", "laser"]);
    subscribe(&mut hub, now, addr(2), &["mobile", "camera"]);
    subscribe(&mut hub, now, addr(3), &["mobile"]);
    subscribe(&mut hub, now, addr(4), &["camera", "laser"]);
    let task = "@ <mobile> <camera> <laser> 0\ntask name \"find-box\"\n";
    assert_eq!(forwarded(&mut hub, now, addr(9), task), [addr(1)]);
    assert_eq!(
        forwarded(&mut hub, now, addr(9), "@ <camera> <mobile> 0\nt x 1\n"),
        [addr(1), addr(2)]
    );
    assert_eq!(
        forwarded(&mut hub, now, addr(9), "@ <mobile> 0\nt x 1\n"),
        [addr(1), addr(2), addr(3)]
    );
}

#[test]
fn a_subscriber_that_stops_refreshing_is_forgotten_after_its_lease() {
    let start = Instant::now();
    let config = HubConfig {
        lease: Duration::from_secs(10),
        ..HubConfig::default()
    };
    let mut hub = Hub::new(config, start);
    subscribe(&mut hub, start, addr(1), &["vision"]);
    subscribe(&mut hub, start, addr(2), &["vision"]);
    // Client 2 refreshes; client 1 does not.
    for s in 1..=12 {
        let now = start + Duration::from_secs(s);
        if s % 3 == 0 {
            subscribe(&mut hub, now, addr(2), &["vision"]);
        }
        hub.handle_timeout(now);
    }
    let now = start + Duration::from_secs(12);
    assert_eq!(
        forwarded(&mut hub, now, addr(9), "@ <vision> 0\nb x 1\n"),
        [addr(2)]
    );
    assert_eq!(hub.client_count(), 1);
}

#[test]
fn timeouts_come_often_enough_to_end_leases_nearly_on_time() {
    let start = Instant::now();
    let hub = Hub::new(
        HubConfig {
            lease: Duration::from_secs(10),
            ..HubConfig::default()
        },
        start,
    );
    assert!(hub.poll_timeout() <= start + Duration::from_secs(1));
}

/// A hub that takes operator requests from `addr(7)`.
fn with_console(now: Instant) -> Hub {
    let config = HubConfig {
        consoles: vec!["127.0.0.1:7".parse().unwrap()],
        ..HubConfig::default()
    };
    Hub::new(config, now)
}

#[test]
fn packets_below_the_minimum_priority_are_dropped_on_every_channel() {
    let now = Instant::now();
    let mut hub = with_console(now);
    subscribe(&mut hub, now, addr(1), &["radio", "vision"]);
    control(&mut hub, now, addr(7), "min_priority value 5\n");
    assert_eq!(
        hub.handle(now, addr(8), b"@ <radio> 0\ncmd id 1\n"),
        Outcome::Dropped(DropReason::BelowMinPriority)
    );
    assert_eq!(
        hub.handle(now, addr(8), b"@ <vision> 4\nball x 1\n"),
        Outcome::Dropped(DropReason::BelowMinPriority)
    );
    assert_eq!(
        forwarded(&mut hub, now, addr(7), "@ <radio> 5\ncmd id 1\n"),
        [addr(1)]
    );
    assert_eq!(
        forwarded(&mut hub, now, addr(7), "@ <radio> 9\ncmd id 1\n"),
        [addr(1)]
    );
    assert_eq!(hub.drops(DropReason::BelowMinPriority), 2);
    // Control requests are never filtered, or nobody could subscribe again.
    subscribe(&mut hub, now, addr(2), &["radio"]);
    control(&mut hub, now, addr(7), "min_priority value -2147483648\n");
    assert_eq!(
        forwarded(&mut hub, now, addr(8), "@ <radio> 0\ncmd id 1\n"),
        [addr(1), addr(2)]
    );
}

#[test]
fn malformed_packets_are_counted_and_do_not_disturb_routing() {
    let now = Instant::now();
    let mut hub = Hub::new(HubConfig::default(), now);
    subscribe(&mut hub, now, addr(1), &["vision"]);
    let junk: [&[u8]; 5] = [
        b"",
        b"garbage",
        b"@ <vision> 0\nx a 1 a 2\n",
        b"@ <vision> 0\nx a (b 1\n",
        b"\xff\xfe",
    ];
    for j in junk {
        assert_eq!(
            hub.handle(now, addr(6), j),
            Outcome::Dropped(DropReason::Malformed)
        );
    }
    assert_eq!(hub.drops(DropReason::Malformed), 5);
    assert_eq!(
        forwarded(&mut hub, now, addr(6), "@ <vision> 0\nball x 1\n"),
        [addr(1)]
    );
}

#[test]
fn unknown_control_requests_are_dropped_as_bad_control() {
    let now = Instant::now();
    let mut hub = Hub::new(HubConfig::default(), now);
    for bad in [
        "@ <hub> 0\nreboot now 1\n",
        "@ <hub> 0\nsubscribe\n",
        "@ <hub> <x> 0\nstatus\n",
        "@ <hub> 0\nsubscribe ch hub\n",
    ] {
        assert_eq!(
            hub.handle(now, addr(1), bad.as_bytes()),
            Outcome::Dropped(DropReason::BadControl),
            "{bad}"
        );
    }
    assert_eq!(hub.client_count(), 0);
}

#[test]
fn a_subscription_is_acknowledged_with_the_lease_time() {
    let now = Instant::now();
    let mut hub = Hub::new(HubConfig::default(), now);
    subscribe(&mut hub, now, addr(1), &["vision"]);
    let r = replies(&mut hub);
    assert_eq!(r.len(), 1);
    assert_eq!(r[0].0, addr(1));
    let p = Packet::parse(&r[0].1).unwrap();
    assert!(matches!(
        Reply::parse(&p),
        Some(Ok(Reply::Lease { ms: 10_000 }))
    ));
}

#[test]
fn unsubscribing_stops_delivery_and_unsubscribe_all_forgets_the_client() {
    let now = Instant::now();
    let mut hub = Hub::new(HubConfig::default(), now);
    subscribe(&mut hub, now, addr(1), &["a", "b"]);
    control(&mut hub, now, addr(1), "unsubscribe ch a\n");
    assert!(forwarded(&mut hub, now, addr(9), "@ <a> 0\nx y 1\n").is_empty());
    assert_eq!(
        forwarded(&mut hub, now, addr(9), "@ <b> 0\nx y 1\n"),
        [addr(1)]
    );
    control(&mut hub, now, addr(1), "unsubscribe_all\n");
    assert!(forwarded(&mut hub, now, addr(9), "@ <b> 0\nx y 1\n").is_empty());
    assert_eq!(hub.client_count(), 0);
}

#[test]
fn status_is_answered_only_to_a_source_that_returned_its_cookie() {
    let now = Instant::now();
    let mut hub = Hub::new(HubConfig::default(), now);
    // A stranger (or a forged source) asking for status gets nothing: its
    // request is shorter than a cookie.
    hub.handle(now, addr(5), b"@ <hub> 0\nstatus\n");
    assert!(replies(&mut hub).is_empty());
    // It is counted, so a person who typed it can see why nothing came back.
    assert_eq!(hub.drops(DropReason::Unproven), 1);
    // A longer hand-typed request, with no cookie line at all, gets one.
    hub.handle(
        now,
        addr(7),
        b"@ <hub> 0\nsubscribe ch a_channel_with_a_long_name\n",
    );
    let r = replies(&mut hub);
    assert_eq!(r.len(), 1);
    assert!(std::str::from_utf8(&r[0].1).unwrap().contains("cookie v "));
    assert_eq!(hub.drops(DropReason::Unproven), 1);
    // With room for one, it gets a cookie and nothing more.
    let c = cookie(&mut hub, now, addr(5));
    assert!(replies(&mut hub).is_empty());
    // Back with its cookie, it gets the report, no lease needed.
    let ask = format!("@ <hub> 0\ncookie v {c}\nstatus\n");
    hub.handle(now, addr(5), ask.as_bytes());
    let r = replies(&mut hub);
    assert_eq!(r.len(), 1);
    let report = StatusReport::from_packet(&Packet::parse(&r[0].1).unwrap()).unwrap();
    assert_eq!(report.client_count, 0);
    // A cookie is good for its own address only.
    hub.handle(now, addr(6), ask.as_bytes());
    let r = replies(&mut hub);
    assert!(
        r.iter().all(|(_, p)| p.len() <= ask.len()),
        "a cookie at most"
    );
    assert_eq!(hub.drops(DropReason::BadCookie), 1);
}

#[test]
fn the_lease_ack_to_a_new_address_is_never_larger_than_the_request() {
    let now = Instant::now();
    let mut hub = Hub::new(HubConfig::default(), now);
    let request = b"@ <hub> 0\nsubscribe ch a\n";
    hub.handle(now, addr(1), request);
    for (_, payload) in replies(&mut hub) {
        assert!(
            payload.len() <= request.len(),
            "{} > {}",
            payload.len(),
            request.len()
        );
    }
}

#[test]
fn status_requests_within_the_interval_are_served_from_one_report() {
    let now = Instant::now();
    let mut hub = Hub::new(HubConfig::default(), now);
    subscribe(&mut hub, now, addr(1), &["x"]);
    let c = cookie(&mut hub, now, addr(1));
    let ask = format!("@ <hub> 0\ncookie v {c}\nstatus\n");
    hub.handle(now, addr(1), ask.as_bytes());
    let first = replies(&mut hub);
    subscribe(&mut hub, now, addr(2), &["x"]);
    replies(&mut hub);
    for _ in 0..10 {
        hub.handle(now, addr(1), ask.as_bytes());
    }
    let again = replies(&mut hub);
    assert_eq!(again.len(), 10, "each verified request is answered");
    assert!(
        again.iter().all(|r| r.1 == first[0].1),
        "from the one report"
    );
    let later = now + Duration::from_millis(150);
    hub.handle(later, addr(1), ask.as_bytes());
    let r = replies(&mut hub);
    let report = StatusReport::from_packet(&Packet::parse(&r[0].1).unwrap()).unwrap();
    assert_eq!(
        report.client_count, 2,
        "a new report once the interval passed"
    );
}

#[test]
fn status_reports_channels_and_drops() {
    let now = Instant::now();
    let mut hub = Hub::new(HubConfig::default(), now);
    subscribe(&mut hub, now, addr(1), &["vision"]);
    hub.handle(now, addr(2), b"@ <vision> 0\nball x 1\n");
    hub.handle(now, addr(2), b"@ <vision> <radio> 0\nball x 1\n");
    hub.handle(now, addr(2), b"nonsense");
    let s = hub.status(now);
    let vision = s.channels.iter().find(|c| c.subjects == "vision").unwrap();
    assert_eq!((vision.packets, vision.bytes), (1, 22));
    assert!(s.channels.iter().any(|c| c.subjects == "vision radio"));
    assert_eq!(s.drops, [("malformed".to_string(), 1)]);
}

#[test]
fn memory_stays_bounded_under_hostile_input() {
    let now = Instant::now();
    let config = HubConfig {
        max_clients: 8,
        max_subscriptions: 4,
        max_channels: 16,
        ..HubConfig::default()
    };
    let mut hub = Hub::new(config, now);
    for p in 0..100u16 {
        subscribe(
            &mut hub,
            now,
            addr(1000 + p),
            &["a", "b", "c", "d", "e", "f"],
        );
    }
    assert_eq!(hub.client_count(), 8);
    assert!(hub.drops(DropReason::TooManyClients) >= 92);
    assert!(hub.drops(DropReason::TooManySubscriptions) >= 16);
    for i in 0..1000 {
        hub.handle(now, addr(1), format!("@ <chan{i}> 0\nx y 1\n").as_bytes());
    }
    let s = hub.status(now);
    assert_eq!(s.channels.len(), 17, "16 named channels and `*other*`");
    assert_eq!(s.channels.iter().map(|c| c.packets).sum::<u64>(), 1000);
    assert!(s.clients.iter().all(|c| c.subscriptions.len() <= 4));
}

#[test]
fn a_subscriber_of_its_own_channel_gets_its_own_packets() {
    let now = Instant::now();
    let mut hub = Hub::new(HubConfig::default(), now);
    subscribe(&mut hub, now, addr(1), &["chat"]);
    assert_eq!(
        forwarded(&mut hub, now, addr(1), "@ <chat> 0\nsay text \"hi\"\n"),
        [addr(1)]
    );
}

#[test]
fn a_no_local_client_hears_everyone_but_itself_for_as_long_as_its_lease() {
    let now = Instant::now();
    let mut hub = Hub::new(HubConfig::default(), now);
    subscribe(&mut hub, now, addr(1), &["a"]);
    control(
        &mut hub,
        now,
        addr(2),
        "subscribe ch a\nsubscribe ch b\nno_local\n",
    );
    let plain = "@ <a> 0\nx v 1\n";
    assert_eq!(forwarded(&mut hub, now, addr(1), plain), [addr(1), addr(2)]);
    assert_eq!(forwarded(&mut hub, now, addr(2), plain), [addr(1)]);
    assert_eq!(
        forwarded(&mut hub, now, addr(2), "@ <a> <b> 0\nx v 1\n"),
        []
    );
    // Forgotten with the lease: subscribed again without it, the client hears itself.
    let later = now + HubConfig::default().lease * 2;
    hub.handle_timeout(later);
    subscribe(&mut hub, later, addr(2), &["a"]);
    assert_eq!(forwarded(&mut hub, later, addr(2), plain), [addr(2)]);
}

#[test]
fn a_tap_hears_every_forwarded_packet_once_for_as_long_as_its_lease() {
    let now = Instant::now();
    let mut hub = Hub::new(HubConfig::default(), now);
    subscribe(&mut hub, now, addr(1), &["a"]);
    // Without a lease a tap is not kept: a stranger holds no state.
    control(&mut hub, now, addr(2), "tap\n");
    assert_eq!(
        forwarded(&mut hub, now, addr(1), "@ <a> 0\nx v 1\n"),
        [addr(1)]
    );
    control(&mut hub, now, addr(2), "subscribe ch a\ntap\n");
    // Subscribed as well: one copy. Nobody else subscribed: the tap still hears it.
    assert_eq!(
        forwarded(&mut hub, now, addr(1), "@ <a> 0\nx v 1\n"),
        [addr(1), addr(2)]
    );
    assert_eq!(
        forwarded(&mut hub, now, addr(1), "@ <new> <set> 0\nx v 1\n"),
        [addr(2)]
    );
    // Forgotten with its lease: a tap must be renewed like a subscription.
    let later = now + HubConfig::default().lease * 2;
    hub.handle_timeout(later);
    subscribe(&mut hub, later, addr(1), &["a"]);
    assert_eq!(forwarded(&mut hub, later, addr(1), "@ <b> 0\nx v 1\n"), []);
}

/// Port `port` of host 10.0.0.`host`.
fn on_host(host: u8, port: u16) -> SocketAddr {
    SocketAddr::from(([10, 0, 0, host], port))
}

#[test]
fn a_hub_lets_only_a_few_clients_tap_few_from_one_host_and_frees_a_place_when_one_goes() {
    let now = Instant::now();
    let config = HubConfig {
        consoles: vec!["10.0.0.99".parse().unwrap()],
        ..HubConfig::default()
    };
    let mut hub = Hub::new(config, now);
    let max = colony_hub::MAX_TAPS as u8;
    // One host with many ports holds two places at most.
    for port in 0..4 {
        control(
            &mut hub,
            now,
            on_host(1, 100 + port),
            "subscribe ch a\ntap\n",
        );
    }
    assert_eq!(hub.drops(DropReason::TooManyTaps), 2);
    let heard = forwarded(&mut hub, now, addr(1), "@ <b> 0\nx v 1\n");
    assert_eq!(heard, [on_host(1, 100), on_host(1, 101)]);
    // Other hosts fill the rest; the next is refused.
    for host in 2..max {
        control(&mut hub, now, on_host(host, 100), "subscribe ch a\ntap\n");
    }
    control(&mut hub, now, on_host(50, 100), "subscribe ch a\ntap\n");
    assert_eq!(hub.drops(DropReason::TooManyTaps), 3);
    let heard = forwarded(&mut hub, now, addr(1), "@ <b> 0\nx v 1\n");
    assert_eq!(heard.len(), max as usize);
    assert!(!heard.contains(&on_host(50, 100)));
    // One tap lets go of its lease at once: the next may take its place.
    control(&mut hub, now, on_host(2, 100), "unsubscribe_all\n");
    control(&mut hub, now, on_host(50, 100), "tap\n");
    let heard = forwarded(&mut hub, now, addr(1), "@ <b> 0\nx v 1\n");
    assert!(heard.contains(&on_host(50, 100)) && !heard.contains(&on_host(2, 100)));
    // Full again: a console still gets a place, the oldest other tap's.
    control(&mut hub, now, on_host(99, 100), "subscribe ch a\ntap\n");
    let heard = forwarded(&mut hub, now, addr(1), "@ <b> 0\nx v 1\n");
    assert_eq!(heard.len(), max as usize);
    assert!(heard.contains(&on_host(99, 100)) && !heard.contains(&on_host(1, 100)));
    // And the status report says who taps.
    control(&mut hub, now, on_host(99, 100), "status\n");
    let r = replies(&mut hub);
    let report = StatusReport::from_packet(&Packet::parse(&r.last().unwrap().1).unwrap()).unwrap();
    let tapping = |who: SocketAddr| {
        report
            .clients
            .iter()
            .find(|c| c.addr == who.to_string())
            .unwrap()
            .tap
    };
    assert!(tapping(on_host(99, 100)) && !tapping(on_host(1, 100)));
}

#[test]
fn a_clients_about_text_is_kept_with_its_lease_cut_to_length_and_shown_in_status() {
    let now = Instant::now();
    let mut hub = Hub::new(HubConfig::default(), now);
    // Before any lease, the words are not kept: a stranger holds no state.
    control(&mut hub, now, addr(1), "about text \"early\"\n");
    let long = "x".repeat(1000);
    control(
        &mut hub,
        now,
        addr(1),
        &format!("subscribe ch a\nabout text \"bridge site lab {long}\"\n"),
    );
    control(&mut hub, now, addr(3), "subscribe ch a\n");
    while hub.poll_transmit().is_some() {}
    let c = cookie(&mut hub, now + Duration::from_secs(1), addr(3));
    let ask = format!("@ <hub> 0\ncookie v {c}\nstatus\n");
    hub.handle(now + Duration::from_secs(1), addr(3), ask.as_bytes());
    let r = replies(&mut hub);
    let report = StatusReport::from_packet(&Packet::parse(&r.last().unwrap().1).unwrap()).unwrap();
    let bridge = report
        .clients
        .iter()
        .find(|c| c.addr == addr(1).to_string())
        .unwrap();
    assert!(
        bridge.about.starts_with("bridge site lab xxx"),
        "{:?}",
        bridge.about
    );
    assert_eq!(bridge.about.len(), colony_wire::MAX_ABOUT);
    let plain = report
        .clients
        .iter()
        .find(|c| c.addr == addr(3).to_string())
        .unwrap();
    assert_eq!(plain.about, "");
}

#[test]
fn a_batch_size_is_kept_only_with_a_lease_shown_in_status_and_forgotten_with_it() {
    let start = Instant::now();
    let config = HubConfig {
        lease: Duration::from_secs(10),
        ..HubConfig::default()
    };
    let mut hub = Hub::new(config, start);
    // Asked without a lease: nothing is kept for an unsubscribed address.
    control(&mut hub, start, addr(1), "batch bytes 1400\n");
    assert_eq!(hub.batch_bytes(&addr(1)), 0);
    control(
        &mut hub,
        start,
        addr(1),
        "subscribe ch a\nbatch bytes 1400\n",
    );
    assert_eq!(hub.batch_bytes(&addr(1)), 1400);
    // Past the largest datagram: the largest.
    control(&mut hub, start, addr(1), "batch bytes 1000000\n");
    assert_eq!(hub.batch_bytes(&addr(1)), colony_wire::MAX_PACKET);
    control(&mut hub, start, addr(1), "status\n");
    let r = replies(&mut hub);
    let report = StatusReport::from_packet(&Packet::parse(&r.last().unwrap().1).unwrap()).unwrap();
    assert_eq!(report.clients[0].batch, colony_wire::MAX_PACKET);
    // The lease lapses, and the size with it: a new client at the address
    // gets one packet a datagram until it asks.
    let later = start + Duration::from_secs(30);
    hub.handle_timeout(later);
    assert_eq!(hub.client_count(), 0);
    subscribe(&mut hub, later, addr(1), &["a"]);
    assert_eq!(hub.batch_bytes(&addr(1)), 0);
}
