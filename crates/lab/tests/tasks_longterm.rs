//! The long-term experiment (section 6.2) on simulated time.

use colony_lab::tasks::longterm::{run, Longterm, LongtermConfig, IMPOSSIBLE_TASK};
use colony_lab::tasks::Progress;

#[test]
fn a_long_run_completes_most_achievable_tasks_within_its_hours_and_reports_the_rest() {
    let cfg = LongtermConfig {
        hours: 3.0,
        seed: 7,
        ..LongtermConfig::default()
    };
    let out = run(&cfg).unwrap();
    let r = &out.report;
    println!("{}", serde_json::to_string_pretty(r).unwrap());
    assert!(r.introduced >= 50, "{r:?}");
    // Exactly the hours asked for: every request is done, given up, or still open then.
    assert_eq!(r.simulated_s, 3.0 * 3600.0);
    assert_eq!(
        r.completed + r.gave_up + r.open_at_end,
        r.introduced,
        "{r:?}"
    );
    assert_eq!(r.completed, r.completed_achievable);
    assert_eq!(r.gave_up_achievable, 0);
    assert!(r.completed_achievable * 10 >= r.achievable * 8, "{r:?}");
    assert!(r.recharges > 0 && r.failures > 0, "{r:?}");
    assert!(r.unachievable_reports > 0);
    // Every report has one cause; "no robot has what it needs" is exactly
    // the task nobody in the roster can do.
    assert_eq!(
        r.unachievable_no_robot
            + r.unachievable_busy
            + r.unachievable_charging
            + r.unachievable_failed,
        r.unachievable_reports,
        "{r:?}"
    );
    let impossible = out
        .log
        .iter()
        .filter(|l| l.kind == "unachievable" && l.task == IMPOSSIBLE_TASK.name)
        .count() as u64;
    assert_eq!(r.unachievable_no_robot, impossible, "{r:?}");
    assert!(r.messages_per_allocation > 3.0);
    assert!(out.log.iter().any(|l| l.kind == "unachievable"
        && l.detail
            .contains("no robot with {gripper mobile} is available")));
}

#[test]
fn the_same_seed_gives_the_same_run() {
    let cfg = LongtermConfig {
        hours: 0.5,
        seed: 3,
        ..LongtermConfig::default()
    };
    let a = run(&cfg).unwrap();
    let b = run(&cfg).unwrap();
    assert_eq!(a.report, b.report);
    assert_eq!(a.log, b.log);
    let other = run(&LongtermConfig { seed: 4, ..cfg }).unwrap();
    assert_ne!(a.log, other.log);
}

#[test]
fn bad_settings_are_refused_with_a_reason() {
    for (cfg, want) in [
        (
            LongtermConfig {
                hours: -1.0,
                ..LongtermConfig::default()
            },
            "hours",
        ),
        (
            LongtermConfig {
                hours: f64::NAN,
                ..LongtermConfig::default()
            },
            "hours",
        ),
        (
            LongtermConfig {
                length_s: (5.0, 1.0),
                ..LongtermConfig::default()
            },
            "lengths",
        ),
        (
            LongtermConfig {
                chargers: vec![],
                ..LongtermConfig::default()
            },
            "charger",
        ),
    ] {
        let e = run(&cfg).unwrap_err().to_string();
        assert!(e.contains(want), "{e}");
    }
}

#[test]
fn a_run_stepped_by_hand_is_the_same_run_and_can_be_watched_on_the_way() {
    let cfg = LongtermConfig {
        hours: 0.5,
        seed: 3,
        ..LongtermConfig::default()
    };
    let whole = run(&cfg).unwrap();
    let mut stepped = Longterm::new(&cfg).unwrap();
    let (mut rows, mut steps) = (0, 0);
    while stepped.step().unwrap() == Progress::Running {
        steps += 1;
        assert_eq!(stepped.now().as_secs_f64(), steps as f64);
        assert!(stepped.log().len() >= rows, "the log only grows");
        rows = stepped.log().len();
    }
    assert!(stepped.report().introduced > 0);
    let end = stepped.now();
    assert_eq!(stepped.step().unwrap(), Progress::Done);
    assert_eq!(stepped.now(), end, "a finished run stays finished");
    let out = stepped.finish();
    assert_eq!(out.report, whole.report);
    assert_eq!(out.log, whole.log);
}

#[test]
fn a_run_stopped_part_way_reports_what_happened_until_then() {
    let cfg = LongtermConfig {
        hours: 0.5,
        seed: 3,
        ..LongtermConfig::default()
    };
    let whole = run(&cfg).unwrap();
    let mut part = Longterm::new(&cfg).unwrap();
    for _ in 0..600 {
        assert_eq!(part.step().unwrap(), Progress::Running);
    }
    let out = part.finish();
    assert_eq!(out.report.simulated_s, 600.0);
    assert!(out.log.iter().all(|r| r.time_s <= 600.0));
    assert_eq!(out.log[..], whole.log[..out.log.len()]);
    assert!(out.report.introduced < whole.report.introduced);
}
