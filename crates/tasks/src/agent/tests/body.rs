//! The agent's body: its battery and its resources.

use super::*;

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
