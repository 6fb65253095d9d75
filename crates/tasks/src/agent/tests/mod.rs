//! The agent's state machine, driven by hand on simulated time.

use std::time::Duration;

use super::*;
use crate::protocol::negotiation_subject;
use crate::protocol::TaskSpec;
use crate::test_keys::{seal_as, speaker};

// The agent's body, its reports and others' authority each have a file of their own.
mod authority;
mod body;
mod reports;

fn token(s: &str) -> Token {
    Token::new(s).unwrap()
}

fn t(ms: u64) -> Time {
    Time::from_micros(ms * 1000)
}

/// `r1` at the origin, idle and full, not reporting (see `reporting`).
fn robot(resources: &str) -> Agent {
    let config = AgentConfig {
        report_interval: None,
        ..AgentConfig::default()
    };
    let mut a = Agent::new(token("r1"), resources.parse().unwrap(), config, Time::ZERO);
    a.set_position(Vec2::ZERO);
    a
}

/// A task 5 cm from the origin, announced by `u`, scored by distance.
fn task(id: u64, resources: &str) -> Announcement {
    Announcement {
        spec: TaskSpec::new("goto", resources.parse().unwrap())
            .length(10.0)
            .param("x", 3.0)
            .param("y", 4.0)
            .metric("distance", 1.0),
        id,
        negotiation: negotiation_subject(&token("u"), id, 1),
        deadline: Duration::from_millis(200),
        announcer: token("u"),
    }
}

/// Hands the packet over if the hub would: true if it did.
fn hear(a: &mut Agent, now: Time, bytes: &[u8]) -> bool {
    let packet = Packet::parse(bytes).unwrap();
    if !packet.subjects().all(|s| a.subscriptions().contains(s)) {
        return false;
    }
    a.handle_packet(now, &packet);
    true
}

/// The announcement, sealed by its announcer.
fn sealed_announcement(ann: &Announcement) -> Vec<u8> {
    seal_as(ann.announcer.as_str(), ann.encode().unwrap())
}

fn announce(a: &mut Agent, now: Time, ann: &Announcement) -> bool {
    hear(a, now, &sealed_announcement(ann))
}

/// Says `m` on the task's subject, sealed by whoever it claims to come from.
fn say(a: &mut Agent, now: Time, ann: &Announcement, m: Negotiation) -> bool {
    let bytes = seal_as(
        speaker(&m, &ann.announcer),
        m.encode(&ann.negotiation).unwrap(),
    );
    hear(a, now, &bytes)
}

/// Says `m` on the task's subject, sealed by `by`.
fn say_as(a: &mut Agent, now: Time, ann: &Announcement, by: &str, m: Negotiation) -> bool {
    hear(a, now, &seal_as(by, m.encode(&ann.negotiation).unwrap()))
}

fn bid_by(ann: &Announcement, bidder: &str, score: f64) -> Negotiation {
    Negotiation::Bid(Bid {
        task: ann.id,
        bidder: token(bidder),
        score,
    })
}

fn award(ann: &Announcement, winner: &str) -> Negotiation {
    Negotiation::Award {
        task: ann.id,
        winner: token(winner),
        score: 5.0,
        bids: 1,
    }
}

fn renew_by(ann: &Announcement, by: &str) -> Negotiation {
    Negotiation::Renew {
        task: ann.id,
        by: token(by),
        progress: None,
    }
}

/// What it published, with the subject each went to.
fn sent(a: &mut Agent) -> Vec<(String, Negotiation)> {
    std::iter::from_fn(|| a.poll_transmit())
        .map(|p| match Message::decode_bytes(&p).unwrap() {
            Message::Negotiation { subject, message } => (subject.to_string(), message),
            other => panic!("an agent sent {other:?}"),
        })
        .collect()
}

fn messages(a: &mut Agent) -> Vec<Negotiation> {
    sent(a).into_iter().map(|(_, m)| m).collect()
}

fn events(a: &mut Agent) -> Vec<AgentEvent> {
    std::iter::from_fn(|| a.poll_event()).collect()
}

fn subs(a: &Agent) -> Vec<&str> {
    a.subscriptions().iter().map(|s| s.as_str()).collect()
}

/// Bids for `ann` at `at` and wins it at once; the bid, ack and Start are drained.
fn win(a: &mut Agent, at: Time, ann: &Announcement) {
    assert!(announce(a, at, ann));
    assert!(say(a, at, ann, award(ann, "r1")));
    assert_eq!(a.mode(), AgentMode::Working);
    sent(a);
    events(a);
}

#[test]
fn a_new_robot_listens_on_its_resources_and_idle() {
    let a = robot("mobile camera");
    assert_eq!(subs(&a), ["camera", "idle", "mobile"]);
    assert_eq!(a.mode(), AgentMode::Idle);
    assert_eq!(a.poll_timeout(), Some(t(1000)));
}

#[test]
fn an_announcement_it_can_do_gets_a_bid_with_its_score() {
    let mut a = robot("camera mobile");
    let ann = task(7, "mobile");
    assert!(announce(&mut a, t(10), &ann));
    assert_eq!(
        sent(&mut a),
        [(
            "murdoch.u.7.1".to_string(),
            Negotiation::Bid(Bid {
                task: 7,
                bidder: token("r1"),
                score: 5.0
            })
        )]
    );
    assert_eq!(a.open_bids(), 1);
    assert_eq!(a.stats().bids, 1);
    assert!(a.subscriptions().contains("murdoch.u.7.1"));
    // It waits for the award until the deadline plus the grace.
    assert_eq!(a.poll_timeout(), Some(t(10 + 200 + 500)));
}

#[test]
fn an_announcement_needing_more_than_it_has_is_not_bid_for() {
    let mut a = robot("mobile");
    let ann = task(7, "camera mobile");
    assert!(
        !announce(&mut a, t(0), &ann),
        "the hub would not deliver it"
    );
    // Even handed over directly, it does not bid.
    let bytes = sealed_announcement(&ann);
    a.handle_packet(t(0), &Packet::parse(&bytes).unwrap());
    assert!(sent(&mut a).is_empty());
    assert_eq!(a.open_bids(), 0);
}

#[test]
fn the_same_announcement_heard_twice_gets_one_bid() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    announce(&mut a, t(0), &ann);
    announce(&mut a, t(5), &ann);
    assert_eq!(sent(&mut a).len(), 1);
    assert_eq!(a.stats().bids, 1);
}

#[test]
fn a_score_beyond_what_metrics_add_up_to_is_not_bid() {
    let mut a = robot("mobile");
    a.metrics_mut().insert("huge", |_, _| Some(1e300));
    let mut ann = task(7, "mobile");
    ann.spec = ann.spec.metric("huge", 1.0);
    announce(&mut a, t(0), &ann);
    assert!(messages(&mut a).is_empty());
    assert!(
        matches!(&events(&mut a)[..], [AgentEvent::Skipped { why, .. }] if why.contains("outside"))
    );
}

#[test]
fn a_task_it_cannot_score_is_skipped_with_the_reason() {
    let mut a = robot("mobile");
    let mut ann = task(7, "mobile");
    ann.spec = ann.spec.metric("charisma", 1.0);
    announce(&mut a, t(0), &ann);
    assert!(sent(&mut a).is_empty());
    assert_eq!(
        events(&mut a),
        [AgentEvent::Skipped {
            task: 7,
            name: "goto".into(),
            why: "unknown metric `charisma`".into()
        }]
    );
}

#[test]
fn a_task_that_would_drain_the_battery_below_the_threshold_is_skipped() {
    let mut a = Agent::new(
        token("r1"),
        "mobile".parse().unwrap(),
        AgentConfig {
            drain_per_second: 0.05,
            ..AgentConfig::default()
        },
        Time::ZERO,
    );
    a.set_battery(0.6);
    // 10 s at 0.05/s leaves 0.1, below 0.2.
    announce(&mut a, t(0), &task(7, "mobile"));
    assert!(sent(&mut a).is_empty());
    assert!(matches!(&events(&mut a)[..],
        [AgentEvent::Skipped { why, .. }] if why.contains("battery 0.60 would fall below 0.20")));
    // 10 s at 0.03/s leaves 0.3: it bids.
    let mut b = Agent::new(
        token("r1"),
        "mobile".parse().unwrap(),
        AgentConfig {
            drain_per_second: 0.03,
            ..AgentConfig::default()
        },
        Time::ZERO,
    );
    b.set_battery(0.6);
    b.set_position(Vec2::ZERO);
    announce(&mut b, t(0), &task(7, "mobile"));
    assert_eq!(b.stats().bids, 1);
}

#[test]
fn a_better_bid_sends_it_back_to_listening_without_a_word() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    announce(&mut a, t(0), &ann);
    sent(&mut a);
    assert!(say(&mut a, t(3), &ann, bid_by(&ann, "r9", 4.0)));
    assert_eq!(a.open_bids(), 0);
    assert_eq!(subs(&a), ["idle", "mobile"]);
    assert!(sent(&mut a).is_empty(), "a loser need not decline");
    // The award to the better bidder no longer reaches it.
    assert!(!say(&mut a, t(200), &ann, award(&ann, "r9")));
    assert_eq!(a.mode(), AgentMode::Idle);
}

#[test]
fn a_worse_bid_or_its_own_echo_leaves_it_bidding() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    announce(&mut a, t(0), &ann);
    say(&mut a, t(1), &ann, bid_by(&ann, "r1", 5.0));
    say(&mut a, t(2), &ann, bid_by(&ann, "r0", 6.0));
    assert_eq!(a.open_bids(), 1);
}

#[test]
fn an_equal_bid_from_a_lower_token_beats_it_and_from_a_higher_does_not() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    announce(&mut a, t(0), &ann);
    say(&mut a, t(1), &ann, bid_by(&ann, "r2", 5.0));
    assert_eq!(a.open_bids(), 1);
    say(&mut a, t(2), &ann, bid_by(&ann, "r0", 5.0));
    assert_eq!(a.open_bids(), 0);
}

#[test]
fn a_bid_for_another_task_on_the_subject_is_ignored() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    announce(&mut a, t(0), &ann);
    let other = Negotiation::Bid(Bid {
        task: 8,
        bidder: token("r0"),
        score: 0.0,
    });
    say(&mut a, t(1), &ann, other);
    assert_eq!(a.open_bids(), 1);
}

#[test]
fn an_award_to_someone_else_sends_it_back_to_listening() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    announce(&mut a, t(0), &ann);
    sent(&mut a);
    say(&mut a, t(200), &ann, award(&ann, "r9"));
    assert_eq!(a.open_bids(), 0);
    assert_eq!(a.mode(), AgentMode::Idle);
    assert!(!a.subscriptions().contains("murdoch.u.7.1"));
    assert!(sent(&mut a).is_empty());
}

#[test]
fn no_award_by_the_deadline_and_grace_drops_the_bid() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    announce(&mut a, t(100), &ann);
    a.handle_timeout(t(799));
    assert_eq!(a.open_bids(), 1);
    a.handle_timeout(t(800));
    assert_eq!(a.open_bids(), 0);
    assert_eq!(subs(&a), ["idle", "mobile"]);
    assert_eq!(a.mode(), AgentMode::Idle);
}

#[test]
fn winning_acknowledges_starts_and_stops_listening_for_tasks() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    announce(&mut a, t(0), &ann);
    sent(&mut a);
    assert!(say(&mut a, t(200), &ann, award(&ann, "r1")));
    assert_eq!(
        messages(&mut a),
        [Negotiation::Ack {
            task: 7,
            bidder: token("r1")
        }]
    );
    assert_eq!(events(&mut a), [AgentEvent::Start(ann.clone())]);
    assert_eq!(a.mode(), AgentMode::Working);
    assert_eq!(a.current_task(), Some(&ann));
    assert_eq!(subs(&a), ["mobile", "murdoch.u.7.1"]);
    assert_eq!(a.stats().started, 1);
    // Working, it hears no announcement.
    assert!(!announce(&mut a, t(250), &task(8, "mobile")));
}

#[test]
fn winning_one_auction_withdraws_its_other_bids() {
    let mut a = robot("mobile");
    let (first, second) = (task(7, "mobile"), task(8, "mobile"));
    announce(&mut a, t(0), &first);
    announce(&mut a, t(0), &second);
    sent(&mut a);
    say(&mut a, t(200), &first, award(&first, "r1"));
    assert_eq!(
        sent(&mut a),
        [
            (
                "murdoch.u.7.1".to_string(),
                Negotiation::Ack {
                    task: 7,
                    bidder: token("r1")
                }
            ),
            (
                "murdoch.u.8.1".to_string(),
                Negotiation::Decline {
                    task: 8,
                    bidder: token("r1")
                }
            ),
        ]
    );
    assert_eq!(a.open_bids(), 0);
    assert!(!a.subscriptions().contains("murdoch.u.8.1"));
}

#[test]
fn the_winner_renews_every_interval_with_its_progress() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    win(&mut a, t(200), &ann);
    assert_eq!(a.poll_timeout(), Some(t(1200)));
    a.handle_timeout(t(700));
    assert!(sent(&mut a).is_empty(), "no renewal before it is due");
    a.set_progress(0.4);
    a.handle_timeout(t(1200));
    assert_eq!(
        messages(&mut a),
        [Negotiation::Renew {
            task: 7,
            by: token("r1"),
            progress: Some(0.4)
        }]
    );
    say(&mut a, t(1500), &ann, renew_by(&ann, "u"));
    assert_eq!(a.poll_timeout(), Some(t(2200)));
    a.handle_timeout(t(2200));
    assert_eq!(messages(&mut a).len(), 1);
    assert_eq!(a.mode(), AgentMode::Working);
}

#[test]
fn progress_is_clamped_and_nan_counts_as_none_done() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    win(&mut a, t(0), &ann);
    for (set, want) in [(1.7, 1.0), (-3.0, 0.0), (f64::NAN, 0.0)] {
        a.set_progress(set);
        let now = a.poll_timeout().unwrap();
        say(&mut a, now, &ann, renew_by(&ann, "u"));
        a.handle_timeout(now);
        assert!(
            matches!(&messages(&mut a)[..],
            [Negotiation::Renew { progress: Some(p), .. }] if *p == want),
            "{set}"
        );
    }
}

#[test]
fn an_announcer_gone_silent_is_abandoned_after_the_timeout() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    win(&mut a, t(0), &ann);
    a.handle_timeout(t(1000));
    a.handle_timeout(t(2000));
    assert_eq!(messages(&mut a).len(), 2, "two renewals");
    assert_eq!(a.poll_timeout(), Some(t(3000)));
    a.handle_timeout(t(3000));
    assert_eq!(
        messages(&mut a),
        [Negotiation::Abandon {
            task: 7,
            bidder: token("r1"),
            reason: "announcer u silent for 3.0 s".into()
        }]
    );
    assert_eq!(
        events(&mut a),
        [AgentEvent::Stop {
            task: 7,
            name: "goto".into(),
            reason: StopReason::AnnouncerSilent
        }]
    );
    assert_eq!(a.mode(), AgentMode::Idle);
    assert_eq!(a.current_task(), None);
    assert_eq!(subs(&a), ["idle", "mobile"]);
    assert_eq!(a.stats().stopped, 1);
}

#[test]
fn the_announcers_renewals_keep_the_task_alive() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    win(&mut a, t(0), &ann);
    say(&mut a, t(2500), &ann, renew_by(&ann, "u"));
    a.handle_timeout(t(3000));
    assert_eq!(a.mode(), AgentMode::Working);
    a.handle_timeout(t(5499));
    assert_eq!(a.mode(), AgentMode::Working);
    a.handle_timeout(t(5500));
    assert_eq!(a.mode(), AgentMode::Idle);
}

#[test]
fn only_the_announcers_renewals_count() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    win(&mut a, t(0), &ann);
    say(&mut a, t(2500), &ann, renew_by(&ann, "r1"));
    say(&mut a, t(2600), &ann, renew_by(&ann, "stranger"));
    a.handle_timeout(t(3000));
    assert_eq!(a.mode(), AgentMode::Idle);
}

#[test]
fn a_repeated_award_is_acknowledged_again() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    win(&mut a, t(0), &ann);
    say(&mut a, t(1100), &ann, award(&ann, "r1"));
    assert_eq!(
        messages(&mut a),
        [Negotiation::Ack {
            task: 7,
            bidder: token("r1")
        }]
    );
    // And it counts as hearing from the announcer.
    a.handle_timeout(t(3000));
    assert_eq!(a.mode(), AgentMode::Working);
    assert!(events(&mut a).is_empty());
}

#[test]
fn a_cancel_stops_the_task_with_the_announcers_reason() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    win(&mut a, t(0), &ann);
    let cancel = Negotiation::Cancel {
        task: 7,
        reason: "presumed failed".into(),
    };
    say(&mut a, t(500), &ann, cancel);
    assert_eq!(
        events(&mut a),
        [AgentEvent::Stop {
            task: 7,
            name: "goto".into(),
            reason: StopReason::Cancelled("presumed failed".into())
        }]
    );
    assert_eq!(a.mode(), AgentMode::Idle);
    assert!(sent(&mut a).is_empty());
    assert!(a.subscriptions().contains("idle"));
}

#[test]
fn finishing_says_done_and_keeps_answering_renewals_until_the_linger_ends() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    win(&mut a, t(0), &ann);
    assert_eq!(a.finish(t(4000)), Some(7));
    let done = || Negotiation::Done {
        task: 7,
        bidder: token("r1"),
    };
    assert_eq!(messages(&mut a), [done()]);
    assert_eq!(a.mode(), AgentMode::Idle);
    assert_eq!(a.stats().finished, 1);
    // The announcer did not hear it and renews: done again.
    assert!(say(&mut a, t(5000), &ann, renew_by(&ann, "u")));
    assert_eq!(messages(&mut a), [done()]);
    // Its own renewal echoing back is not answered.
    say(&mut a, t(5100), &ann, renew_by(&ann, "r1"));
    assert!(sent(&mut a).is_empty());
    a.handle_timeout(t(7000));
    assert!(!a.subscriptions().contains("murdoch.u.7.1"));
    assert_eq!(a.finish(t(7000)), None);
}

#[test]
fn abandoning_tells_the_announcer_why() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    win(&mut a, t(0), &ann);
    assert_eq!(a.abandon(t(100), "stuck"), Some(7));
    assert_eq!(
        messages(&mut a),
        [Negotiation::Abandon {
            task: 7,
            bidder: token("r1"),
            reason: "stuck".into()
        }]
    );
    assert_eq!(a.mode(), AgentMode::Idle);
    assert!(!a.subscriptions().contains("murdoch.u.7.1"));
    assert_eq!(a.abandon(t(200), "again"), None);
}
