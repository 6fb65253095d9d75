use colony_sim::{RobotId, Vec2, WheelCommand};
use colony_testkit::sim::{pose, scene, BACK, FORWARD, LEFT};

#[test]
fn driving_onto_a_puck_captures_it_and_backing_away_leaves_it() {
    let start = Vec2::new(0.0, 0.0);
    let mut world = scene(pose(-40.0, 0.0, 0.0), &[start]);
    assert!(world.observe(RobotId(0)).gripper.is_none());
    // 40 cm to the puck less the gripper's reach: about 7 steps of 4.3 cm.
    let mut steps = 0;
    while world.observe(RobotId(0)).gripper.is_none() && steps < 20 {
        world.step(&[FORWARD]);
        steps += 1;
    }
    let obs = world.observe(RobotId(0));
    let held = obs.gripper.expect("the puck should be in the gripper");
    assert!(steps <= 9, "capture took {steps} steps");
    assert_eq!(world.robots()[0].carrying, Some(colony_sim::PuckId(0)));
    // Carried further, it sits in the pocket, reported where it really is.
    for _ in 0..10 {
        world.step(&[FORWARD]);
    }
    let obs = world.observe(RobotId(0));
    let held2 = obs.gripper.expect("still carried");
    let shape = world.robot_shape();
    assert!(
        held2.pos.distance(shape.gripper_centre) < 0.6,
        "puck at {:?}",
        held2.pos
    );
    assert!(
        obs.pucks.is_empty(),
        "the carried puck is not listed among seen pucks"
    );
    let actual = world.pucks()[0].pos;
    assert!(obs.pose.to_world(held2.pos).distance(actual) < 1e-6);
    assert_eq!(held.kind, held2.kind);
    // A turn on the spot keeps it.
    for _ in 0..10 {
        world.step(&[LEFT]);
    }
    assert!(
        world.observe(RobotId(0)).gripper.is_some(),
        "a turn must not lose the puck"
    );
    // Backing away leaves it behind, roughly where it was.
    let left_at = world.pucks()[0].pos;
    for _ in 0..6 {
        world.step(&[BACK]);
    }
    assert!(world.observe(RobotId(0)).gripper.is_none());
    assert_eq!(world.robots()[0].carrying, None);
    let after = world.pucks()[0].pos;
    assert!(
        after.distance(left_at) < 2.0,
        "puck moved from {left_at:?} to {after:?}"
    );
    // And the robot sees it ahead.
    let seen = world.observe(RobotId(0)).pucks;
    assert_eq!(seen.len(), 1);
    assert!(!seen[0].held_by_other);
}

#[test]
fn a_puck_slightly_off_centre_is_funnelled_into_the_gripper() {
    let mut world = scene(pose(-40.0, 0.0, 0.0), &[Vec2::new(0.0, 1.5)]);
    for _ in 0..15 {
        world.step(&[FORWARD]);
    }
    assert!(
        world.observe(RobotId(0)).gripper.is_some(),
        "puck at {:?}",
        world.pucks()[0].pos
    );
}

#[test]
fn the_gripper_holds_one_puck_and_pushes_the_next() {
    let mut world = scene(
        pose(-40.0, 0.0, 0.0),
        &[Vec2::new(0.0, 0.0), Vec2::new(7.0, 0.0)],
    );
    for _ in 0..15 {
        world.step(&[FORWARD]);
    }
    let r = world.robots()[0];
    let pocket = r.pose.to_world(world.robot_shape().gripper_centre);
    let pucks = world.pucks();
    let inside = pucks
        .iter()
        .filter(|p| p.pos.distance(pocket) < world.robot_shape().gripper_radius)
        .count();
    assert_eq!(inside, 1, "robot at {:?}, pucks {:?}", r.pose, pucks);
    // The second puck is pushed ahead of the first, outside the gripper.
    assert!(pucks[1].pos.x > pucks[0].pos.x + 3.0, "{pucks:?}");
    assert!(pucks[1].pos.distance(pucks[0].pos) > 6.0, "{pucks:?}");
    assert!(
        pucks[1].pos.x > 20.0,
        "the second puck was pushed along: {pucks:?}"
    );
}

#[test]
fn a_pushed_puck_stops_by_floor_friction() {
    // The robot backs into a puck behind it and shoves it with its flat rear.
    let mut world = scene(pose(0.0, 0.0, 0.0), &[Vec2::new(-20.0, 0.0)]);
    for _ in 0..8 {
        world.step(&[BACK]);
    }
    let pushed = world.pucks()[0].pos;
    assert!(pushed.x < -22.0, "the puck was not pushed: {pushed:?}");
    // The robot stops dead; the puck coasts a little and stops.
    for _ in 0..3 {
        world.step(&[WheelCommand::STOP]);
    }
    let a = world.pucks()[0].pos;
    assert!(a.distance(pushed) < 3.0, "coasted from {pushed:?} to {a:?}");
    for _ in 0..5 {
        world.step(&[WheelCommand::STOP]);
    }
    let b = world.pucks()[0].pos;
    assert!(a.distance(b) < 0.01, "still sliding: {a:?} -> {b:?}");
}

#[test]
fn a_free_puck_hit_at_speed_coasts_only_a_few_centimetres() {
    // A robot sweeps a puck with the side of its gripper while turning: the puck is flung and stops.
    let mut world = scene(pose(0.0, 0.0, 0.0), &[Vec2::new(8.0, 9.5)]);
    for _ in 0..4 {
        world.step(&[LEFT]);
    }
    let moved = world.pucks()[0].pos;
    for _ in 0..10 {
        world.step(&[WheelCommand::STOP]);
    }
    let rest = world.pucks()[0].pos;
    assert!(
        moved.distance(Vec2::new(8.0, 9.5)) > 0.5,
        "the puck was hit: {moved:?}"
    );
    assert!(
        rest.distance(moved) < 6.0,
        "coasted from {moved:?} to {rest:?}"
    );
}

#[test]
fn driving_through_a_cluster_pushes_and_breaks_it() {
    // A tight 3 x 3 cluster, 7 cm apart, in the robot's way.
    let mut pucks = Vec::new();
    for i in 0..3 {
        for j in 0..3 {
            pucks.push(Vec2::new(i as f64 * 7.0, (j as f64 - 1.0) * 7.0));
        }
    }
    let mut world = scene(pose(-40.0, 0.0, 0.0), &pucks);
    for _ in 0..25 {
        world.step(&[FORWARD]);
    }
    let after = world.pucks();
    let moved = after
        .iter()
        .zip(&pucks)
        .filter(|(a, b)| a.pos.distance(**b) > 3.0)
        .count();
    assert!(moved >= 3, "only {moved} pucks moved: {after:?}");
    // The robot got through or at least deep into it, pushing as it went.
    assert!(
        world.robots()[0].pose.x > 0.0,
        "robot stuck at {:?}",
        world.robots()[0].pose
    );
    // No two pucks overlap after the shove.
    for a in &after {
        for b in &after {
            assert!(
                a.id == b.id || a.pos.distance(b.pos) > 6.0,
                "{a:?} overlaps {b:?}"
            );
        }
    }
}

#[test]
fn robots_driving_head_on_do_not_pass_through_each_other() {
    let cfg = colony_sim::SceneConfig::default();
    let robots = [pose(-30.0, 0.0, 0.0), pose(30.0, 0.0, std::f64::consts::PI)];
    let mut world = colony_sim::World::with_layout(&cfg, &robots, &[]).unwrap();
    for _ in 0..20 {
        world.step(&[FORWARD, FORWARD]);
    }
    let r = world.robots();
    assert!(r[0].pose.x < r[1].pose.x, "{r:?}");
    // Their bows meet: the centres stay at least two gripper reaches apart, less a little give.
    let reach = world.robot_shape().gripper_centre.x + world.robot_shape().gripper_radius;
    assert!(r[1].pose.x - r[0].pose.x > 2.0 * reach - 1.0, "{r:?}");
}
