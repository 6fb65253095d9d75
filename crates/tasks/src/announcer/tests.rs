//! The announcer's state machine, driven by hand on simulated time.

use std::time::Duration;

use super::*;
use crate::protocol::ResourceSet;
use crate::test_keys::{seal_as, speaker};

fn token(s: &str) -> Token {
    Token::new(s).unwrap()
}

fn t(ms: u64) -> Time {
    Time::from_micros(ms * 1000)
}

fn user() -> Announcer {
    Announcer::new(token("user"), AuctionConfig::default())
}

fn look() -> TaskSpec {
    TaskSpec::new("look", "camera mobile".parse().unwrap())
        .length(5.0)
        .metric("distance", 1.0)
}

fn subject(id: u64, attempt: u32) -> Subject {
    negotiation_subject(&token("user"), id, attempt)
}

/// Hands the message over if the hub would, sealed by whoever it claims to
/// come from: true if it did.
fn say(a: &mut Announcer, now: Time, on: &Subject, m: Negotiation) -> bool {
    let by = speaker(&m, a.token()).to_owned();
    say_as(a, now, on, &by, m)
}

/// Hands the message over if the hub would, sealed by `by`.
fn say_as(a: &mut Announcer, now: Time, on: &Subject, by: &str, m: Negotiation) -> bool {
    let bytes = seal_as(by, m.encode(on).unwrap());
    let packet = Packet::parse(&bytes).unwrap();
    if !packet.subjects().all(|s| a.subscriptions().contains(s)) {
        return false;
    }
    a.handle_packet(now, &packet);
    true
}

fn bid(a: &mut Announcer, now: Time, id: u64, bidder: &str, score: f64) -> bool {
    let m = Negotiation::Bid(Bid {
        task: id,
        bidder: token(bidder),
        score,
    });
    say(a, now, &subject(id, 1), m)
}

fn sent(a: &mut Announcer) -> Vec<Message> {
    std::iter::from_fn(|| a.poll_transmit())
        .map(|p| Message::decode_bytes(&p).unwrap())
        .collect()
}

/// The negotiation messages sent, with their subjects.
fn said(a: &mut Announcer) -> Vec<(String, Negotiation)> {
    sent(a)
        .into_iter()
        .filter_map(|m| match m {
            Message::Negotiation { subject, message } => Some((subject.to_string(), message)),
            Message::Announce(_) | Message::Robot(_) => None,
        })
        .collect()
}

fn events(a: &mut Announcer) -> Vec<AnnouncerEvent> {
    std::iter::from_fn(|| a.poll_event()).collect()
}

fn subs(a: &Announcer) -> Vec<&str> {
    a.subscriptions().iter().map(|s| s.as_str()).collect()
}

/// Announces `look` at 0 and awards it to `r1` at the deadline, acked at `ack`.
fn running(a: &mut Announcer, ack: Time) -> u64 {
    let id = a.announce(Time::ZERO, look()).unwrap();
    bid(a, t(10), id, "r1", 1.0);
    a.handle_timeout(t(200));
    let ackm = Negotiation::Ack {
        task: id,
        bidder: token("r1"),
    };
    assert!(say(a, ack, &subject(id, 1), ackm));
    assert_eq!(a.phase(id), Some(TaskPhase::Running(token("r1"))));
    sent(a);
    events(a);
    id
}

#[test]
fn an_announcement_goes_to_the_resources_and_idle_with_a_fresh_subject() {
    let mut a = user();
    let id = a.announce(t(50), look()).unwrap();
    assert_eq!(id, 1);
    assert_eq!(a.announce(t(50), look()), Ok(2));
    let out = sent(&mut a);
    let Message::Announce(ann) = &out[0] else {
        panic!("{out:?}");
    };
    assert_eq!(ann.subjects(), ["camera", "mobile", "idle"]);
    assert_eq!(ann.negotiation.as_str(), "murdoch.user.1.1");
    assert_eq!(ann.deadline, Duration::from_millis(200));
    assert_eq!(ann.announcer, token("user"));
    assert_eq!(subs(&a), ["murdoch.user.1.1", "murdoch.user.2.1"]);
    assert_eq!(a.phase(id), Some(TaskPhase::Bidding));
    assert_eq!(a.poll_timeout(), Some(t(250)));
    assert_eq!(
        events(&mut a)[0],
        AnnouncerEvent::Announced {
            task: 1,
            name: "look".into(),
            attempt: 1
        }
    );
}

#[test]
fn an_invalid_task_is_refused_and_takes_no_number() {
    let mut a = user();
    assert!(a.announce(t(0), look().length(f64::NAN)).is_err());
    assert!(sent(&mut a).is_empty());
    assert_eq!(a.announce(t(0), look()), Ok(1));
}

#[test]
fn a_bid_window_no_robot_would_accept_is_refused_up_front() {
    let mut a = Announcer::new(
        token("user"),
        AuctionConfig {
            bid_window: MAX_DEADLINE + Duration::from_millis(1),
            ..AuctionConfig::default()
        },
    );
    let e = a.announce(t(0), look()).unwrap_err();
    assert!(e.to_string().contains("bid_window"), "{e}");
    assert!(sent(&mut a).is_empty());
    assert_eq!(a.open_tasks().count(), 0);
}

#[test]
fn bids_are_taken_until_the_deadline_and_the_lowest_wins() {
    let mut a = user();
    let id = a.announce(t(0), look()).unwrap();
    sent(&mut a);
    for (who, score) in [("r1", 30.0), ("r2", 10.0), ("r3", 20.0)] {
        assert!(bid(&mut a, t(50), id, who, score));
    }
    a.handle_timeout(t(199));
    assert_eq!(a.phase(id), Some(TaskPhase::Bidding));
    a.handle_timeout(t(200));
    assert_eq!(
        said(&mut a),
        [(
            "murdoch.user.1.1".to_string(),
            Negotiation::Award {
                task: id,
                winner: token("r2"),
                score: 10.0,
                bids: 3
            }
        )]
    );
    assert_eq!(a.phase(id), Some(TaskPhase::Awarded(token("r2"))));
    assert_eq!(a.winner(id), Some(&token("r2")));
    assert!(events(&mut a).contains(&AnnouncerEvent::Awarded {
        task: id,
        name: "look".into(),
        winner: token("r2"),
        score: 10.0,
        bids: 3
    }));
}

#[test]
fn equal_scores_go_to_the_lowest_token_whatever_the_arrival_order() {
    for order in [["charlie", "alpha", "bravo"], ["bravo", "charlie", "alpha"]] {
        let mut a = user();
        let id = a.announce(t(0), look()).unwrap();
        for who in order {
            bid(&mut a, t(10), id, who, 7.0);
        }
        bid(&mut a, t(10), id, "aaa", 7.5);
        a.handle_timeout(t(200));
        assert_eq!(a.winner(id), Some(&token("alpha")), "{order:?}");
    }
}

#[test]
fn a_lower_score_beats_a_lower_token() {
    let mut a = user();
    let id = a.announce(t(0), look()).unwrap();
    bid(&mut a, t(10), id, "alpha", 2.0);
    bid(&mut a, t(10), id, "zulu", 1.0);
    a.handle_timeout(t(200));
    assert_eq!(a.winner(id), Some(&token("zulu")));
}

#[test]
fn a_second_bid_from_the_same_robot_replaces_its_first() {
    let mut a = user();
    let id = a.announce(t(0), look()).unwrap();
    bid(&mut a, t(10), id, "r1", 1.0);
    bid(&mut a, t(20), id, "r2", 2.0);
    bid(&mut a, t(30), id, "r1", 3.0);
    a.handle_timeout(t(200));
    assert!(matches!(&said(&mut a)[..],
        [(_, Negotiation::Award { winner, bids: 2, .. })] if winner.as_str() == "r2"));
}

#[test]
fn a_declined_bid_is_withdrawn_from_the_auction() {
    let mut a = user();
    let id = a.announce(t(0), look()).unwrap();
    bid(&mut a, t(10), id, "r1", 1.0);
    bid(&mut a, t(10), id, "r2", 2.0);
    let decline = Negotiation::Decline {
        task: id,
        bidder: token("r1"),
    };
    say(&mut a, t(20), &subject(id, 1), decline);
    a.handle_timeout(t(200));
    assert_eq!(a.winner(id), Some(&token("r2")));
}

#[test]
fn a_bid_after_the_deadline_changes_nothing() {
    let mut a = user();
    let id = a.announce(t(0), look()).unwrap();
    bid(&mut a, t(10), id, "r2", 2.0);
    a.handle_timeout(t(200));
    bid(&mut a, t(201), id, "r1", 1.0);
    assert_eq!(a.phase(id), Some(TaskPhase::Awarded(token("r2"))));
    assert_eq!(a.stats().bids, 1);
}

#[test]
fn a_bid_naming_another_task_on_the_subject_is_ignored() {
    let mut a = user();
    let one = a.announce(t(0), look()).unwrap();
    let two = a.announce(t(0), look()).unwrap();
    // A bid for task 2 sent on task 1's subject.
    let stray = Negotiation::Bid(Bid {
        task: two,
        bidder: token("r1"),
        score: 1.0,
    });
    say(&mut a, t(10), &subject(one, 1), stray);
    assert_eq!(a.stats().bids, 0);
}

#[test]
fn no_bids_by_the_deadline_is_unachievable_naming_the_resources() {
    let mut a = user();
    let id = a.announce(t(0), look()).unwrap();
    sent(&mut a);
    events(&mut a);
    a.handle_timeout(t(200));
    let reason = "no robot with {camera mobile} is available".to_string();
    assert_eq!(
        said(&mut a),
        [(
            "murdoch.user.1.1".to_string(),
            Negotiation::Unachievable {
                task: id,
                name: "look".into(),
                reason: reason.clone()
            }
        )]
    );
    assert_eq!(
        events(&mut a),
        [AnnouncerEvent::Unachievable {
            task: id,
            name: "look".into(),
            reason
        }]
    );
    assert_eq!(a.open_tasks().count(), 0);
    assert!(a.subscriptions().is_empty());
    assert_eq!(a.poll_timeout(), None);
    assert_eq!(a.stats().unachievable, 1);
}

#[test]
fn a_task_needing_nothing_with_no_bids_says_so() {
    let mut a = user();
    a.announce(t(0), TaskSpec::new("think", ResourceSet::new()))
        .unwrap();
    a.handle_timeout(t(200));
    assert!(events(&mut a).iter().any(|e| matches!(e,
        AnnouncerEvent::Unachievable { reason, .. } if reason == "no robot with {} is available")));
}

#[test]
fn the_winners_ack_starts_the_task_and_the_announcer_renews() {
    let mut a = user();
    let id = a.announce(t(0), look()).unwrap();
    bid(&mut a, t(10), id, "r1", 1.0);
    a.handle_timeout(t(200));
    events(&mut a);
    sent(&mut a);
    let ack = |who: &str| Negotiation::Ack {
        task: id,
        bidder: token(who),
    };
    say(&mut a, t(210), &subject(id, 1), ack("r9"));
    assert_eq!(a.phase(id), Some(TaskPhase::Awarded(token("r1"))));
    say(&mut a, t(220), &subject(id, 1), ack("r1"));
    assert_eq!(a.phase(id), Some(TaskPhase::Running(token("r1"))));
    assert_eq!(
        events(&mut a),
        [AnnouncerEvent::Started {
            task: id,
            winner: token("r1")
        }]
    );
    assert_eq!(a.poll_timeout(), Some(t(1220)));
    a.handle_timeout(t(1220));
    assert_eq!(
        said(&mut a),
        [(
            "murdoch.user.1.1".to_string(),
            Negotiation::Renew {
                task: id,
                by: token("user"),
                progress: None
            }
        )]
    );
    assert_eq!(a.poll_timeout(), Some(t(2220)));
}

#[test]
fn a_renewal_from_the_winner_stands_for_a_lost_ack() {
    let mut a = user();
    let id = a.announce(t(0), look()).unwrap();
    bid(&mut a, t(10), id, "r1", 1.0);
    a.handle_timeout(t(200));
    let renew = Negotiation::Renew {
        task: id,
        by: token("r1"),
        progress: Some(0.1),
    };
    say(&mut a, t(900), &subject(id, 1), renew);
    assert_eq!(a.phase(id), Some(TaskPhase::Running(token("r1"))));
}

#[test]
fn the_winners_renewals_keep_the_task_with_it() {
    let mut a = user();
    let id = running(&mut a, t(300));
    let renew = |who: &str| Negotiation::Renew {
        task: id,
        by: token(who),
        progress: Some(0.5),
    };
    say(&mut a, t(3000), &subject(id, 1), renew("r1"));
    // Another robot's (or its own) renewals do not count for the winner.
    say(&mut a, t(4000), &subject(id, 1), renew("r2"));
    say(&mut a, t(4000), &subject(id, 1), renew("user"));
    a.handle_timeout(t(5999));
    assert_eq!(a.phase(id), Some(TaskPhase::Running(token("r1"))));
    a.handle_timeout(t(6000));
    assert_eq!(a.phase(id), Some(TaskPhase::Bidding));
}

#[test]
fn a_winner_that_stops_renewing_is_cancelled_and_the_task_auctioned_again() {
    let mut a = user();
    let id = running(&mut a, t(300));
    a.handle_timeout(t(1300));
    a.handle_timeout(t(2300));
    assert_eq!(said(&mut a).len(), 2, "two renewals");
    assert_eq!(a.poll_timeout(), Some(t(3300)));
    a.handle_timeout(t(3300));
    let reason = "presumed failed: no renewal for 3.0 s".to_string();
    let out = sent(&mut a);
    assert_eq!(
        out[0],
        Message::Negotiation {
            subject: subject(id, 1),
            message: Negotiation::Cancel {
                task: id,
                reason: reason.clone()
            }
        }
    );
    let Message::Announce(again) = &out[1] else {
        panic!("{out:?}");
    };
    assert_eq!((again.id, again.negotiation.clone()), (id, subject(id, 2)));
    assert_eq!(out.len(), 2);
    assert_eq!(subs(&a), ["murdoch.user.1.2"]);
    assert_eq!(
        events(&mut a),
        [
            AnnouncerEvent::WinnerLost {
                task: id,
                name: "look".into(),
                winner: token("r1"),
                reason
            },
            AnnouncerEvent::Announced {
                task: id,
                name: "look".into(),
                attempt: 2
            }
        ]
    );
    assert_eq!(a.poll_timeout(), Some(t(3500)));
    assert_eq!(a.stats().lost, 1);
    assert_eq!(a.stats().auctions, 2);
}

#[test]
fn messages_from_an_earlier_auction_of_the_task_are_ignored() {
    let mut a = user();
    let id = running(&mut a, t(300));
    a.handle_timeout(t(3300));
    let done = Negotiation::Done {
        task: id,
        bidder: token("r1"),
    };
    // Unsubscribed from the old subject, and deaf to it even if handed a packet.
    assert!(!say(&mut a, t(3400), &subject(id, 1), done.clone()));
    let bytes = seal_as("r1", done.encode(&subject(id, 1)).unwrap());
    a.handle_packet(t(3400), &Packet::parse(&bytes).unwrap());
    assert_eq!(a.phase(id), Some(TaskPhase::Bidding));
    assert_eq!(a.stats().completed, 0);
}

#[test]
fn no_ack_within_the_timeout_is_a_lost_winner() {
    let mut a = user();
    let id = a.announce(t(0), look()).unwrap();
    bid(&mut a, t(10), id, "r1", 1.0);
    a.handle_timeout(t(200));
    events(&mut a);
    assert_eq!(a.poll_timeout(), Some(t(1200)));
    a.handle_timeout(t(1200));
    assert!(matches!(&events(&mut a)[0],
        AnnouncerEvent::WinnerLost { reason, .. } if reason == "no acknowledgement within 1.0 s"));
    assert_eq!(a.phase(id), Some(TaskPhase::Bidding));
}

#[test]
fn a_winner_declining_the_award_sends_the_task_to_auction_again() {
    let mut a = user();
    let id = a.announce(t(0), look()).unwrap();
    bid(&mut a, t(10), id, "r1", 1.0);
    a.handle_timeout(t(200));
    events(&mut a);
    let decline = Negotiation::Decline {
        task: id,
        bidder: token("r1"),
    };
    say(&mut a, t(210), &subject(id, 1), decline);
    assert!(matches!(&events(&mut a)[0],
        AnnouncerEvent::WinnerLost { reason, .. } if reason == "the winner declined"));
    assert!(a.subscriptions().contains(subject(id, 2).as_str()));
}

#[test]
fn an_abandoned_task_is_auctioned_again_with_the_winners_reason() {
    let mut a = user();
    let id = running(&mut a, t(300));
    let abandon = Negotiation::Abandon {
        task: id,
        bidder: token("r1"),
        reason: "stuck".into(),
    };
    say(&mut a, t(500), &subject(id, 1), abandon);
    assert!(matches!(&events(&mut a)[0],
        AnnouncerEvent::WinnerLost { reason, .. } if reason == "the winner abandoned it: stuck"));
    assert_eq!(a.phase(id), Some(TaskPhase::Bidding));
}

#[test]
fn only_the_winner_can_finish_or_abandon() {
    let mut a = user();
    let id = running(&mut a, t(300));
    let on = subject(id, 1);
    say(
        &mut a,
        t(400),
        &on,
        Negotiation::Done {
            task: id,
            bidder: token("r2"),
        },
    );
    say(
        &mut a,
        t(400),
        &on,
        Negotiation::Abandon {
            task: id,
            bidder: token("r2"),
            reason: "x".into(),
        },
    );
    assert_eq!(a.phase(id), Some(TaskPhase::Running(token("r1"))));
    assert!(events(&mut a).is_empty());
}

#[test]
fn done_completes_the_task_and_closes_its_subject() {
    let mut a = user();
    let id = running(&mut a, t(300));
    let done = Negotiation::Done {
        task: id,
        bidder: token("r1"),
    };
    say(&mut a, t(800), &subject(id, 1), done);
    assert_eq!(
        events(&mut a),
        [AnnouncerEvent::Completed {
            task: id,
            name: "look".into(),
            winner: token("r1")
        }]
    );
    assert_eq!(a.phase(id), None);
    assert!(a.subscriptions().is_empty());
    assert!(sent(&mut a).is_empty(), "nothing more to say");
    assert_eq!(a.poll_timeout(), None);
}

#[test]
fn a_task_lost_too_often_is_reported_unachievable() {
    let mut a = Announcer::new(
        token("user"),
        AuctionConfig {
            max_attempts: 2,
            ..AuctionConfig::default()
        },
    );
    let id = a.announce(t(0), look()).unwrap();
    for attempt in 1..=2 {
        let now = a.poll_timeout().unwrap();
        let m = Negotiation::Bid(Bid {
            task: id,
            bidder: token("r1"),
            score: 1.0,
        });
        say(&mut a, now, &subject(id, attempt), m);
        a.handle_timeout(now); // award
        let ack_by = a.poll_timeout().unwrap();
        a.handle_timeout(ack_by); // no ack: lost
    }
    let ev = events(&mut a);
    assert!(matches!(ev.last(),
        Some(AnnouncerEvent::Unachievable { reason, .. }) if reason == "auctioned 2 times without being done"));
    assert_eq!(a.open_tasks().count(), 0);
    assert!(a.subscriptions().is_empty());
}

#[test]
fn cancel_tells_the_winner_and_forgets_the_task() {
    let mut a = user();
    let id = running(&mut a, t(300));
    assert!(a.cancel(id, "not needed"));
    assert_eq!(
        said(&mut a),
        [(
            "murdoch.user.1.1".to_string(),
            Negotiation::Cancel {
                task: id,
                reason: "not needed".into()
            }
        )]
    );
    assert_eq!(events(&mut a), [AnnouncerEvent::Cancelled { task: id }]);
    assert!(a.subscriptions().is_empty());
    assert!(!a.cancel(id, "again"));
}

#[test]
fn a_malformed_packet_is_counted_and_ignored() {
    let mut a = user();
    let id = a.announce(t(0), look()).unwrap();
    let bytes = seal_as(
        "r1",
        b"@ <murdoch.user.1.1> 0\nbid task 1 bidder r1 score lots\n".to_vec(),
    );
    a.handle_packet(t(10), &Packet::parse(&bytes).unwrap());
    assert_eq!(a.stats().rejected, 1);
    assert_eq!(a.stats().bids, 0);
    assert_eq!(a.phase(id), Some(TaskPhase::Bidding));
}

#[test]
fn a_flood_of_bidders_is_capped_but_known_bidders_may_still_improve() {
    let mut a = user();
    let id = a.announce(t(0), look()).unwrap();
    for i in 0..MAX_BIDS {
        bid(&mut a, t(10), id, &format!("b{i}"), 100.0);
    }
    bid(&mut a, t(20), id, "late", 1.0);
    bid(&mut a, t(20), id, "b77", 2.0);
    a.handle_timeout(t(200));
    assert!(matches!(&said(&mut a)[..],
        [(_, Negotiation::Award { winner, bids, .. })]
            if winner.as_str() == "b77" && *bids as usize == MAX_BIDS));
}

// Attacks from other processes on the hub: each message below is sealed by
// a key other than the one the task is bound to, or is a copy of one taken.

#[test]
fn a_done_from_another_key_does_not_end_the_task() {
    let mut a = user();
    let id = running(&mut a, t(300));
    let done = Negotiation::Done {
        task: id,
        bidder: token("r1"),
    };
    assert!(say_as(
        &mut a,
        t(400),
        &subject(id, 1),
        "mallory",
        done.clone()
    ));
    assert_eq!(a.phase(id), Some(TaskPhase::Running(token("r1"))));
    assert_eq!((a.stats().completed, a.stats().forged), (0, 1));
    // The winner's own still does.
    assert!(say(&mut a, t(500), &subject(id, 1), done));
    assert_eq!(a.stats().completed, 1);
}

#[test]
fn another_key_cannot_renew_the_winners_task_or_abandon_it() {
    let mut a = user();
    let id = running(&mut a, t(300));
    let renew = Negotiation::Renew {
        task: id,
        by: token("r1"),
        progress: Some(0.5),
    };
    let abandon = Negotiation::Abandon {
        task: id,
        bidder: token("r1"),
        reason: "forged".into(),
    };
    assert!(say_as(&mut a, t(400), &subject(id, 1), "mallory", abandon));
    assert_eq!(a.phase(id), Some(TaskPhase::Running(token("r1"))));
    // Renewals from a forger every half second do not keep a silent winner.
    for ms in (1000..=3500).step_by(500) {
        say_as(&mut a, t(ms), &subject(id, 1), "mallory", renew.clone());
        a.handle_timeout(t(ms));
    }
    assert_eq!(a.phase(id), Some(TaskPhase::Bidding), "re-auctioned");
    assert!(a.stats().forged >= 5);
}

#[test]
fn a_copy_of_the_winners_renewal_keeps_nothing_alive() {
    let mut a = user();
    let id = running(&mut a, t(300));
    let renew = Negotiation::Renew {
        task: id,
        by: token("r1"),
        progress: Some(0.5),
    };
    let bytes = seal_as("r1", renew.encode(&subject(id, 1)).unwrap());
    for ms in (400..=3400).step_by(500) {
        a.handle_packet(t(ms), &Packet::parse(&bytes).unwrap());
        a.handle_timeout(t(ms));
    }
    // Taken once at 400 ms; the copies are refused, so the winner's silence
    // since then loses it the task.
    assert_eq!(a.phase(id), Some(TaskPhase::Bidding));
}

#[test]
fn a_bid_in_another_bidders_name_from_another_key_is_refused() {
    let mut a = user();
    let id = a.announce(t(0), look()).unwrap();
    bid(&mut a, t(10), id, "r1", 100.0);
    let forged = Negotiation::Bid(Bid {
        task: id,
        bidder: token("r1"),
        score: 1.0,
    });
    assert!(say_as(&mut a, t(20), &subject(id, 1), "mallory", forged));
    let decline = Negotiation::Decline {
        task: id,
        bidder: token("r1"),
    };
    assert!(say_as(&mut a, t(30), &subject(id, 1), "mallory", decline));
    a.handle_timeout(t(200));
    assert!(matches!(&said(&mut a)[..],
        [(_, Negotiation::Award { winner, score, .. })] if winner.as_str() == "r1" && *score == 100.0));
    assert_eq!(a.stats().forged, 2);
}

#[test]
fn a_bid_no_robot_can_score_is_ignored() {
    let mut a = user();
    let id = a.announce(t(0), look()).unwrap();
    // `look` is scored by distance alone, a cost: never below 0.
    bid(&mut a, t(10), id, "rogue", -1e12);
    bid(&mut a, t(20), id, "r1", 100.0);
    a.handle_timeout(t(200));
    assert!(matches!(&said(&mut a)[..],
        [(_, Negotiation::Award { winner, .. })] if winner.as_str() == "r1"));
    assert_eq!(a.stats().bids, 1);
}

#[test]
fn an_unsealed_message_is_refused() {
    let mut a = user();
    let id = a.announce(t(0), look()).unwrap();
    let m = Negotiation::Bid(Bid {
        task: id,
        bidder: token("r1"),
        score: 1.0,
    });
    let bytes = m.encode(&subject(id, 1)).unwrap();
    a.handle_packet(t(10), &Packet::parse(&bytes).unwrap());
    assert_eq!((a.stats().bids, a.stats().rejected), (0, 1));
}
