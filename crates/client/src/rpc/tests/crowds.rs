//! Strangers: announcements under fresh keys, ghosts that echo, unproven providers, changed packets.

use super::*;

/// A sealed announcement under a fresh key nobody will use again.
fn ghost_announcement(seed: u64, lease: Duration, nonce: Option<Id>) -> Vec<u8> {
    let mut bytes = [0u8; 32];
    bytes[..8].copy_from_slice(&seed.to_le_bytes());
    bytes[31] = 0xee;
    let mut identity = Identity::from_seed(bytes);
    let notice = Notice::Provider {
        id: Id::from(identity.public()),
        lease,
        nonce,
    };
    identity.sealed(notice.to_packet(&service()))
}

#[test]
fn announcements_under_fresh_keys_hold_at_most_64_places_and_a_live_provider_takes_one() {
    let t0 = Instant::now();
    let mut net = Net::new(1, t0);
    for i in 0..200 {
        let ghost = ghost_announcement(i, Duration::from_secs(3600), None);
        net.caller.handle_packet(t0, &parse(&ghost));
    }
    assert_eq!(net.caller.providers().count(), 64);
    // The real provider's plain announcement finds no room (its lease is shorter)...
    net.run(t0);
    assert!(!net.caller.providers().any(|p| p == net.ids[0]));
    // ...but its echo to a call's `who` proves it live, and that makes room.
    for i in 0..6 {
        let line = format!("n value {i}");
        net.caller.call(t0, Priority(0), &[&line], TIMEOUT).unwrap();
        net.run(t0);
    }
    let outcomes = net.outcomes();
    assert_eq!(outcomes.len(), 6);
    for (_, result) in &outcomes {
        assert_eq!(result.as_ref().unwrap().provider, net.ids[0]);
    }
    assert_eq!(net.caller.providers().count(), 64);
    // Believed a minute at most, whatever they claim.
    net.caller.handle_timeout(t0 + Duration::from_secs(61));
    assert_eq!(net.caller.providers().count(), 0);
}

#[test]
fn ghosts_that_echo_cost_a_call_an_ack_wait_each_and_never_its_answer() {
    let t0 = Instant::now();
    let mut net = Net::new(1, t0);
    net.run(t0);
    net.caller.call(t0, Priority(0), &["x"], TIMEOUT).unwrap();
    let who = net.caller.poll_transmit().unwrap();
    let Some(Notice::Who { nonce }) = Notice::read(&parse(&who)) else {
        panic!("expected `who`");
    };
    // Three ghosts answer first, echoing the nonce, and never take a call.
    for i in 0..3 {
        let ghost = ghost_announcement(i, LEASE, nonce);
        net.caller.handle_packet(t0, &parse(&ghost));
    }
    net.caller.handle_packet(t0, &parse(&who));
    for p in &mut net.providers {
        p.handle_packet(t0, &parse(&who));
    }
    net.run(t0);
    let now = net.run_for(t0, 4 * ACK_WAIT);
    let outcomes = net.outcomes();
    assert_eq!(outcomes.len(), 1, "not answered within {:?}", now - t0);
    assert_eq!(outcomes[0].1.as_ref().unwrap().provider, net.ids[0]);
}

#[test]
fn no_change_to_a_providers_packet_panics_or_passes_for_its_word() {
    let t0 = Instant::now();
    let mut net = Net::new(1, t0);
    net.run(t0);
    net.mute[0] = true;
    let id = net.caller.call(t0, Priority(0), &["x"], TIMEOUT).unwrap();
    net.run(t0);
    let ticket = Ticket {
        id,
        reply_to: net.caller.subjects()[0].clone(),
        priority: Priority(0),
    };
    net.providers[0]
        .answer(&ticket, &["real x 1".into()])
        .unwrap();
    net.providers[0].handle_timeout(t0 + LEASE);
    net.providers[0].leave();
    let genuine: Vec<Vec<u8>> = std::iter::from_fn(|| net.providers[0].poll_transmit()).collect();
    let mut changed = 0;
    for bytes in &genuine {
        for i in 0..bytes.len() {
            for bit in [0x01, 0x20] {
                let mut bad = bytes.clone();
                bad[i] ^= bit;
                let Ok(packet) = Packet::parse(&bad) else {
                    continue;
                };
                changed += 1;
                net.caller.handle_packet(t0, &packet);
                net.providers[0].handle_packet(t0, &packet);
            }
        }
    }
    assert!(changed > 100, "{changed} changed packets");
    assert_eq!(net.caller.poll_outcome(), None);
    assert_eq!(net.caller.providers().count(), 1);
}

#[test]
fn a_caller_keeps_asking_while_its_call_sits_with_an_unproven_provider() {
    let t0 = Instant::now();
    let mut caller = Caller::with_id("echo", Id(7)).unwrap();
    let mut ghost = provider(50, t0);
    caller.handle_packet(t0, &parse(&ghost.poll_transmit().unwrap()));
    let mut real = provider(51, t0);
    let _ = real.poll_transmit();
    caller.call(t0, Priority(0), &["x"], TIMEOUT).unwrap();
    // The first question is lost; the call goes to the ghost after the ack wait...
    assert!(caller.poll_transmit().is_some());
    let at = t0 + ACK_WAIT;
    caller.handle_timeout(at);
    let sent: Vec<Vec<u8>> = std::iter::from_fn(|| caller.poll_transmit()).collect();
    assert!(parse(&sent[0]).has_subject(ghost.subjects()[1].as_str()));
    // ...and a fresh question goes out with it, which the real one answers.
    let who = sent.get(1).expect("asked again");
    real.handle_packet(at, &parse(who));
    caller.handle_packet(at, &parse(&real.poll_transmit().unwrap()));
    assert_eq!(caller.live().collect::<Vec<_>>(), [real.id()]);
    let at = caller.poll_timeout().unwrap();
    caller.handle_timeout(at);
    let call = caller.poll_transmit().unwrap();
    assert!(parse(&call).has_subject(real.subjects()[1].as_str()));
}
