//! The environment cores stepped from Rust alone, with no Python: the floor the
//! Python package's step rates are measured against (`scripts/bench-envs.sh`
//! runs it beside `bench/env_speed.py`; the difference per step is what crossing
//! between Python and Rust costs).
//!
//! `cargo run --release -p colony-py --example env_speed -- [SECONDS]`
//!
//! Each line: `NAME STEPS_PER_SECOND` for one world from seed 1, robot `i`
//! driven with forward 0.8 and turn 0.5 sin(i) (physics costs more when robots
//! push things, so the Python benchmark drives them the same way), observation
//! written every step.

use std::time::{Duration, Instant};

use colony_game::env::{Fire, GameEnv, GameEnvConfig, RobotAction};
use colony_game::rules::Mode;
use colony_sim::WheelCommand;
use colony_sort::env::{EnvConfig, SortEnv};

/// Steps `step` for about `budget`, and returns steps per second.
fn rate(budget: Duration, mut step: impl FnMut()) -> f64 {
    let started = Instant::now();
    let mut steps = 0u64;
    while started.elapsed() < budget {
        step();
        steps += 1;
    }
    steps as f64 / started.elapsed().as_secs_f64()
}

/// Robot `i`'s command, the same in `bench/env_speed.py`.
fn fixed(i: usize) -> WheelCommand {
    WheelCommand {
        forward: 0.8,
        turn: 0.5 * (i as f64).sin(),
    }
}

fn sorting(robots: usize, budget: Duration) -> anyhow::Result<f64> {
    let base = EnvConfig::default();
    // The Python benchmark's scenes: the standard one for 4 robots, scaled
    // (10 pucks each, the paper's densities) above it.
    let mut config = if robots == 4 {
        base
    } else {
        base.with_scaled_robots(robots)
    };
    config.max_steps = u64::MAX;
    let mut env = SortEnv::new(config, 1)?;
    let l = env.layout();
    let (mut map, mut grip, mut pose) = (
        vec![0.0; l.map_total()],
        vec![0.0; l.gripper_total()],
        vec![0.0; l.pose_total()],
    );
    let commands: Vec<WheelCommand> = (0..robots).map(fixed).collect();
    Ok(rate(budget, || {
        let _ = env.step(&commands);
        let _ = env.observe(&mut map, &mut grip, &mut pose);
    }))
}

fn capture_the_flag(budget: Duration) -> anyhow::Result<f64> {
    let mut config = GameEnvConfig::shipped(Mode::CaptureTheFlag)?;
    config.max_steps = u64::MAX;
    let mut env = GameEnv::new(config, 1)?;
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
    Ok(rate(budget, || {
        if env.step_robots(&actions).is_err() {
            let _ = env.reset(2);
        }
        let [own, nearby, flags, patch] = &mut bufs;
        let _ = env.observe(own, nearby, flags, patch);
    }))
}

fn main() -> anyhow::Result<()> {
    let seconds: f64 = match std::env::args().nth(1) {
        Some(s) => s.parse()?,
        None => 3.0,
    };
    let budget = Duration::try_from_secs_f64(seconds)?;
    for robots in [4, 64, 256] {
        println!("sorting-{robots} {:.1}", sorting(robots, budget)?);
    }
    println!("ctf-12 {:.1}", capture_the_flag(budget)?);
    Ok(())
}
