use colony_sim::{PuckId, SceneConfig, Vec2, WheelCommand, World};
use colony_testkit::sim::{pose, scene, FORWARD};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

#[test]
fn shifting_a_cluster_moves_exactly_those_pucks_by_the_offset() {
    let cluster = [
        Vec2::new(-30.0, -30.0),
        Vec2::new(-23.5, -30.0),
        Vec2::new(-26.75, -24.5),
    ];
    let mut pucks = cluster.to_vec();
    pucks.push(Vec2::new(40.0, 40.0));
    let mut world = scene(pose(0.0, 50.0, 0.0), &pucks);
    let offset = Vec2::new(50.0, -20.0);
    world.shift_cluster(&[PuckId(0), PuckId(1), PuckId(2), PuckId(99)], offset);
    let after = world.pucks();
    for (i, p) in cluster.iter().enumerate() {
        assert!(after[i].pos.distance(*p + offset) < 1e-4, "{:?}", after[i]);
    }
    assert!(after[3].pos.distance(Vec2::new(40.0, 40.0)) < 1e-4);
    // They land at rest: a few steps later they have not moved.
    for _ in 0..5 {
        world.step(&[WheelCommand::STOP]);
    }
    for (i, p) in cluster.iter().enumerate() {
        assert!(world.pucks()[i].pos.distance(*p + offset) < 1e-3);
    }
}

#[test]
fn a_shift_past_the_wall_lands_inside() {
    let mut world = scene(
        pose(0.0, 0.0, 0.0),
        &[Vec2::new(80.0, 0.0), Vec2::new(70.0, 70.0)],
    );
    world.shift_cluster(&[PuckId(0), PuckId(1)], Vec2::new(50.0, 50.0));
    let rp = world.config().puck_radius();
    for p in world.pucks() {
        assert!(world.wall_distance(p.pos) >= rp - 1e-6, "{p:?}");
    }
    world.shift_cluster(&[PuckId(0)], Vec2::new(f64::NAN, 0.0)); // ignored
    assert!(world.pucks()[0].pos.x.is_finite());
}

#[test]
fn a_shifted_carried_puck_leaves_the_gripper() {
    let mut world = scene(pose(-40.0, 0.0, 0.0), &[Vec2::new(0.0, 0.0)]);
    for _ in 0..12 {
        world.step(&[FORWARD]);
    }
    assert!(world.robots()[0].carrying.is_some());
    world.shift_cluster(&[PuckId(0)], Vec2::new(0.0, 40.0));
    assert!(world.robots()[0].carrying.is_none());
}

#[test]
fn reinserting_puts_every_puck_somewhere_new_and_free() {
    let cfg = SceneConfig::default();
    let mut world = World::new(&cfg, 8).unwrap();
    let before = world.pucks();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    world.reinsert_pucks(&mut rng).unwrap();
    let after = world.pucks();
    let rp = cfg.puck_radius();
    let shape = world.robot_shape();
    for (a, b) in before.iter().zip(&after) {
        assert_eq!(a.kind, b.kind);
        assert!(a.pos.distance(b.pos) > 1e-3);
        assert!(world.wall_distance(b.pos) > rp);
        for r in world.robots() {
            assert!(r.pose.position().distance(b.pos) > shape.bounding_radius + rp);
        }
        for c in &after {
            assert!(c.id == b.id || c.pos.distance(b.pos) > 2.0 * rp);
        }
    }
    // The same generator state gives the same re-insertion.
    let mut twin = World::new(&cfg, 8).unwrap();
    twin.reinsert_pucks(&mut ChaCha8Rng::seed_from_u64(1))
        .unwrap();
    assert_eq!(twin.snapshot(), world.snapshot());
}
