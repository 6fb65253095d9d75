//! How a sorting swarm scales: setting up a world of N robots with their pucks (the
//! standard densities, `SceneConfig::scaled`), then a trial of CACHECONS controllers on
//! full physics, as `colony sort run` runs it (metrics every 100 steps). Prints one
//! Markdown table row: engine, robots, pucks, arena, setup time, control steps per second,
//! the multiple of real time (a control step is 0.214 s of simulated time), the process's
//! peak memory, the whole step's cost per body per physics step, contact points per body
//! and sleeping pucks at the end, the engine's own cost and its stages' shares where it
//! keeps them, and the final PC. Run one N per process so the peak is that N's.
//!
//! ```text
//! cargo run --release -p colony-lab --example swarm_scale -- --robots 1024 --steps 200
//! ```

use std::time::Instant;

use colony_lab::sort::experiment::{run_trial_then, TrialSpec};
use colony_sim::{Engine, SceneConfig, World};
use colony_sort::{Method, SortParams};

fn main() {
    let (mut robots, mut steps, mut seed) = (4usize, 1_000u64, 1u64);
    let mut engine = Engine::default();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let text = args.next();
        if a == "--engine" {
            match text.as_deref().map(str::parse) {
                Some(Ok(e)) => engine = e,
                _ => {
                    eprintln!("swarm_scale: --engine takes one of rapier, disc");
                    std::process::exit(2);
                }
            }
            continue;
        }
        let value = text.and_then(|v| v.parse::<u64>().ok());
        match (a.as_str(), value) {
            ("--robots", Some(v)) if v > 0 => robots = v as usize,
            ("--steps", Some(v)) if v > 0 => steps = v,
            ("--seed", Some(v)) => seed = v,
            _ => {
                eprintln!("usage: swarm_scale [--robots N] [--steps N] [--seed N] [--engine NAME]");
                std::process::exit(2);
            }
        }
    }
    let mut scene = SceneConfig::scaled(robots);
    scene.physics.engine = engine;
    let started = Instant::now();
    let world = World::new(&scene, seed).unwrap_or_else(|e| {
        eprintln!("swarm_scale: {e}");
        std::process::exit(1);
    });
    let setup = started.elapsed().as_secs_f64();
    drop(world);
    let spec = TrialSpec {
        method: Method::CacheCons,
        scene: scene.clone(),
        params: SortParams::default(),
        steps,
        seed,
        sample_every: 100,
        snapshot_at: Vec::new(),
        disturbances: Vec::new(),
    };
    let started = Instant::now();
    let mut physics = None;
    let result = run_trial_then(&spec, &|_| {}, |w| physics = Some(w.physics_stats()))
        .unwrap_or_else(|e| {
            eprintln!("swarm_scale: {e}");
            std::process::exit(1);
        });
    // The trial builds its own world: take that setup out of the stepping time.
    let stepping = started.elapsed().as_secs_f64() - setup;
    let per_second = steps as f64 / stepping;
    let real_time = per_second * scene.control_step_seconds();
    let physics = physics.expect("the trial hands its world over");
    let bodies = (robots + scene.pucks.count) as f64;
    let body_steps = bodies * (steps * u64::from(scene.physics.substeps)) as f64;
    // Whole step (controllers, sensing, metrics and physics) per body per physics step.
    let per_body = stepping / body_steps * 1e6;
    let engine_time: f64 = physics.stage_seconds.iter().map(|(_, s)| s).sum();
    let stages = if engine_time > 0.0 {
        let shares: Vec<String> = physics
            .stage_seconds
            .iter()
            .map(|(name, s)| format!("{name} {:.0} %", 100.0 * s / engine_time))
            .collect();
        format!(
            "{:.2} µs/body ({:.0} % of the step): {}",
            engine_time / body_steps * 1e6,
            100.0 * engine_time / stepping,
            shares.join(", ")
        )
    } else {
        "-".to_owned()
    };
    println!(
        "| {engine} | {robots} | {} | {:.1} m x {:.1} m | {setup:.3} s | {per_second:.1} | {real_time:.2} | {} | {per_body:.2} µs | {:.2} | {} | {stages} | {:.1} % |",
        scene.pucks.count,
        scene.arena.width / 100.0,
        scene.arena.height / 100.0,
        peak_memory(),
        physics.contacts as f64 / bodies,
        physics.sleeping_pucks,
        result.final_pc()
    );
}

/// The process's peak resident memory (Linux's VmHWM), or "?" where it cannot be read.
fn peak_memory() -> String {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("VmHWM:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        })
        .map_or("?".to_owned(), |kb| format!("{:.0} MB", kb / 1024.0))
}
