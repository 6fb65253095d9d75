//! The `parallel-physics` build, where rapier's own threads work inside each physics step:
//! worlds stepped together on rayon's workers all finish, and no thread count changes a bit.
//! (`determinism.rs`'s recorded digest, run in this build, ties it to the default build.)
#![cfg(feature = "parallel-physics")]

mod common;

use std::sync::mpsc;
use std::time::Duration;

use colony_sim::field::{Field, FieldConfig, RobotSpec, TileMap};
use colony_sim::{SceneConfig, WheelCommand, World};
use common::{digest, pose, RandomDriver};
use rayon::prelude::*;

/// A sorting world of `robots` robots (ten pucks each) after `steps` control steps of
/// random driving.
fn sorting(robots: usize, seed: u64, steps: usize) -> World {
    let cfg = SceneConfig::scaled(robots);
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
fn worlds_stepped_together_on_rayons_workers_all_finish() {
    // Rapier's parallel step waits, on the stepping thread, for a task it gave its pool;
    // stepped straight on a shared pool, two worlds could leave both workers waiting
    // for tasks queued behind them, and the test would hang here.
    let (done, finished) = mpsc::channel();
    std::thread::spawn(move || {
        let digests: Vec<u64> = in_pool(2, || {
            (0..16u64)
                .into_par_iter()
                .map(|seed| digest(&sorting(4, seed, 1000)))
                .collect()
        });
        let _ = done.send(digests);
    });
    let digests = finished
        .recv_timeout(Duration::from_secs(300))
        .expect("16 worlds stepped on two workers did not finish in five minutes");
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

/// Poses of 80 robots driving in circles on an open field, crowding into each other.
fn field_trace() -> Vec<u64> {
    let mut field =
        Field::new(TileMap::open(60, 60, 10.0).unwrap(), FieldConfig::default()).unwrap();
    let spec = RobotSpec {
        radius: 6.0,
        max_speed: 30.0,
        max_turn: 3.0,
        amphibious: false,
    };
    for k in 0..80 {
        let (x, y) = (40.0 + (k % 10) as f64 * 55.0, 40.0 + (k / 10) as f64 * 70.0);
        field.add_robot(spec, pose(x, y, k as f64)).unwrap();
    }
    let commands: Vec<WheelCommand> = (0..80)
        .map(|k| WheelCommand {
            forward: 1.0,
            turn: if k % 2 == 0 { 0.3 } else { -0.2 },
        })
        .collect();
    let mut out = Vec::new();
    for _ in 0..200 {
        field.step(&commands);
        for r in field.robots() {
            out.extend([
                r.pose.x.to_bits(),
                r.pose.y.to_bits(),
                r.pose.theta.to_bits(),
            ]);
        }
    }
    out
}

#[test]
fn the_thread_count_does_not_change_a_field() {
    let one = in_pool(1, field_trace);
    assert!(
        in_pool(2, field_trace) == one,
        "two threads differ from one"
    );
    assert!(
        in_pool(3, field_trace) == one,
        "three threads differ from one"
    );
}
