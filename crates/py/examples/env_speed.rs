//! The environment cores stepped from Rust alone, with no Python: the floor the
//! Python package's step rates are measured against (`scripts/bench-envs.sh`
//! runs it beside `bench/env_speed.py`; the difference per step is what crossing
//! between Python and Rust costs).
//!
//! `cargo run --release -p colony-py --example env_speed`
//!
//! Each line: `NAME STEPS_PER_SECOND` for one world: the best of five runs of
//! the same steps from seed 1 (the number per scene is in `STEPS`, the same in
//! `bench/env_speed.py`), robot `i` driven with forward 0.8 and turn 0.5 sin(i),
//! the observation written every step. The Python benchmark runs exactly these
//! steps, so the two differ only by what crossing into Python costs.

use std::time::Instant;

use colony_env::game::{Fire, GameEnv, GameEnvConfig, RobotAction};
use colony_env::sort::{EnvConfig, SortEnv};
use colony_game::rules::Mode;
use colony_sim::WheelCommand;

/// Steps per run for each scene (robots; 12 is Capture the Flag).
const STEPS: [(usize, u32); 4] = [(4, 4000), (64, 800), (256, 300), (12, 2000)];

/// The best of five runs of `steps` calls of `step`, each after `reset`, in steps per second.
fn rate(steps: u32, mut reset: impl FnMut(), mut step: impl FnMut()) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        reset();
        let started = Instant::now();
        for _ in 0..steps {
            step();
        }
        best = best.min(started.elapsed().as_secs_f64());
    }
    f64::from(steps) / best
}

fn steps_for(robots: usize) -> u32 {
    STEPS
        .iter()
        .find(|(r, _)| *r == robots)
        .map_or(100, |(_, n)| *n)
}

/// Robot `i`'s command, the same in `bench/env_speed.py`.
fn fixed(i: usize) -> WheelCommand {
    WheelCommand {
        forward: 0.8,
        turn: 0.5 * (i as f64).sin(),
    }
}

fn sorting(robots: usize) -> anyhow::Result<f64> {
    let base = EnvConfig::default();
    // The Python benchmark's scenes: the standard one for 4 robots, scaled
    // (10 pucks each, the paper's densities) above it.
    let mut config = if robots == 4 {
        base
    } else {
        base.with_scaled_robots(robots)
    };
    config.max_steps = u64::MAX;
    let env = SortEnv::new(config, 1)?;
    let l = env.layout();
    let (mut map, mut grip, mut pose) = (
        vec![0.0; l.map_total()],
        vec![0.0; l.gripper_total()],
        vec![0.0; l.pose_total()],
    );
    let commands: Vec<WheelCommand> = (0..robots).map(fixed).collect();
    let env = std::cell::RefCell::new(env);
    Ok(rate(
        steps_for(robots),
        || {
            let _ = env.borrow_mut().reset(1);
        },
        || {
            let mut env = env.borrow_mut();
            let _ = env.step(&commands);
            let _ = env.observe(&mut map, &mut grip, &mut pose);
        },
    ))
}

fn capture_the_flag() -> anyhow::Result<f64> {
    let mut config = GameEnvConfig::shipped(Mode::CaptureTheFlag)?;
    config.max_steps = u64::MAX;
    let env = GameEnv::new(config, 1)?;
    let l = env.layout();
    let n = l.agents;
    let mut bufs = [
        vec![0.0; n * l.own_len()],
        vec![0.0; n * l.nearby_len()],
        vec![0.0; n * l.flags_len()],
        vec![0.0; n * l.patch_len()],
    ];
    let actions: Vec<RobotAction> = (0..n)
        .map(|i| {
            let c = fixed(i);
            RobotAction {
                forward: c.forward,
                turn: c.turn,
                fire: Fire::Nearest,
                pickup: true,
            }
        })
        .collect();
    let env = std::cell::RefCell::new(env);
    Ok(rate(
        steps_for(12),
        || {
            let _ = env.borrow_mut().reset(1);
        },
        || {
            let mut env = env.borrow_mut();
            // A match that ends starts again, as the Python loop does.
            if env
                .step_robots(&actions)
                .is_ok_and(|i| i.terminated || i.truncated)
            {
                let _ = env.reset(2);
            }
            let [own, nearby, flags, patch] = &mut bufs;
            let _ = env.observe(own, nearby, flags, patch);
        },
    ))
}

fn main() -> anyhow::Result<()> {
    for robots in [4, 64, 256] {
        println!("sorting-{robots} {:.1}", sorting(robots)?);
    }
    println!("ctf-12 {:.1}", capture_the_flag()?);
    Ok(())
}
