//! The agent's state machine, driven by hand on simulated time.

use std::time::Duration;

use super::*;
use crate::protocol::negotiation_subject;
use crate::protocol::TaskSpec;
use crate::test_keys::{seal_as, speaker};

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

#[test]
fn a_low_battery_while_idle_unsubscribes_from_everything_at_the_check() {
    let mut a = robot("camera mobile");
    let ann = task(7, "mobile");
    announce(&mut a, t(900), &ann);
    sent(&mut a);
    a.set_battery(0.1);
    a.handle_timeout(t(999));
    assert_eq!(a.mode(), AgentMode::Idle, "it looks only at the check");
    a.handle_timeout(t(1000));
    assert_eq!(a.mode(), AgentMode::Charging);
    assert!(a.subscriptions().is_empty());
    assert_eq!(events(&mut a), [AgentEvent::Charge]);
    // Its open bid is withdrawn so the auction need not wait for it.
    assert_eq!(
        messages(&mut a),
        [Negotiation::Decline {
            task: 7,
            bidder: token("r1")
        }]
    );
    assert_eq!(a.open_bids(), 0);
    assert_eq!(a.poll_timeout(), None);
    assert_eq!(a.stats().charges, 1);
}

#[test]
fn a_charging_robot_ignores_even_an_announcement_handed_to_it() {
    let mut a = robot("mobile");
    a.set_battery(0.0);
    a.handle_timeout(t(1000));
    assert!(!announce(&mut a, t(1100), &task(7, "mobile")));
    let bytes = sealed_announcement(&task(7, "mobile"));
    a.handle_packet(t(1100), &Packet::parse(&bytes).unwrap());
    assert!(sent(&mut a).is_empty());
}

#[test]
fn charged_rejoins_and_resumes_battery_checks() {
    let mut a = robot("mobile");
    a.set_battery(0.1);
    a.handle_timeout(t(1000));
    events(&mut a);
    a.charged(t(5000));
    assert_eq!(events(&mut a), [AgentEvent::Rejoined]);
    assert_eq!(a.mode(), AgentMode::Idle);
    assert_eq!(subs(&a), ["idle", "mobile"]);
    assert_eq!(a.poll_timeout(), Some(t(6000)));
    // Still low: back to the charger at the next check.
    a.handle_timeout(t(6000));
    assert_eq!(a.mode(), AgentMode::Charging);
    // charged() while not charging does nothing.
    let mut b = robot("mobile");
    b.charged(t(10));
    assert!(events(&mut b).is_empty());
}

#[test]
fn a_low_battery_while_working_waits_for_the_end_of_the_task() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    win(&mut a, t(0), &ann);
    a.set_battery(0.05);
    say(&mut a, t(900), &ann, renew_by(&ann, "u"));
    a.handle_timeout(t(1000));
    assert_eq!(a.mode(), AgentMode::Working);
    assert!(matches!(&messages(&mut a)[..], [Negotiation::Renew { .. }]));
    a.finish(t(1500));
    assert_eq!(a.mode(), AgentMode::Charging);
    assert_eq!(events(&mut a), [AgentEvent::Charge]);
    // It said done before it left, but lingers no more.
    assert!(matches!(&messages(&mut a)[..], [Negotiation::Done { .. }]));
    assert!(a.subscriptions().is_empty());
}

#[test]
fn battery_levels_are_clamped_and_nan_is_flat() {
    let mut a = robot("mobile");
    a.set_battery(2.0);
    assert_eq!(a.battery(), 1.0);
    a.set_battery(-1.0);
    assert_eq!(a.battery(), 0.0);
    a.set_battery(f64::NAN);
    assert_eq!(a.battery(), 0.0);
}

#[test]
fn a_malformed_packet_is_reported_and_changes_nothing() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    announce(&mut a, t(0), &ann);
    sent(&mut a);
    let bad = b"@ <murdoch.u.7.1> 0\nbid task 7 bidder r0 score lots\n";
    assert!(hear(&mut a, t(1), &seal_as("r0", bad.to_vec())));
    assert_eq!(a.open_bids(), 1);
    assert_eq!(a.stats().rejected, 1);
    assert!(
        matches!(&events(&mut a)[..], [AgentEvent::Rejected(e)] if e.to_string().contains("`score`"))
    );
}

#[test]
fn the_event_queue_keeps_only_the_newest() {
    let mut a = robot("mobile");
    for _ in 0..MAX_EVENTS + 5 {
        hear(&mut a, t(0), b"@ <idle> 0\nnonsense task 1\n");
    }
    assert_eq!(events(&mut a).len(), MAX_EVENTS);
    assert_eq!(a.stats().rejected, MAX_EVENTS as u64 + 5);
}

#[test]
fn losing_a_resource_gives_up_the_task_that_needs_it_and_stops_hearing_its_announcements() {
    let mut a = robot("mobile,laser,camera");
    let ann = task(7, "mobile,laser");
    win(&mut a, t(0), &ann);
    assert!(a.subscriptions().contains("laser"));
    assert_eq!(
        a.set_resources(t(500), "mobile,camera".parse().unwrap()),
        Some(7)
    );
    assert_eq!(
        messages(&mut a),
        [Negotiation::Abandon {
            task: 7,
            bidder: token("r1"),
            reason: "lost resource laser".into()
        }]
    );
    assert_eq!(
        events(&mut a),
        [AgentEvent::Stop {
            task: 7,
            name: "goto".into(),
            reason: StopReason::LostResource("laser".into())
        }]
    );
    assert_eq!(a.mode(), AgentMode::Idle);
    assert!(!a.subscriptions().contains("laser"));
    // An announcement that needs the laser no longer reaches it; one it can serve does.
    assert!(!announce(&mut a, t(600), &task(8, "laser")));
    assert!(announce(&mut a, t(600), &task(9, "camera")));
    // Repaired, it hears laser tasks again.
    assert_eq!(
        a.set_resources(t(700), "mobile,laser,camera".parse().unwrap()),
        None
    );
    assert!(a.subscriptions().contains("laser"));
}

#[test]
fn losing_a_resource_declines_a_bid_that_needs_it_and_keeps_a_task_that_does_not() {
    let mut a = robot("mobile,laser");
    let ann = task(7, "laser");
    assert!(announce(&mut a, t(0), &ann));
    sent(&mut a);
    assert_eq!(a.set_resources(t(10), "mobile".parse().unwrap()), None);
    assert_eq!(
        messages(&mut a),
        [Negotiation::Decline {
            task: 7,
            bidder: token("r1")
        }]
    );
    assert_eq!(a.open_bids(), 0);
    let mut b = robot("mobile,laser");
    win(&mut b, t(0), &task(3, "mobile"));
    assert_eq!(b.set_resources(t(10), "mobile".parse().unwrap()), None);
    assert_eq!(b.mode(), AgentMode::Working);
}

/// What a reporting robot reported, in order: (mode, battery, resources, task).
fn reports(a: &mut Agent) -> Vec<(AgentMode, f64, String, Option<u64>)> {
    std::iter::from_fn(|| a.poll_transmit())
        .filter_map(|p| match Message::decode_bytes(&p).unwrap() {
            Message::Robot(r) => Some((
                r.mode,
                r.battery,
                r.resources.to_string(),
                r.task.map(|(id, _)| id),
            )),
            _ => None,
        })
        .collect()
}

#[test]
fn a_robot_reports_at_start_every_interval_and_at_each_change() {
    let mut a = Agent::new(
        token("r1"),
        "mobile".parse().unwrap(),
        AgentConfig::default(),
        Time::ZERO,
    );
    a.set_position(Vec2::ZERO);
    assert_eq!(a.poll_timeout(), Some(Time::ZERO));
    a.handle_timeout(Time::ZERO);
    assert_eq!(
        reports(&mut a),
        [(AgentMode::Idle, 1.0, "{mobile}".into(), None)]
    );
    // Nothing new before the interval...
    a.handle_timeout(t(500));
    assert_eq!(reports(&mut a), []);
    // ...then the same again.
    a.set_battery(0.5);
    a.handle_timeout(t(1000));
    assert_eq!(
        reports(&mut a),
        [(AgentMode::Idle, 0.5, "{mobile}".into(), None)]
    );
    // Winning is reported at once, with the task.
    let ann = task(7, "mobile");
    assert!(announce(&mut a, t(1100), &ann));
    assert!(say(&mut a, t(1300), &ann, award(&ann, "r1")));
    assert_eq!(
        reports(&mut a),
        [(AgentMode::Working, 0.5, "{mobile}".into(), Some(7))]
    );
    // So is a lost resource, and the task given up with it.
    a.set_resources(t(1400), "".parse().unwrap());
    let r = reports(&mut a);
    assert_eq!(r.last(), Some(&(AgentMode::Idle, 0.5, "{}".into(), None)));
}

#[test]
fn a_robot_told_not_to_report_never_does() {
    let mut a = robot("mobile");
    a.handle_timeout(Time::ZERO);
    a.handle_timeout(t(5000));
    assert_eq!(reports(&mut a), []);
    assert_ne!(a.poll_timeout(), Some(Time::ZERO));
}

// Attacks from other processes on the hub: each message below is sealed by
// a key other than the one the task is bound to, or is a copy of one taken.

#[test]
fn an_award_from_another_key_is_not_taken() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    assert!(announce(&mut a, t(0), &ann));
    sent(&mut a);
    assert!(say_as(&mut a, t(100), &ann, "mallory", award(&ann, "r1")));
    assert_eq!(a.mode(), AgentMode::Idle);
    assert_eq!(a.open_bids(), 1, "still waiting for the real award");
    assert_eq!(a.stats().forged, 1);
    assert!(say(&mut a, t(200), &ann, award(&ann, "r1")));
    assert_eq!(a.mode(), AgentMode::Working);
}

#[test]
fn a_cancel_from_another_key_does_not_stop_the_task() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    win(&mut a, t(0), &ann);
    let cancel = Negotiation::Cancel {
        task: 7,
        reason: "forged".into(),
    };
    say_as(&mut a, t(500), &ann, "mallory", cancel);
    assert_eq!(a.mode(), AgentMode::Working);
    assert!(events(&mut a).is_empty());
    assert_eq!(a.stats().forged, 1);
}

#[test]
fn a_copy_of_the_announcers_renewal_keeps_no_task_alive() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    win(&mut a, t(0), &ann);
    let bytes = seal_as("u", renew_by(&ann, "u").encode(&ann.negotiation).unwrap());
    for ms in (500..=3500).step_by(500) {
        hear(&mut a, t(ms), &bytes);
        a.handle_timeout(t(ms));
    }
    // Taken once at 500 ms; silent since, the announcer is presumed gone.
    assert_eq!(a.mode(), AgentMode::Idle);
}

#[test]
fn a_bid_in_its_own_name_or_past_the_metrics_does_not_make_it_withdraw() {
    let mut a = robot("mobile");
    let ann = task(7, "mobile");
    assert!(announce(&mut a, t(0), &ann));
    sent(&mut a);
    // Its own name from another key, then a score no robot can reach.
    say_as(&mut a, t(10), &ann, "mallory", bid_by(&ann, "r1", 0.0));
    say(&mut a, t(20), &ann, bid_by(&ann, "rogue", -1e12));
    assert_eq!(a.open_bids(), 1);
    assert_eq!(a.stats().forged, 2);
    // A real better bid still beats it.
    say(&mut a, t(30), &ann, bid_by(&ann, "r0", 1.0));
    assert_eq!(a.open_bids(), 0);
}

#[test]
fn an_unsealed_announcement_gets_no_bid() {
    let mut a = robot("mobile");
    let bytes = task(7, "mobile").encode().unwrap();
    assert!(hear(&mut a, t(0), &bytes));
    assert!(sent(&mut a).is_empty());
    assert_eq!(a.stats().rejected, 1);
}
