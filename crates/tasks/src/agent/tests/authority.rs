//! Others' authority: awards, cancels, renewals and bids it must not take from the wrong key.

use super::*;

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
