use super::message::{proven, AnswerHeader, CallHeader, Notice, Said};
use super::*;
use colony_wire::seal::{self, Identity};
use colony_wire::{Packet, Priority};
use std::time::Instant;

const LEASE: Duration = Duration::from_secs(3);
const TIMEOUT: Duration = Duration::from_secs(5);

fn key(seed: u8) -> Identity {
    Identity::from_seed([seed; 32])
}

fn provider(seed: u8, now: Instant) -> Provider {
    Provider::with_identity("echo", key(seed), LEASE, now).unwrap()
}

fn parse(bytes: &[u8]) -> Packet<'_> {
    Packet::parse(bytes).unwrap()
}

fn service() -> Service {
    Service::new("echo").unwrap()
}

/// Delivers what each side sends to the sides subscribed to its subject,
/// as a hub would, until nothing more is sent. Providers answer each call
/// they take at once with its lines (or refuse it when its first line
/// starts with `fail`), unless muted.
struct Net {
    caller: Caller,
    providers: Vec<Provider>,
    ids: Vec<Id>,
    /// Providers that take nothing and say nothing (dead).
    dead: Vec<bool>,
    /// Providers that take calls (and say `accepted`) but never answer.
    mute: Vec<bool>,
    taken: Vec<Vec<Id>>,
}

impl Net {
    fn new(providers: usize, now: Instant) -> Net {
        let providers: Vec<Provider> = (0..providers)
            .map(|i| provider(100 + i as u8, now))
            .collect();
        Net {
            caller: Caller::with_id("echo", Id(7)).unwrap(),
            ids: providers.iter().map(Provider::id).collect(),
            dead: vec![false; providers.len()],
            mute: vec![false; providers.len()],
            taken: vec![Vec::new(); providers.len()],
            providers,
        }
    }

    fn run(&mut self, now: Instant) {
        loop {
            let mut sent = Vec::new();
            while let Some(p) = self.caller.poll_transmit() {
                sent.push(p);
            }
            for (i, prov) in self.providers.iter_mut().enumerate() {
                while let Some(p) = prov.poll_transmit() {
                    if !self.dead[i] {
                        sent.push(p);
                    }
                }
            }
            if sent.is_empty() {
                return;
            }
            for bytes in &sent {
                self.deliver(now, bytes);
            }
        }
    }

    fn deliver(&mut self, now: Instant, bytes: &[u8]) {
        let packet = parse(bytes);
        if self
            .caller
            .subjects()
            .iter()
            .any(|s| packet.has_subject(s.as_str()))
        {
            self.caller.handle_packet(now, &packet);
        }
        for (i, prov) in self.providers.iter_mut().enumerate() {
            let wants = prov
                .subjects()
                .iter()
                .any(|s| packet.has_subject(s.as_str()));
            if self.dead[i] || !wants {
                continue;
            }
            if let Some(call) = prov.handle_packet(now, &packet) {
                self.taken[i].push(call.id());
                if self.mute[i] {
                    continue;
                }
                let lines: Vec<String> = call.lines().map(|l| l.as_str().to_owned()).collect();
                let ticket = call.ticket();
                if lines.first().is_some_and(|l| l.starts_with("fail")) {
                    prov.refuse(&ticket, "asked to fail");
                } else {
                    prov.answer(&ticket, &lines).unwrap();
                }
            }
        }
    }

    /// Makes a call and holds it back: the provider it goes to (which the
    /// test may now silence) and the packet, to [`deliver`](Net::deliver).
    fn call_held(&mut self, now: Instant, timeout: Duration) -> (Id, usize, Vec<u8>) {
        let id = self.caller.call(now, Priority(0), &["x"], timeout).unwrap();
        let packet = self.caller.poll_transmit().expect("sent at once");
        let to = self
            .ids
            .iter()
            .position(|p| parse(&packet).has_subject(service().inbox(*p).as_str()))
            .expect("a call to a provider");
        (id, to, packet)
    }

    /// Two providers, both proven live by a first call.
    fn warm(now: Instant) -> Net {
        let mut net = Net::new(2, now);
        net.run(now);
        net.caller
            .call(now, Priority(0), &["warm"], TIMEOUT)
            .unwrap();
        net.run(now);
        assert!(net.outcomes()[0].1.is_ok());
        assert_eq!(net.caller.live().count(), 2);
        net
    }

    fn tick(&mut self, now: Instant) {
        self.caller.handle_timeout(now);
        for (i, p) in self.providers.iter_mut().enumerate() {
            if !self.dead[i] {
                p.handle_timeout(now);
            }
        }
        self.run(now);
    }

    /// Ticks every 10 ms from `from` for `span`; the time reached.
    fn run_for(&mut self, from: Instant, span: Duration) -> Instant {
        let mut now = from;
        while now < from + span {
            now += Duration::from_millis(10);
            self.tick(now);
        }
        now
    }

    fn outcomes(&mut self) -> Vec<Outcome> {
        std::iter::from_fn(|| self.caller.poll_outcome()).collect()
    }
}

// Crowds of strangers' announcements, and limits and refusals, each have a file of their own.
mod crowds;
mod limits;

#[test]
fn calls_are_spread_over_the_live_providers_and_each_is_answered_once_with_its_lines() {
    let t0 = Instant::now();
    let mut net = Net::new(2, t0);
    net.run(t0);
    assert_eq!(net.caller.providers().count(), 2);
    // The first call asks who is live; both echo.
    net.caller
        .call(t0, Priority(0), &["warm"], TIMEOUT)
        .unwrap();
    net.run(t0);
    assert_eq!(net.outcomes().len(), 1);
    assert_eq!(net.caller.live().count(), 2);
    let before = [net.taken[0].len(), net.taken[1].len()];
    let ids: Vec<Id> = (0..10)
        .map(|i| {
            let line = format!("n value {i}");
            net.caller.call(t0, Priority(0), &[&line], TIMEOUT).unwrap()
        })
        .collect();
    net.run(t0);
    let outcomes = net.outcomes();
    assert_eq!(outcomes.len(), 10);
    for (id, result) in &outcomes {
        let answer = result.as_ref().unwrap();
        let i = ids.iter().position(|x| x == id).unwrap();
        assert_eq!(answer.id, *id);
        assert_eq!(answer.lines, [format!("n value {i}")]);
    }
    let mut ended: Vec<Id> = outcomes.iter().map(|(id, _)| *id).collect();
    ended.sort();
    ended.dedup();
    assert_eq!(ended.len(), 10);
    assert_eq!(net.taken[0].len() - before[0], 5);
    assert_eq!(net.taken[1].len() - before[1], 5);
    assert_eq!(net.caller.in_flight(), 0);
    assert_eq!((net.caller.strays(), net.caller.forged()), (0, 0));
}

#[test]
fn a_provider_is_named_by_its_keys_fingerprint_and_seals_everything_it_says() {
    let t0 = Instant::now();
    let identity = key(9);
    let mut p = Provider::with_identity("echo", identity.clone(), LEASE, t0).unwrap();
    assert_eq!(p.id(), Id(identity.public().fingerprint()));
    let who = Notice::Who {
        nonce: Some(Id(42)),
    }
    .to_packet(&service());
    p.handle_packet(t0, &parse(&who));
    let call = format!(
        "@ <{}> 0\ncall id 0000000000000001 reply_to reply.0000000000000007\nx y 1\n",
        p.subjects()[1]
    );
    let ticket = p
        .handle_packet(t0, &parse(call.as_bytes()))
        .unwrap()
        .ticket();
    p.answer(&ticket, &["x y 1".into()]).unwrap();
    p.refuse(&ticket, "no");
    let mut said = Vec::new();
    while let Some(bytes) = p.poll_transmit() {
        said.push(bytes);
    }
    p.leave();
    said.push(p.poll_transmit().unwrap());
    let firsts: Vec<String> = said
        .iter()
        .map(|bytes| {
            let sealed = seal::open(bytes).expect("sealed");
            assert_eq!(sealed.key, identity.public());
            let packet = proven(&parse(bytes), p.id()).expect("proven as its own");
            packet.packet.lines().next().unwrap().label().to_owned()
        })
        .collect();
    assert_eq!(
        firsts,
        ["provider", "provider", "accepted", "reply", "refused", "leaving"]
    );
    // The echo carries the question's nonce.
    assert_eq!(
        Notice::read(&parse(&said[1])),
        Some(Notice::Provider {
            id: p.id(),
            lease: LEASE,
            nonce: Some(Id(42))
        })
    );
}

#[test]
fn a_call_before_any_provider_asks_who_provides_and_is_sent_once_one_answers() {
    let t0 = Instant::now();
    let mut net = Net::new(1, t0);
    // The provider's first announcement is lost, as when its hub lease is not yet there.
    while net.providers[0].poll_transmit().is_some() {}
    let id = net.caller.call(t0, Priority(0), &["x"], TIMEOUT).unwrap();
    net.run(t0);
    let outcomes = net.outcomes();
    assert_eq!(outcomes.len(), 1);
    assert_eq!(outcomes[0].0, id);
    assert!(outcomes[0].1.is_ok());
    assert_eq!(net.taken[0], [id]);
}

#[test]
fn with_no_provider_a_call_ends_at_its_deadline_and_who_is_asked_every_250_ms_with_a_fresh_nonce() {
    let t0 = Instant::now();
    let mut caller = Caller::with_id("nobody", Id(1)).unwrap();
    caller.call(t0, Priority(0), &["x"], TIMEOUT).unwrap();
    let mut nonces = Vec::new();
    let mut now = t0;
    while now < t0 + TIMEOUT {
        while let Some(p) = caller.poll_transmit() {
            match Notice::read(&parse(&p)) {
                Some(Notice::Who { nonce: Some(n) }) => nonces.push(n),
                other => panic!("expected `who nonce X`, got {other:?}"),
            }
        }
        now = caller.poll_timeout().unwrap();
        caller.handle_timeout(now);
    }
    let asked = nonces.len();
    assert!((19..=21).contains(&asked), "asked {asked} times in 5 s");
    nonces.sort();
    nonces.dedup();
    assert_eq!(nonces.len(), asked, "a nonce was used twice");
    let (_, result) = caller.poll_outcome().unwrap();
    assert!(matches!(result, Err(CallError::NoProvider { .. })));
    assert_eq!(caller.poll_timeout(), None);
}

#[test]
fn a_provider_that_does_not_accept_within_the_ack_wait_is_passed_over_and_tried_last() {
    let t0 = Instant::now();
    let mut net = Net::warm(t0);
    let (id, silent, packet) = net.call_held(t0, TIMEOUT);
    let other = 1 - silent;
    net.dead[silent] = true;
    net.deliver(t0, &packet);
    let now = net.run_for(t0, ACK_WAIT - Duration::from_millis(10));
    assert!(net.outcomes().is_empty(), "passed over before the ack wait");
    net.run_for(now, Duration::from_millis(20));
    let ended = net.outcomes();
    assert_eq!(ended.len(), 1, "{ended:?}");
    assert_eq!(ended[0].0, id);
    assert_eq!(ended[0].1.as_ref().unwrap().provider, net.ids[other]);
    // Tried last from then on: new calls go to the live one.
    assert_eq!(net.caller.live().collect::<Vec<_>>(), [net.ids[other]]);
    let before = net.taken[other].len();
    let at = t0 + Duration::from_secs(1);
    for _ in 0..4 {
        net.caller.call(at, Priority(0), &["y"], TIMEOUT).unwrap();
    }
    net.run(at);
    assert!(net.outcomes().iter().all(|(_, r)| r.is_ok()));
    assert_eq!(net.taken[other].len() - before, 4);
}

#[test]
fn the_ack_wait_is_never_more_than_a_quarter_of_the_time_left() {
    let t0 = Instant::now();
    let mut net = Net::warm(t0);
    let (_, silent, packet) = net.call_held(t0, Duration::from_millis(400));
    net.dead[silent] = true;
    net.deliver(t0, &packet);
    // The other answers after 100 ms, not 250.
    let now = net.run_for(t0, Duration::from_millis(90));
    assert!(net.outcomes().is_empty());
    net.run_for(now, Duration::from_millis(20));
    assert!(net.outcomes()[0].1.is_ok());
}

#[test]
fn once_accepted_a_call_is_never_sent_elsewhere_and_ends_with_its_providers_lease() {
    let t0 = Instant::now();
    let mut net = Net::warm(t0);
    let (id, held, packet) = net.call_held(t0, TIMEOUT);
    let other = 1 - held;
    net.mute[held] = true;
    net.deliver(t0, &packet);
    net.run(t0);
    let taken_by_other = net.taken[other].len();
    // Well past the ack wait, it is still the first one's.
    let now = net.run_for(t0, Duration::from_secs(1));
    assert!(net.outcomes().is_empty());
    assert_eq!(net.taken[other].len(), taken_by_other);
    // That one dies: the call ends with its lease, never sent to the other.
    net.dead[held] = true;
    net.run_for(now, LEASE + Duration::from_millis(100));
    let ended = net.outcomes();
    assert!(
        matches!(&ended[..], [(i, Err(CallError::ProviderLapsed { provider, .. }))] if *i == id && *provider == net.ids[held]),
        "{ended:?}"
    );
    assert_eq!(net.taken[other].len(), taken_by_other);
    assert_eq!(net.caller.providers().collect::<Vec<_>>(), [net.ids[other]]);
}

#[test]
fn a_provider_that_leaves_gets_no_new_calls_and_those_it_took_end_with_its_lease() {
    let t0 = Instant::now();
    let mut net = Net::warm(t0);
    let (_, held, packet) = net.call_held(t0, TIMEOUT);
    let other = 1 - held;
    net.mute[held] = true;
    net.deliver(t0, &packet);
    net.providers[held].leave();
    net.run(t0);
    assert!(net.outcomes().is_empty());
    assert_eq!(net.caller.providers().collect::<Vec<_>>(), [net.ids[other]]);
    let before = net.taken[other].len();
    for _ in 0..4 {
        net.caller.call(t0, Priority(0), &["y"], TIMEOUT).unwrap();
    }
    net.run(t0);
    assert_eq!(net.taken[other].len() - before, 4);
    assert!(net.outcomes().iter().all(|(_, r)| r.is_ok()));
    // It no longer announces; the call it took ends when its lease does.
    net.dead[held] = true;
    net.run_for(t0, LEASE + Duration::from_millis(100));
    let ended = net.outcomes();
    assert!(
        matches!(&ended[..], [(_, Err(CallError::ProviderLeft { provider }))] if *provider == net.ids[held]),
        "{ended:?}"
    );
}

#[test]
fn notices_not_sealed_by_the_provider_they_name_are_forged_and_change_nothing() {
    let t0 = Instant::now();
    let mut net = Net::new(1, t0);
    net.run(t0);
    net.mute[0] = true;
    net.caller.call(t0, Priority(0), &["x"], TIMEOUT).unwrap();
    net.run(t0);
    let real = net.ids[0];
    let mut forger = key(66);
    let short = Notice::Provider {
        id: real,
        lease: Duration::ZERO,
        nonce: None,
    }
    .to_packet(&service());
    let leaving = Notice::Leaving { id: real }.to_packet(&service());
    for bytes in [
        short.clone(),
        forger.sealed(short),
        leaving.clone(),
        forger.sealed(leaving),
    ] {
        net.caller.handle_packet(t0, &parse(&bytes));
    }
    assert_eq!(net.caller.forged(), 4);
    net.caller.handle_timeout(t0 + Duration::from_secs(1));
    assert!(net.outcomes().is_empty());
    assert_eq!(net.caller.providers().collect::<Vec<_>>(), [real]);
}

#[test]
fn a_recorded_notice_sent_again_is_refused() {
    let t0 = Instant::now();
    let mut caller = Caller::with_id("echo", Id(7)).unwrap();
    let mut p = provider(1, t0);
    let announced = p.poll_transmit().unwrap();
    caller.handle_packet(t0, &parse(&announced));
    p.leave();
    caller.handle_packet(t0, &parse(&p.poll_transmit().unwrap()));
    assert_eq!(caller.providers().count(), 0);
    // The old announcement, sent again, does not bring it back.
    caller.handle_packet(t0, &parse(&announced));
    assert_eq!(caller.providers().count(), 0);
    assert_eq!(caller.forged(), 1);
}

#[test]
fn an_answer_counts_only_under_the_seal_of_a_provider_the_call_was_sent_to() {
    let t0 = Instant::now();
    let mut net = Net::new(1, t0);
    net.run(t0);
    net.mute[0] = true;
    let id = net.caller.call(t0, Priority(0), &["x"], TIMEOUT).unwrap();
    net.run(t0);
    let real = net.ids[0];
    let inbox = net.caller.subjects()[0].clone();
    let mut forger = key(66);
    let header = |from: Id, said: Said| {
        AnswerHeader { id, from, said }
            .to_packet(&inbox, Priority(0), &["forged x 1".into()])
            .unwrap()
    };
    let forged = [
        // Unsealed, as the hostile review sent it.
        header(real, Said::Reply),
        header(real, Said::Refused("no".into())),
        // Sealed, but by another key than the one the provider's id names.
        forger.sealed(header(real, Said::Reply)),
        forger.sealed(header(real, Said::Accepted)),
    ];
    for bytes in &forged {
        net.caller.handle_packet(t0, &parse(bytes));
    }
    assert_eq!(net.caller.forged(), 4);
    // Its own seal, honestly: but the call was never sent to it.
    let own = Id::from(forger.public());
    net.caller
        .handle_packet(t0, &parse(&forger.sealed(header(own, Said::Reply))));
    assert_eq!(net.caller.strays(), 1);
    assert!(net.outcomes().is_empty());
    let ticket = Ticket {
        id,
        reply_to: inbox,
        priority: Priority(0),
    };
    net.providers[0]
        .answer(&ticket, &["real x 1".into()])
        .unwrap();
    let answer = net.providers[0].poll_transmit().unwrap();
    for _ in 0..3 {
        net.caller.handle_packet(t0, &parse(&answer));
    }
    let outcomes = net.outcomes();
    assert_eq!(outcomes.len(), 1);
    assert_eq!(outcomes[0].1.as_ref().unwrap().lines, ["real x 1"]);
    // Repeated: genuine, but the call has ended.
    assert_eq!(net.caller.strays(), 3);
}

#[test]
fn a_caller_without_a_live_provider_waits_for_an_echo_before_trying_announced_ones() {
    let t0 = Instant::now();
    let mut caller = Caller::with_id("echo", Id(7)).unwrap();
    // Announced, sealed by a real key, and nobody behind it.
    let mut ghost = provider(50, t0);
    caller.handle_packet(t0, &parse(&ghost.poll_transmit().unwrap()));
    let mut real = provider(51, t0);
    let _ = real.poll_transmit();
    caller.call(t0, Priority(0), &["x"], TIMEOUT).unwrap();
    let who = caller.poll_transmit().unwrap();
    let Some(Notice::Who { nonce: Some(_) }) = Notice::read(&parse(&who)) else {
        panic!("expected a `who nonce X` first");
    };
    assert_eq!(caller.poll_transmit(), None, "sent before any echo");
    real.handle_packet(t0, &parse(&who));
    let echo = real.poll_transmit().unwrap();
    caller.handle_packet(t0, &parse(&echo));
    let call = caller.poll_transmit().unwrap();
    assert!(parse(&call).has_subject(real.subjects()[1].as_str()));

    // With no echo at all, the announced one is tried after the ack wait.
    caller.call(t0, Priority(0), &["y"], TIMEOUT).unwrap();
    caller.handle_timeout(t0 + Duration::from_millis(10));
    let call = caller.poll_transmit().unwrap();
    assert!(
        parse(&call).has_subject(real.subjects()[1].as_str()),
        "the live one first"
    );
    let mut caller = Caller::with_id("echo", Id(8)).unwrap();
    ghost.handle_timeout(t0 + LEASE);
    caller.handle_packet(t0, &parse(&ghost.poll_transmit().unwrap()));
    caller.call(t0, Priority(0), &["z"], TIMEOUT).unwrap();
    assert!(caller
        .poll_transmit()
        .is_some_and(|p| Notice::read(&parse(&p)).is_some()));
    caller.handle_timeout(t0 + ACK_WAIT - Duration::from_millis(1));
    assert_eq!(caller.poll_transmit(), None);
    caller.handle_timeout(t0 + ACK_WAIT);
    let call = caller.poll_transmit().unwrap();
    assert!(parse(&call).has_subject(ghost.subjects()[1].as_str()));
}

#[test]
fn an_answer_keeps_a_busy_provider_alive_though_it_has_no_time_to_announce() {
    let t0 = Instant::now();
    let mut net = Net::new(1, t0);
    net.run(t0);
    net.caller
        .call(t0, Priority(0), &["warm"], TIMEOUT)
        .unwrap();
    net.run(t0);
    assert!(net.outcomes()[0].1.is_ok());
    // Answers every 0.5 s for 10 s; its announcements are all lost.
    let mut now = t0;
    for _ in 0..20 {
        now += Duration::from_millis(500);
        net.caller.handle_timeout(now);
        net.caller.call(now, Priority(0), &["x"], TIMEOUT).unwrap();
        let call = net.caller.poll_transmit().unwrap();
        let p = &mut net.providers[0];
        let ticket = p.handle_packet(now, &parse(&call)).unwrap().ticket();
        p.answer(&ticket, &[]).unwrap();
        while let Some(bytes) = p.poll_transmit() {
            net.caller.handle_packet(now, &parse(&bytes));
        }
        assert!(net.caller.poll_outcome().unwrap().1.is_ok());
    }
    assert_eq!(net.caller.providers().count(), 1);
}
