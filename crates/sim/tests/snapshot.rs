use colony_sim::{SceneConfig, World, WorldSnapshot};
use colony_testkit::sim::RandomDriver;

#[test]
fn a_snapshot_holds_every_robot_and_puck_and_round_trips_through_serde() {
    let cfg = SceneConfig::default();
    let mut world = World::new(&cfg, 4).unwrap();
    let mut driver = RandomDriver::new(4, 4);
    for _ in 0..50 {
        world.step(driver.next());
    }
    let snap = world.snapshot();
    assert_eq!(snap.step, 50);
    assert!((snap.time - 50.0 * 3.0 / 14.0).abs() < 1e-9);
    assert_eq!(snap.arena, cfg.arena);
    assert_eq!(snap.robots.len(), 4);
    assert_eq!(snap.pucks.len(), 40);
    for (s, r) in snap.robots.iter().zip(world.robots()) {
        assert_eq!(
            (s.id, s.pose, s.carrying),
            (r.id.0, r.pose, r.carrying.map(|p| p.0))
        );
    }
    for (s, p) in snap.pucks.iter().zip(world.pucks()) {
        assert_eq!((s.id, s.kind, s.pos), (p.id.0, p.kind, p.pos));
    }
    let text = toml::to_string(&snap).unwrap();
    let back: WorldSnapshot = toml::from_str(&text).unwrap();
    assert_eq!(back, snap);
}
