use colony_sim::{Pose, PuckKind, RobotId, SceneConfig, Vec2, World};
use colony_testkit::sim::{pose, scene};

fn close(a: Vec2, b: Vec2) -> bool {
    a.distance(b) < 1e-4
}

#[test]
fn a_puck_ahead_in_the_footprint_is_seen_at_its_robot_frame_position() {
    // Robot at (10, -20) facing +y; a puck 20 cm ahead and 5 cm to its left.
    let robot = pose(10.0, -20.0, std::f64::consts::FRAC_PI_2);
    let world = scene(robot, &[Vec2::new(5.0, 0.0)]);
    let obs = world.observe(RobotId(0));
    assert_eq!(obs.pucks.len(), 1);
    assert!(
        close(obs.pucks[0].pos, Vec2::new(20.0, 5.0)),
        "{:?}",
        obs.pucks[0].pos
    );
    assert_eq!(obs.pucks[0].kind, PuckKind(0));
    assert!(!obs.pucks[0].held_by_other);
    assert!(obs.gripper.is_none());
    assert!((obs.pose.theta - std::f64::consts::FRAC_PI_2).abs() < 1e-6);
    assert!(close(obs.pose.position(), Vec2::new(10.0, -20.0)));
}

#[test]
fn pucks_behind_beside_or_too_far_are_not_seen() {
    let robot = pose(0.0, 0.0, 0.0);
    let fp = SceneConfig::default().camera.footprint();
    let outside = [
        Vec2::new(-20.0, 0.0), // behind
        Vec2::new(0.0, 20.0),  // beside
        Vec2::new(20.0, 36.0), // beyond the half-width
        Vec2::new(45.0, 0.0),  // beyond the far edge
        Vec2::new(42.0, 30.0), // beyond the maximum range
    ];
    for p in outside {
        assert!(!fp.contains(p), "{p:?}");
        let world = scene(robot, &[p]);
        assert!(
            world.observe(RobotId(0)).pucks.is_empty(),
            "a puck at {p:?} was seen"
        );
    }
    // Just inside the near and far edges (camera 3.75 cm ahead of the centre).
    for p in [
        Vec2::new(3.75 + 35.0, 0.0),
        Vec2::new(3.75 + 12.0, 25.0),
        Vec2::new(3.75 + 30.0, -30.0),
    ] {
        assert!(fp.contains(p), "{p:?}");
    }
    // The angular limit cuts the footprint's near corners.
    assert!(!fp.contains(Vec2::new(3.75 + 3.0, 29.0)));
}

#[test]
fn wall_points_appear_when_facing_a_wall() {
    // 30 cm from the east wall (x = 93.5), facing it.
    let facing = scene(pose(63.5, 0.0, 0.0), &[]);
    let obs = facing.observe(RobotId(0));
    assert!(
        obs.obstacles.len() > 40,
        "only {} wall points",
        obs.obstacles.len()
    );
    for p in &obs.obstacles {
        assert!((p.x - 30.0).abs() < 1e-6, "wall point at {p:?}");
        assert!(p.y.abs() <= 30.5 + 1e-9);
    }
    // About 1 cm apart.
    let mut ys: Vec<f64> = obs.obstacles.iter().map(|p| p.y).collect();
    ys.sort_by(f64::total_cmp);
    assert!(ys.windows(2).all(|w| w[1] - w[0] <= 1.0 + 1e-9));
    // Facing away, nothing.
    let away = scene(pose(63.5, 0.0, std::f64::consts::PI), &[]);
    assert!(away.observe(RobotId(0)).obstacles.is_empty());
}

#[test]
fn another_robot_is_seen_as_a_centre_and_outline_points() {
    let cfg = SceneConfig::default();
    let robots = [pose(0.0, 0.0, 0.0), pose(30.0, 5.0, 1.0)];
    let world = World::with_layout(&cfg, &robots, &[]).unwrap();
    let obs = world.observe(RobotId(0));
    assert_eq!(obs.robots.len(), 1);
    assert!(close(obs.robots[0], Vec2::new(30.0, 5.0)));
    assert!(obs.obstacles.len() > 20);
    // The points lie on the other robot's body (within its half-diagonal of its centre).
    let half_diag = 6.25f64.hypot(5.4);
    assert!(obs
        .obstacles
        .iter()
        .all(|p| p.distance(Vec2::new(30.0, 5.0)) <= half_diag + 1e-6));
    // The other robot faces away at an angle and does not see the first.
    assert!(world.observe(RobotId(1)).robots.is_empty());
}

#[test]
fn a_puck_in_another_robots_gripper_is_flagged() {
    let cfg = SceneConfig::default();
    // Robot 1 stands 35 cm ahead of robot 0, facing it, with a puck in its pocket.
    let robots = [pose(0.0, 0.0, 0.0), pose(35.0, 0.0, std::f64::consts::PI)];
    let pocket = Pose {
        x: 35.0,
        y: 0.0,
        theta: std::f64::consts::PI,
    }
    .to_world(Vec2::new(9.4, 0.0));
    let pucks = [(PuckKind(1), pocket), (PuckKind(0), Vec2::new(10.0, 20.0))];
    let world = World::with_layout(&cfg, &robots, &pucks).unwrap();
    assert_eq!(world.robots()[1].carrying, Some(colony_sim::PuckId(0)));
    let obs = world.observe(RobotId(0));
    assert_eq!(obs.pucks.len(), 2);
    let held: Vec<bool> = obs.pucks.iter().map(|p| p.held_by_other).collect();
    let kinds: Vec<u8> = obs.pucks.iter().map(|p| p.kind.0).collect();
    for (h, k) in held.iter().zip(&kinds) {
        assert_eq!(*h, *k == 1);
    }
    // Its holder reports it in its own gripper, not among the pucks it sees.
    let holder = world.observe(RobotId(1));
    assert!(holder
        .gripper
        .is_some_and(|g| !g.held_by_other && g.kind == PuckKind(1)));
    assert!(holder.pucks.iter().all(|p| p.kind == PuckKind(0)));
}

#[test]
fn an_unknown_robot_observes_nothing() {
    let world = scene(pose(0.0, 0.0, 0.0), &[Vec2::new(20.0, 0.0)]);
    assert_eq!(
        world.observe(RobotId(7)),
        colony_sim::Observation::default()
    );
}

#[test]
fn in_a_large_swarm_each_robot_sees_exactly_the_robots_in_its_footprint_in_id_order() {
    // 300 robots at the standard density, after they have driven into one another a while.
    let mut world = World::new(&SceneConfig::scaled(300), 5).unwrap();
    let go = colony_sim::WheelCommand {
        forward: 1.0,
        turn: 0.3,
    };
    for _ in 0..40 {
        world.step(&[go; 300]);
    }
    let robots = world.robots();
    let fp = world.footprint();
    let mut seen_any = 0;
    for me in &robots {
        let (s, c) = me.pose.theta.sin_cos();
        let expected: Vec<Vec2> = robots
            .iter()
            .filter(|o| o.id != me.id)
            .map(|o| {
                let (dx, dy) = (o.pose.x - me.pose.x, o.pose.y - me.pose.y);
                Vec2::new(c * dx + s * dy, -s * dx + c * dy)
            })
            .filter(|local| fp.contains(*local))
            .collect();
        let obs = world.observe(me.id);
        assert_eq!(obs.robots.len(), expected.len(), "robot {}", me.id.0);
        for (got, want) in obs.robots.iter().zip(&expected) {
            assert!(
                close(*got, *want),
                "robot {}: {got:?} against {want:?}",
                me.id.0
            );
        }
        seen_any += usize::from(!expected.is_empty());
    }
    assert!(seen_any > 10, "only {seen_any} robots saw another");
}
