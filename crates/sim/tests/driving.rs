use colony_sim::{SceneConfig, Vec2, WheelCommand, World};
use colony_testkit::sim::{angle_diff, pose, scene, FORWARD, LEFT};

#[test]
fn full_speed_forward_covers_20_cm_per_second() {
    let mut world = scene(pose(-60.0, 0.0, 0.0), &[]);
    let steps = 20;
    for _ in 0..steps {
        world.step(&[FORWARD]);
    }
    let travelled = world.robots()[0]
        .pose
        .position()
        .distance(Vec2::new(-60.0, 0.0));
    let expected = 20.0 * world.time();
    assert!(
        (travelled - expected).abs() < 0.15 * expected,
        "travelled {travelled} cm, expected {expected}"
    );
    // Straight: no drift sideways or in heading.
    assert!(world.robots()[0].pose.y.abs() < 0.01);
    assert!(world.robots()[0].pose.theta.abs() < 1e-3);
}

#[test]
fn half_turn_takes_about_ten_steps() {
    let mut world = scene(pose(0.0, 0.0, 0.0), &[]);
    let mut steps = 0;
    while world.robots()[0].pose.theta.abs() < std::f64::consts::PI - 0.05 && steps < 50 {
        world.step(&[LEFT]);
        steps += 1;
    }
    assert!((9..=11).contains(&steps), "half turn took {steps} steps");
    // It turns on the spot.
    assert!(world.robots()[0].pose.position().length() < 0.1);
}

#[test]
fn commands_are_clamped_and_missing_ones_mean_stop() {
    let cfg = SceneConfig::default();
    let robots = [pose(-50.0, 0.0, 0.0), pose(50.0, 0.0, 0.0)];
    let mut world = World::with_layout(&cfg, &robots, &[]).unwrap();
    let wild = WheelCommand {
        forward: 7.0,
        turn: f64::NAN,
    };
    world.step(&[wild]); // only one command for two robots
    world.step(&[wild, wild, wild]); // one too many: ignored
    let r = world.robots();
    let per_step = 20.0 * cfg.control_step_seconds();
    assert!(
        (r[0].pose.x - (-50.0 + 2.0 * per_step)).abs() < 0.05,
        "{:?}",
        r[0].pose
    );
    assert!(r[0].pose.theta.abs() < 1e-6);
    assert!(
        (r[1].pose.x - (50.0 + per_step)).abs() < 0.05,
        "{:?}",
        r[1].pose
    );
}

#[test]
fn physical_command_duration_shortens_each_move() {
    let mut cfg = SceneConfig::default();
    cfg.robots.command_duration = Some(0.075);
    let mut world = World::with_layout(&cfg, &[pose(0.0, 0.0, 0.0)], &[]).unwrap();
    for _ in 0..10 {
        world.step(&[FORWARD]);
    }
    // 75 ms of 20 cm/s per step.
    let x = world.robots()[0].pose.x;
    assert!((x - 10.0 * 0.075 * 20.0).abs() < 0.1, "x = {x}");
}

#[test]
fn a_robot_is_stopped_by_a_wall() {
    let mut world = scene(pose(70.0, 0.0, 0.0), &[]);
    for _ in 0..40 {
        world.step(&[FORWARD]);
    }
    let r = world.robots()[0];
    let front =
        r.pose.x + world.robot_shape().gripper_centre.x + world.robot_shape().gripper_radius;
    assert!(front < 93.5 + 0.6, "gripper front at {front}");
    assert!(front > 90.0, "stopped short at {front}");
    assert!(angle_diff(r.pose.theta, 0.0).abs() < 0.05);
}
