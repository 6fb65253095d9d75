//! Box pushing (section 6.1) in the physics field.

use colony_tasks::experiment::boxpush::{run, BoxPush, BoxPushConfig};
use colony_tasks::experiment::Progress;

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

#[test]
fn a_run_stepped_by_hand_is_the_same_run_and_the_box_can_be_watched_moving() {
    let cfg = BoxPushConfig::default();
    let whole = run(&cfg).unwrap();
    let mut stepped = BoxPush::new(&cfg).unwrap();
    let start = stepped.box_pose().position().distance(cfg.goal);
    let mut closest = start;
    while stepped.step().unwrap() == Progress::Running {
        closest = closest.min(stepped.box_pose().position().distance(cfg.goal));
    }
    assert!(closest <= cfg.tolerance_cm && start > cfg.tolerance_cm);
    let end = stepped.now_s();
    assert_eq!(stepped.step().unwrap(), Progress::Done);
    assert_eq!(stepped.now_s(), end, "a finished run stays finished");
    let out = stepped.finish();
    assert_eq!(out.report, whole.report);
    assert_eq!(out.track, whole.track);
    assert_eq!(out.events, whole.events);
}

#[test]
fn settings_a_run_cannot_be_made_with_are_refused_with_the_reason() {
    for (cfg, want) in [
        (
            BoxPushConfig {
                on_at: Some(10.0),
                ..BoxPushConfig::default()
            },
            "--on-at needs --off-at",
        ),
        (
            BoxPushConfig {
                off_at: Some(20.0),
                on_at: Some(10.0),
                ..BoxPushConfig::default()
            },
            "--on-at (10) must come after --off-at (20)",
        ),
        (
            BoxPushConfig {
                goal: colony_proto::Vec2::new(900.0, 100.0),
                ..BoxPushConfig::default()
            },
            "the goal (900, 100) is off the 700 x 600 cm field",
        ),
        (
            BoxPushConfig {
                max_s: f64::NAN,
                ..BoxPushConfig::default()
            },
            "must be finite",
        ),
    ] {
        let e = run(&cfg).expect_err("refused").to_string();
        assert!(e.contains(want), "{e}");
    }
}
