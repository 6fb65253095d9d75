//! What the agent says of itself: its reports, malformed packets, its event queue.

use super::*;

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
