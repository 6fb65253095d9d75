//! The client session's timing, with time driven by hand.

use std::time::{Duration, Instant};

use colony_client::{ClientConfig, HubState, Session};
use colony_wire::auth::Key;
use colony_wire::{Cookie, Packet, Reply, Request, Subject};

fn subject(s: &str) -> Subject {
    Subject::new(s).unwrap()
}

/// Every request the session sends by `now`, after running its timers
/// (less the cookie line each of its packets carries).
fn sent(session: &mut Session, now: Instant) -> Vec<Request> {
    session.handle_timeout(now);
    drain(session)
}

fn drain(session: &mut Session) -> Vec<Request> {
    std::iter::from_fn(|| session.poll_transmit())
        .flat_map(|d| Request::parse_all(&Packet::parse(&d).unwrap()).unwrap())
        .filter(|r| !matches!(r, Request::Cookie(_)))
        .collect()
}

fn data(session: &mut Session, now: Instant, channel: &str) {
    let text = format!("@ <{channel}> 0\nx y 1\n");
    session.handle_datagram(now, text.as_bytes()).unwrap();
}

#[test]
fn a_new_subscription_is_requested_at_once_in_one_packet() {
    let t0 = Instant::now();
    let mut s = Session::new(ClientConfig::default(), t0);
    s.subscribe(t0, subject("vision"));
    s.subscribe(t0, subject("radio"));
    s.handle_timeout(t0);
    let datagram = s.poll_transmit().expect("a subscribe request");
    assert!(
        s.poll_transmit().is_none(),
        "both subscriptions in one datagram"
    );
    let reqs = Request::parse_all(&Packet::parse(&datagram).unwrap()).unwrap();
    assert_eq!(
        reqs,
        [
            Request::Cookie(Cookie::NONE),
            Request::Subscribe(subject("vision")),
            Request::Subscribe(subject("radio"))
        ]
    );
}

#[test]
fn a_cookie_from_the_hub_has_everything_asked_again_at_once_with_it() {
    let t0 = Instant::now();
    let mut s = Session::new(ClientConfig::default(), t0);
    s.subscribe(t0, subject("vision"));
    sent(&mut s, t0);
    s.request(&[Request::Status]);
    drain(&mut s);
    let t1 = t0 + Duration::from_millis(5);
    let cookie = Cookie(0xfeed_beef_0000_0001);
    s.handle_datagram(t1, &Reply::cookie_packet(cookie))
        .unwrap();
    assert_eq!(s.cookie(), Some(cookie));
    let again: Vec<Vec<Request>> = std::iter::from_fn(|| s.poll_transmit())
        .map(|d| Request::parse_all(&Packet::parse(&d).unwrap()).unwrap())
        .collect();
    assert_eq!(
        again,
        [
            vec![Request::Cookie(cookie), Request::Status],
            vec![
                Request::Cookie(cookie),
                Request::Subscribe(subject("vision"))
            ],
        ]
    );
    // The same cookie again (the hub refused it for a reason of its own) is no loop.
    s.handle_datagram(t1, &Reply::cookie_packet(cookie))
        .unwrap();
    assert!(s.poll_transmit().is_none());
    // A request made long before a cookie arrives is not repeated.
    s.request(&[Request::UnsubscribeAll]);
    drain(&mut s);
    let late = t1 + Duration::from_secs(10);
    s.subscribe(late, subject("radio"));
    sent(&mut s, late);
    s.handle_datagram(late, &Reply::cookie_packet(Cookie(7)))
        .unwrap();
    assert_eq!(s.cookie(), Some(Cookie(7)));
    assert!(drain(&mut s).iter().all(|r| *r != Request::UnsubscribeAll));
}

#[test]
fn forged_cookies_and_leases_cannot_set_a_client_spinning() {
    let t0 = Instant::now();
    let mut s = Session::new(ClientConfig::default(), t0);
    s.subscribe(t0, subject("vision"));
    sent(&mut s, t0);
    // Two cookies alternating, as fast as a forger can send them: one taken
    // per quarter second, so one resend per quarter second at most.
    let mut resent = 0;
    for i in 0..1000u64 {
        let at = t0 + Duration::from_millis(i);
        s.handle_datagram(at, &Reply::cookie_packet(Cookie(1 + i % 2)))
            .unwrap();
        resent += drain(&mut s).len();
    }
    assert!(resent <= 4, "{resent} requests resent in one second");
    // A cookie nobody asked for (nothing sent lately) is not taken.
    let quiet = t0 + Duration::from_secs(60);
    s.handle_datagram(quiet, &Reply::cookie_packet(Cookie(99)))
        .unwrap();
    assert_ne!(s.cookie(), Some(Cookie(99)));
    // `lease ms 0` is read as the shortest lease a hub grants.
    s.handle_datagram(quiet, b"@ <hub> 0\nlease ms 0\n")
        .unwrap();
    assert!(s.refresh_interval() >= Duration::from_millis(30));
}

#[test]
fn a_session_with_a_key_signs_every_datagram() {
    let t0 = Instant::now();
    let key = Key::new(b"a key for the session tests, 32b").unwrap();
    let mut s = Session::new(ClientConfig::default(), t0);
    s.set_key(key.clone());
    s.subscribe(t0, subject("vision"));
    s.request(&[Request::MinPriority(colony_wire::Priority(4))]);
    s.handle_timeout(t0);
    let mut last = 0;
    let mut count = 0;
    while let Some(d) = s.poll_transmit() {
        let signed = key.verify(&d).expect("signed");
        assert!(signed.n > last, "counters increase");
        last = signed.n;
        count += 1;
    }
    assert_eq!(count, 2);
}

#[test]
fn a_flowing_channel_is_refreshed_every_refresh_interval() {
    let t0 = Instant::now();
    let config = ClientConfig::default();
    let mut s = Session::new(config.clone(), t0);
    s.subscribe(t0, subject("vision"));
    assert_eq!(sent(&mut s, t0).len(), 1);
    let mut refreshes = 0;
    // Data every 100 ms for 10 s: refreshes come every `refresh`, no sooner.
    for step in 1..=100 {
        let now = t0 + Duration::from_millis(100 * step);
        data(&mut s, now, "vision");
        refreshes += sent(&mut s, now).len();
    }
    assert_eq!(refreshes, (10.0 / config.refresh.as_secs_f64()) as usize);
}

#[test]
fn a_silent_channel_is_resubscribed_after_the_silence_interval() {
    let t0 = Instant::now();
    let mut s = Session::new(ClientConfig::default(), t0);
    s.subscribe(t0, subject("vision"));
    sent(&mut s, t0);
    data(&mut s, t0 + Duration::from_millis(100), "vision");
    // The hub restarts: nothing arrives. Within a second and a bit, we ask again.
    assert!(sent(&mut s, t0 + Duration::from_millis(1000)).is_empty());
    assert_eq!(
        sent(&mut s, t0 + Duration::from_millis(1100)),
        [Request::Subscribe(subject("vision"))]
    );
    // And keep asking every second while it stays silent.
    assert_eq!(sent(&mut s, t0 + Duration::from_millis(2100)).len(), 1);
    assert!(s.poll_timeout().unwrap() <= t0 + Duration::from_millis(3100));
}

#[test]
fn only_the_silent_channel_is_resubscribed() {
    let t0 = Instant::now();
    let mut s = Session::new(ClientConfig::default(), t0);
    s.subscribe(t0, subject("vision"));
    s.subscribe(t0, subject("radio"));
    sent(&mut s, t0);
    for step in 1..=15 {
        let now = t0 + Duration::from_millis(100 * step);
        data(&mut s, now, "vision");
        let reqs = sent(&mut s, now);
        assert!(
            reqs.iter()
                .all(|r| *r == Request::Subscribe(subject("radio"))),
            "{reqs:?}"
        );
    }
}

#[test]
fn a_subject_set_packet_counts_as_data_for_each_of_its_subjects() {
    let t0 = Instant::now();
    let mut s = Session::new(ClientConfig::default(), t0);
    s.subscribe(t0, subject("mobile"));
    s.subscribe(t0, subject("camera"));
    sent(&mut s, t0);
    for step in 1..=15 {
        let now = t0 + Duration::from_millis(100 * step);
        s.handle_datagram(now, b"@ <mobile> <camera> 0\ntask x 1\n")
            .unwrap();
        assert!(sent(&mut s, now).is_empty());
    }
}

#[test]
fn the_hub_is_unreachable_after_the_configured_silence_and_alive_when_heard() {
    let t0 = Instant::now();
    let config = ClientConfig {
        unreachable_after: Duration::from_secs(10),
        ..ClientConfig::default()
    };
    let mut s = Session::new(config, t0);
    s.subscribe(t0, subject("vision"));
    assert_eq!(s.hub_state(t0 + Duration::from_secs(5)), HubState::Unknown);
    assert!(matches!(
        s.hub_state(t0 + Duration::from_secs(10)),
        HubState::Unreachable { .. }
    ));
    s.handle_datagram(t0 + Duration::from_secs(11), &Reply::lease_packet(10_000))
        .unwrap();
    assert_eq!(s.hub_state(t0 + Duration::from_secs(12)), HubState::Alive);
    assert_eq!(s.lease(), Some(Duration::from_secs(10)));
}

#[test]
fn unsubscribing_sends_the_request_and_stops_the_refreshes() {
    let t0 = Instant::now();
    let mut s = Session::new(ClientConfig::default(), t0);
    s.subscribe(t0, subject("vision"));
    sent(&mut s, t0);
    s.unsubscribe(&subject("vision"));
    assert_eq!(sent(&mut s, t0), [Request::Unsubscribe(subject("vision"))]);
    assert!(sent(&mut s, t0 + Duration::from_secs(60)).is_empty());
    assert_eq!(s.poll_timeout(), None);
}

#[test]
fn refreshes_come_at_least_three_times_per_lease_the_hub_announces() {
    let t0 = Instant::now();
    let mut s = Session::new(ClientConfig::default(), t0);
    s.subscribe(t0, subject("vision"));
    sent(&mut s, t0);
    s.handle_datagram(t0, &Reply::lease_packet(1_000)).unwrap();
    let mut last = t0;
    let mut longest = Duration::ZERO;
    for step in 1..=30 {
        let now = t0 + Duration::from_millis(100 * step);
        data(&mut s, now, "vision");
        if !sent(&mut s, now).is_empty() {
            longest = longest.max(now - last);
            last = now;
        }
    }
    // Under a 1 s lease, refreshes every third of a second (plus one 100 ms
    // step of this test's clock), never the configured 3 s.
    assert!(
        longest <= Duration::from_millis(400),
        "a gap of {longest:?} between refreshes"
    );
    assert!(t0 + Duration::from_secs(3) - last <= Duration::from_millis(400));
}
