use colony_sim::{Engine, SceneConfig, World};
use colony_testkit::sim::{digest, RandomDriver};

fn run(seed: u64, steps: usize) -> World {
    run_on(Engine::default(), seed, steps)
}

fn run_on(engine: Engine, seed: u64, steps: usize) -> World {
    let mut cfg = SceneConfig::default();
    cfg.physics.engine = engine;
    let mut world = World::new(&cfg, seed).unwrap();
    let mut driver = RandomDriver::new(seed ^ 0x5eed, cfg.robots.count);
    for _ in 0..steps {
        world.step(driver.next());
    }
    world
}

#[test]
fn same_seed_gives_identical_positions_after_2000_steps() {
    // One run on another thread, one here: the thread must not matter either.
    let other = std::thread::spawn(|| run(11, 2000).snapshot());
    let here = run(11, 2000).snapshot();
    let other = other.join().unwrap();
    assert_eq!(here.step, 2000);
    // Bit-for-bit: the whole snapshot, every pose and puck, compares equal.
    assert_eq!(here, other);
}

/// The same trial gives the same bits on every machine: this digest was recorded on
/// x86-64 Linux. If it changes on another platform, determinism is broken there; if
/// it changes after a deliberate change to the physics, record the new value.
#[test]
fn a_recorded_trial_replays_bit_for_bit() {
    for (engine, recorded) in [(Engine::Rapier, RAPIER_DIGEST), (Engine::Disc, DISC_DIGEST)] {
        let world = run_on(engine, 2024, 300);
        assert_eq!(
            digest(&world),
            recorded,
            "{engine}: digest {:#018x}",
            digest(&world)
        );
    }
}

const RAPIER_DIGEST: u64 = 0x9a9f37f8b78ac699;
const DISC_DIGEST: u64 = 0x3d37afc955f23cf0;

/// The disc engine finds contacts on rayon's threads, in chunks of a fixed size: a
/// world of more bodies than one chunk steps to the same bits on one thread and on two.
#[test]
fn the_disc_engine_gives_the_same_bits_on_one_thread_and_two() {
    let run_in = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut cfg = SceneConfig::scaled(100);
            cfg.physics.engine = Engine::Disc;
            let mut world = World::new(&cfg, 8).unwrap();
            let mut driver = RandomDriver::new(3, cfg.robots.count);
            for _ in 0..60 {
                world.step(driver.next());
            }
            assert!(world.physics_stats().contacts > 0, "no contacts to test");
            digest(&world)
        })
    };
    assert_eq!(run_in(1), run_in(2));
}

#[test]
fn different_seeds_give_different_layouts() {
    let a = World::new(&SceneConfig::default(), 1).unwrap();
    let b = World::new(&SceneConfig::default(), 2).unwrap();
    assert_ne!(a.snapshot().robots, b.snapshot().robots);
    assert_ne!(a.snapshot().pucks, b.snapshot().pucks);
}

#[test]
fn initial_layout_has_no_overlaps_and_keeps_clear_of_walls() {
    let world = World::new(&SceneConfig::default(), 3).unwrap();
    let shape = world.robot_shape();
    let rp = world.config().puck_radius();
    let robots = world.robots();
    let pucks = world.pucks();
    assert_eq!((robots.len(), pucks.len()), (4, 40));
    for r in &robots {
        assert!(world.wall_distance(r.pose.position()) > shape.bounding_radius);
        for o in &robots {
            if o.id != r.id {
                assert!(
                    r.pose.position().distance(o.pose.position()) > 2.0 * shape.bounding_radius
                );
            }
        }
        for p in &pucks {
            assert!(r.pose.position().distance(p.pos) > shape.bounding_radius + rp);
        }
    }
    for p in &pucks {
        assert!(world.wall_distance(p.pos) > rp);
        for q in &pucks {
            if q.id != p.id {
                assert!(p.pos.distance(q.pos) > 2.0 * rp);
            }
        }
    }
    // Pucks are divided evenly among the two types.
    assert_eq!(pucks.iter().filter(|p| p.kind.0 == 0).count(), 20);
    assert_eq!(pucks.iter().filter(|p| p.kind.0 == 1).count(), 20);
}
