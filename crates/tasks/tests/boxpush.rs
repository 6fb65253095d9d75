//! Box pushing (section 6.1) in the physics field.

use colony_tasks::experiment::boxpush::{run, BoxPushConfig};

fn show(name: &str, out: &colony_tasks::experiment::boxpush::BoxPushOutcome) {
    println!("== {name}: {:?}", out.report);
    for (t, e) in &out.events {
        println!("  {t:7.1} {e}");
    }
    for (t, p) in out.track.iter().step_by(10) {
        println!("  {t:7.1} box ({:.0}, {:.0}) {:.2}", p.x, p.y, p.theta);
    }
}

#[test]
fn two_pushers_move_the_box_to_the_goal() {
    let out = run(&BoxPushConfig::default()).unwrap();
    show("two", &out);
    let r = &out.report;
    assert!(r.reached, "{r:?}");
    assert!(
        r.pushes_by.iter().all(|&n| n > 0),
        "both pushers pushed: {r:?}"
    );
}

#[test]
fn one_pusher_switched_off_halfway_leaves_the_other_to_see_saw_the_box_home() {
    let cfg = BoxPushConfig {
        off_at: Some(30.0),
        ..BoxPushConfig::default()
    };
    let out = run(&cfg).unwrap();
    show("off", &out);
    let r = &out.report;
    assert!(r.reached, "{r:?}");
    assert!(r.pushes_left > 0 && r.pushes_right > 0);
    assert!(
        r.unachievable > 0,
        "the missing pusher's tasks are reported: {r:?}"
    );
}

#[test]
fn a_pusher_switched_on_again_rejoins_the_team() {
    let cfg = BoxPushConfig {
        off_at: Some(30.0),
        on_at: Some(90.0),
        ..BoxPushConfig::default()
    };
    let out = run(&cfg).unwrap();
    show("off-on", &out);
    let r = &out.report;
    assert!(r.reached, "{r:?}");
    assert!(out
        .events
        .iter()
        .any(|(_, e)| e.contains("switched on again")));
}
