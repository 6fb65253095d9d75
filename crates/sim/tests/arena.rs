use colony_sim::{SceneConfig, Vec2, World};
use colony_testkit::sim::RandomDriver;

#[test]
fn robots_and_pucks_never_leave_the_arena_over_5000_random_steps() {
    let cfg = SceneConfig::default();
    let mut world = World::new(&cfg, 5).unwrap();
    let mut driver = RandomDriver::new(99, cfg.robots.count);
    let rp = cfg.puck_radius();
    let shape = world.robot_shape();
    for step in 0..5000 {
        world.step(driver.next());
        for r in world.robots() {
            // The body's centre keeps at least half the body width from the wall
            // (a little penetration of the soft contacts is allowed).
            let d = world.wall_distance(r.pose.position());
            assert!(
                d > shape.width / 2.0 - 0.5,
                "step {step}: robot {:?} {d} cm from the wall",
                r.id
            );
        }
        for p in world.pucks() {
            let d = world.wall_distance(p.pos);
            assert!(
                d > rp - 0.5,
                "step {step}: puck {:?} at {:?}, {d} cm from the wall",
                p.id,
                p.pos
            );
        }
    }
}

#[test]
fn arena_contains_is_the_rounded_square() {
    let world = World::with_layout(&SceneConfig::default(), &[], &[]).unwrap();
    assert!(world.arena_contains(Vec2::new(0.0, 0.0)));
    assert!(world.arena_contains(Vec2::new(93.0, 0.0)));
    assert!(!world.arena_contains(Vec2::new(94.0, 0.0)));
    assert!(world.arena_contains(Vec2::new(0.0, -93.0)));
    // The corner is rounded with radius 15: its centre is at (78.5, 78.5).
    assert!(!world.arena_contains(Vec2::new(92.0, 92.0)));
    let on_arc = 78.5 + 15.0 / 2f64.sqrt();
    assert!(world.arena_contains(Vec2::new(on_arc - 0.1, on_arc - 0.1)));
    assert!(!world.arena_contains(Vec2::new(on_arc + 0.1, on_arc + 0.1)));
    assert!((world.wall_distance(Vec2::new(80.0, 0.0)) - 13.5).abs() < 1e-9);
}

#[test]
fn a_scaled_world_has_ten_pucks_per_robot_and_a_larger_arena() {
    let cfg = SceneConfig::scaled(16);
    assert_eq!((cfg.robots.count, cfg.pucks.count), (16, 160));
    assert!((cfg.arena.width - 374.0).abs() < 1e-9);
    let world = World::new(&cfg, 1).unwrap();
    assert_eq!(world.robots().len(), 16);
    assert!(world.pucks().iter().all(|p| world.arena_contains(p.pos)));
}
