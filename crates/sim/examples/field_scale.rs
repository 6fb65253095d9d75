//! How the tile-map field scales with the game's robots: N robots (radius 6 cm, 30 cm/s,
//! a quarter amphibious) wandering on a map grown with N to keep the density of the
//! `field` benchmark (24 robots on 64 x 48 cells of 10 cm: 1.28 m² per robot), with a
//! river every 64 columns crossed by bridges and 4 % of the cells blocked, and the
//! benchmark's 10 boxes. Each control step is the physics plus `sense` for every robot. Prints one
//! Markdown table row: robots, map, setup time, control steps per second, the multiple
//! of real time (a control step is 0.1 s), peak memory. One N per process.
//!
//! ```text
//! cargo run --release -p colony-sim --example field_scale -- --robots 1024 --steps 200
//! ```

use std::time::Instant;

use colony_sim::field::{BoxSpec, Field, FieldConfig, FieldRobotId, RobotSpec, Terrain, TileMap};
use colony_sim::{Pose, WheelCommand};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn map_for(robots: usize) -> TileMap {
    let k = (robots as f64 / 24.0).sqrt().max(1.0);
    let (w, h) = ((64.0 * k).ceil() as usize, (48.0 * k).ceil() as usize);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    TileMap::from_fn(w, h, 10.0, |x, y| {
        let centre = 30.0 + 64.0 * (x / 64) as f64 + 6.0 * libm::sin(y as f64 / 6.0);
        let river = (x as f64 - centre).abs() <= 1.5;
        let bridge = matches!(y % 24, 10..=12);
        if river && !bridge {
            Terrain::Water
        } else if rng.random_bool(0.04) {
            Terrain::Blocked
        } else {
            Terrain::Open
        }
    })
    .expect("map")
}

fn main() {
    let (mut robots, mut steps) = (24usize, 1_000u64);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let value = args.next().and_then(|v| v.parse::<u64>().ok());
        match (a.as_str(), value) {
            ("--robots", Some(v)) if v > 0 => robots = v as usize,
            ("--steps", Some(v)) if v > 0 => steps = v,
            _ => {
                eprintln!("usage: field_scale [--robots N] [--steps N]");
                std::process::exit(2);
            }
        }
    }
    let started = Instant::now();
    let map = map_for(robots);
    let (w, h) = (map.width(), map.height());
    let config = FieldConfig::default();
    let mut field = Field::new(map, config).expect("field");
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let size = field.map().size_cm();
    let mut placed = 0;
    while placed < robots {
        let spec = RobotSpec {
            radius: 6.0,
            max_speed: 30.0,
            max_turn: 2.0,
            amphibious: placed % 4 == 0,
        };
        let pose = Pose {
            x: rng.random_range(0.0..size.x),
            y: rng.random_range(0.0..size.y),
            theta: rng.random_range(-3.0..3.0),
        };
        if field.add_robot(spec, pose).is_ok() {
            placed += 1;
        }
    }
    let boxes = 10;
    let spec = BoxSpec {
        half_length: 10.0,
        half_width: 5.0,
        mass: 300.0,
        damping: 3.0,
    };
    let mut added = 0;
    while added < boxes {
        let pose = Pose {
            x: rng.random_range(0.0..size.x),
            y: rng.random_range(0.0..size.y),
            theta: rng.random_range(-3.0..3.0),
        };
        if field.add_box(spec, pose).is_ok() {
            added += 1;
        }
    }
    let setup = started.elapsed().as_secs_f64();
    let mut commands = vec![WheelCommand::STOP; robots];
    let mut pressed = 0usize;
    let started = Instant::now();
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
        field.step(&commands);
        for i in 0..robots {
            if let Some(s) = field.sense(FieldRobotId(i)) {
                pressed += usize::from(s.bump_front || s.sonar.is_some() || s.border_ahead);
            }
        }
    }
    let per_second = steps as f64 / started.elapsed().as_secs_f64();
    println!(
        "| {robots} | {w} x {h} cells, {boxes} boxes | {setup:.3} s | {per_second:.1} | {:.2} | {} | {:.0} % of senses saw something |",
        per_second * config.control_step,
        peak_memory(),
        100.0 * pressed as f64 / (steps as f64 * robots as f64)
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
