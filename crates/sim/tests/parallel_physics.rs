//! The `parallel-physics` build, where rapier's own threads work inside each physics step:
//! worlds stepped together on rayon's workers all finish, and no thread count changes a bit.
//! (`determinism.rs`'s recorded digest, run in this build, ties it to the default build.)
#![cfg(feature = "parallel-physics")]

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::Duration;

use colony_sim::field::{Field, FieldConfig, RobotSpec, TileMap};
use colony_sim::{Engine, SceneConfig, WheelCommand, World};
use colony_testkit::sim::{bits, digest, pose, RandomDriver};
use rayon::prelude::*;

/// A sorting world of `robots` robots (ten pucks each) on rapier, after `steps` control
/// steps of random driving.
fn sorting(robots: usize, seed: u64, steps: usize) -> World {
    let mut cfg = SceneConfig::scaled(robots);
    cfg.physics.engine = Engine::Rapier;
    let mut world = World::new(&cfg, seed).unwrap();
    let mut driver = RandomDriver::new(seed, cfg.robots.count);
    for _ in 0..steps {
        world.step(driver.next());
    }
    world
}

fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

#[test]
fn worlds_stepped_together_on_rayons_workers_all_finish_one_at_a_time_per_worker() {
    // Rapier's parallel step waits, on the stepping thread, for a task it gave its pool;
    // stepped straight on a shared pool, two worlds could leave both workers waiting
    // for tasks queued behind them, and the test would hang here. And a worker waiting
    // for a world's physics must not start another world meanwhile.
    static ALIVE: AtomicUsize = AtomicUsize::new(0);
    static MOST_ALIVE: AtomicUsize = AtomicUsize::new(0);
    let (done, finished) = mpsc::channel();
    std::thread::spawn(move || {
        let digests: Vec<u64> = in_pool(2, || {
            (0..16u64)
                .into_par_iter()
                .map(|seed| {
                    let alive = ALIVE.fetch_add(1, Ordering::SeqCst) + 1;
                    MOST_ALIVE.fetch_max(alive, Ordering::SeqCst);
                    let d = digest(&sorting(4, seed, 1000));
                    ALIVE.fetch_sub(1, Ordering::SeqCst);
                    d
                })
                .collect()
        });
        let _ = done.send(digests);
    });
    let digests = finished
        .recv_timeout(Duration::from_secs(300))
        .expect("16 worlds stepped on two workers did not finish in five minutes");
    assert!(
        MOST_ALIVE.load(Ordering::SeqCst) <= 2,
        "{} worlds were alive at once on two workers",
        MOST_ALIVE.load(Ordering::SeqCst)
    );
    // The same worlds stepped one after another, on this thread: the same bits.
    for (seed, d) in digests.iter().enumerate() {
        assert_eq!(*d, digest(&sorting(4, seed as u64, 1000)), "world {seed}");
    }
}

#[test]
fn the_thread_count_does_not_change_a_sorting_world() {
    let one = in_pool(1, || digest(&sorting(64, 7, 150)));
    let two = in_pool(2, || digest(&sorting(64, 7, 150)));
    let three = in_pool(3, || digest(&sorting(64, 7, 150)));
    assert_eq!(one, two);
    assert_eq!(one, three);
}

/// Poses of 300 robots packed on a 3 m square, all driving at its centre: a jam of several
/// hundred contacts, enough for rapier to split its solver over threads.
fn field_trace() -> Vec<u64> {
    let mut field =
        Field::new(TileMap::open(30, 30, 10.0).unwrap(), FieldConfig::default()).unwrap();
    let spec = RobotSpec {
        radius: 6.0,
        max_speed: 30.0,
        max_turn: 3.0,
        amphibious: false,
    };
    let mut commands = Vec::new();
    for k in 0..300 {
        let (x, y) = (30.0 + (k % 20) as f64 * 12.5, 30.0 + (k / 20) as f64 * 16.0);
        let heading = (150.0 - y).atan2(150.0 - x);
        field.add_robot(spec, pose(x, y, heading)).unwrap();
        commands.push(WheelCommand {
            forward: 1.0,
            turn: if k % 3 == 0 { 0.1 } else { 0.0 },
        });
    }
    let mut out = Vec::new();
    for _ in 0..100 {
        field.step(&commands);
        for r in field.robots() {
            out.extend(bits(r.pose));
        }
    }
    out
}

#[test]
fn the_thread_count_does_not_change_a_crowded_field() {
    let one = in_pool(1, field_trace);
    // Rapier splits its solver once there are 32 two-body contacts per worker
    // (`enhanced-determinism`'s one-lane SIMD): the jam must have many more.
    let last = &one[one.len() - 300 * 3..];
    let centres: Vec<(f64, f64)> = last
        .chunks(3)
        .map(|p| (f64::from_bits(p[0]), f64::from_bits(p[1])))
        .collect();
    let touching = centres
        .iter()
        .enumerate()
        .flat_map(|(i, a)| centres[i + 1..].iter().map(move |b| (a, b)))
        .filter(|(a, b)| (a.0 - b.0).hypot(a.1 - b.1) < 12.5)
        .count();
    assert!(
        touching >= 200,
        "only {touching} pairs of robots touch in the jam"
    );
    assert!(
        in_pool(2, field_trace) == one,
        "two threads differ from one"
    );
    assert!(
        in_pool(3, field_trace) == one,
        "three threads differ from one"
    );
}
