//! Box pushing (section 6.1) in the physics field.

use colony_lab::tasks::boxpush::{run, BoxPush, BoxPushConfig};
use colony_lab::tasks::Progress;

fn show(name: &str, out: &colony_lab::tasks::boxpush::BoxPushOutcome) {
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

/// The goal moves from (360, 400) to (520, 430) at 45 s.
fn moving(off_at: Option<f64>, on_at: Option<f64>) -> BoxPushConfig {
    BoxPushConfig {
        move_goal: Some((45.0, colony_proto::Vec2::new(520.0, 430.0))),
        off_at,
        on_at,
        ..BoxPushConfig::default()
    }
}

#[test]
fn the_box_reaches_a_goal_moved_mid_run_with_both_pushers() {
    let cfg = moving(None, None);
    let mut run = BoxPush::new(&cfg).unwrap();
    let watcher_start = run.robot_poses()[2];
    let mut moved_at = None;
    while run.step().unwrap() == Progress::Running {
        if moved_at.is_none() && run.goal() != cfg.goal {
            moved_at = Some(run.now_s());
        }
    }
    let watcher_end = run.robot_poses()[2];
    let goal = run.goal();
    let out = run.finish();
    show("moving goal", &out);
    let r = &out.report;
    assert!(r.reached, "{r:?}");
    assert!((moved_at.unwrap() - 45.0).abs() < 0.5);
    assert_eq!(goal, colony_proto::Vec2::new(520.0, 430.0));
    assert!(
        r.final_distance_cm <= cfg.tolerance_cm,
        "at the moved goal: {r:?}"
    );
    assert!(r.pushes_by.iter().all(|&n| n > 0), "{r:?}");
    // The watcher led the box: it drove most of the way with it.
    let driven = watcher_start.position().distance(watcher_end.position());
    assert!(driven > 150.0, "the watcher drove {driven:.0} cm");
    assert!(out
        .events
        .iter()
        .any(|(_, e)| e.starts_with("the goal moved to (520, 430)")));
}

#[test]
fn the_box_reaches_a_moved_goal_with_one_pusher_switched_off_and_on_again() {
    let out = run(&moving(Some(30.0), Some(90.0))).unwrap();
    show("moving goal, off and on", &out);
    let r = &out.report;
    assert!(r.reached, "{r:?}");
    assert!(r.final_distance_cm <= 25.0);
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
                move_goal: Some((10.0, colony_proto::Vec2::new(100.0, -5.0))),
                ..BoxPushConfig::default()
            },
            "the goal (100, -5) is off the 700 x 600 cm field",
        ),
        (
            BoxPushConfig {
                move_goal: Some((f64::INFINITY, colony_proto::Vec2::new(100.0, 100.0))),
                ..BoxPushConfig::default()
            },
            "the goal's move must be at a time in seconds, not inf",
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
