//! Times whole trials: the standard configuration (or `--robots N`, scaled as in the
//! benchmark), random wheel commands, and `observe` for every robot at every step.
//!
//! ```text
//! cargo run --release -p colony-sim --example trial_time -- [--steps 100000] [--robots 4] [--seed 1]
//! ```

use std::time::{Duration, Instant};

use colony_sim::{Observation, RobotId, SceneConfig, WheelCommand, World};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn main() {
    let mut steps: u64 = 100_000;
    let mut robots: usize = 4;
    let mut seed: u64 = 1;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || {
            args.next()
                .and_then(|v| v.parse::<u64>().ok())
                .expect("a number after the flag")
        };
        match a.as_str() {
            "--steps" => steps = value(),
            "--robots" => robots = value() as usize,
            "--seed" => seed = value(),
            other => panic!("unknown argument {other}; use --steps N --robots N --seed N"),
        }
    }
    let cfg = SceneConfig::scaled(robots);
    let started = Instant::now();
    let mut world = World::new(&cfg, seed).expect("standard layout");
    let setup = started.elapsed();
    let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(1));
    let mut commands = vec![WheelCommand::STOP; robots];
    let mut obs = Observation::default();
    let (mut t_step, mut t_observe) = (Duration::ZERO, Duration::ZERO);
    let (mut seen_pucks, mut seen_obstacles, mut carrying) = (0u64, 0u64, 0u64);
    for _ in 0..steps {
        // A wandering robot: each command is held for about five steps.
        for c in &mut commands {
            if rng.random_bool(0.2) {
                *c = WheelCommand {
                    forward: rng.random_range(-0.5..1.0),
                    turn: rng.random_range(-1.0..1.0),
                };
            }
        }
        let t = Instant::now();
        world.step(&commands);
        t_step += t.elapsed();
        let t = Instant::now();
        for i in 0..robots {
            world.observe_into(RobotId(i), &mut obs);
            seen_pucks += obs.pucks.len() as u64;
            seen_obstacles += obs.obstacles.len() as u64;
            carrying += obs.gripper.is_some() as u64;
        }
        t_observe += t.elapsed();
    }
    let total = started.elapsed();
    let n = (steps * robots as u64) as f64;
    println!(
        "{steps} control steps, {robots} robots, {} pucks, arena {:.0} cm, seed {seed}",
        cfg.pucks.count, cfg.arena.width
    );
    println!(
        "total {:.2} s (setup {:.3} s, step {:.2} s, observe {:.2} s); {:.1} us per control step",
        total.as_secs_f64(),
        setup.as_secs_f64(),
        t_step.as_secs_f64(),
        t_observe.as_secs_f64(),
        total.as_secs_f64() * 1e6 / steps as f64
    );
    println!(
        "per observation: {:.1} pucks, {:.1} obstacle points, carrying {:.1} % of the time",
        seen_pucks as f64 / n,
        seen_obstacles as f64 / n,
        100.0 * carrying as f64 / n
    );
    let outside = world
        .pucks()
        .iter()
        .filter(|p| !world.arena_contains(p.pos))
        .count()
        + world
            .robots()
            .iter()
            .filter(|r| !world.arena_contains(r.pose.position()))
            .count();
    println!("bodies outside the arena at the end: {outside}");
    let s = world.snapshot();
    let checksum: f64 = s.pucks.iter().map(|p| p.pos.x * 3.0 + p.pos.y).sum::<f64>()
        + s.robots
            .iter()
            .map(|r| r.pose.x + r.pose.theta)
            .sum::<f64>();
    println!("final-state checksum {checksum:.12}");
}
