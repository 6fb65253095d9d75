//! Control steps per second on the tile-map field: physics plus `sense` for every
//! robot, as a game or experiment loop runs them; and how long a large map takes
//! to build.
//!
//! ```text
//! cargo bench -p colony-sim --bench field
//! ```
//!
//! `control_step/N`: N robots (a quarter amphibious, radius 6 cm, 30 cm/s) and 10
//! boxes on a 64 x 48 map of 10 cm cells with a winding three-cell river crossed by
//! two bridges and 4 % of cells blocked at random. Robots wander with random
//! commands, each held for about five steps; the field is warmed up for 200 steps.
//! Criterion's throughput line gives control steps per second.
//!
//! `build/1024x1024`: `Field::new` on a 1024 x 1024 map of 5 cm cells, 20 % blocked
//! and 10 % water at random (noise, the worst case for merging cells into rectangles).

use std::time::Duration;

use colony_sim::field::{BoxSpec, Field, FieldConfig, FieldRobotId, RobotSpec, Terrain, TileMap};
use colony_sim::{Pose, WheelCommand};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn river_map() -> TileMap {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    TileMap::from_fn(64, 48, 10.0, |x, y| {
        let centre = 30.0 + 6.0 * libm::sin(y as f64 / 6.0);
        let river = (x as f64 - centre).abs() <= 1.5;
        let bridge = (10..13).contains(&y) || (34..37).contains(&y);
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

struct Trial {
    field: Field,
    rng: ChaCha8Rng,
    commands: Vec<WheelCommand>,
}

impl Trial {
    fn new(robots: usize) -> Trial {
        let mut field = Field::new(river_map(), FieldConfig::default()).expect("field");
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
        let spec = BoxSpec {
            half_length: 10.0,
            half_width: 5.0,
            mass: 300.0,
            damping: 3.0,
        };
        let mut boxes = 0;
        while boxes < 10 {
            let pose = Pose {
                x: rng.random_range(0.0..size.x),
                y: rng.random_range(0.0..size.y),
                theta: rng.random_range(-3.0..3.0),
            };
            if field.add_box(spec, pose).is_ok() {
                boxes += 1;
            }
        }
        let mut t = Trial {
            field,
            rng: ChaCha8Rng::seed_from_u64(2),
            commands: vec![WheelCommand::STOP; robots],
        };
        for _ in 0..200 {
            t.step();
        }
        t
    }

    fn step(&mut self) -> usize {
        for c in &mut self.commands {
            if self.rng.random_bool(0.2) {
                *c = WheelCommand {
                    forward: self.rng.random_range(-0.5..1.0),
                    turn: self.rng.random_range(-1.0..1.0),
                };
            }
        }
        self.field.step(&self.commands);
        let mut pressed = 0;
        for i in 0..self.commands.len() {
            if let Some(s) = self.field.sense(FieldRobotId(i)) {
                pressed += usize::from(s.bump_front || s.sonar.is_some() || s.border_ahead);
            }
        }
        pressed
    }
}

fn control_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("control_step");
    group.throughput(Throughput::Elements(1));
    group.warm_up_time(Duration::from_secs(1));
    group.measurement_time(Duration::from_secs(3));
    for robots in [8, 24, 100] {
        let mut trial = Trial::new(robots);
        group.bench_with_input(BenchmarkId::from_parameter(robots), &robots, |b, _| {
            b.iter(|| trial.step())
        });
    }
    group.finish();
}

fn sense_only(c: &mut Criterion) {
    let trial = Trial::new(24);
    c.bench_function("sense_all/24", |b| {
        b.iter(|| {
            (0..24)
                .filter_map(|i| trial.field.sense(FieldRobotId(i)))
                .filter(|s| s.sonar.is_some())
                .count()
        })
    });
}

fn build(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let cells: Vec<Terrain> = (0..1024 * 1024)
        .map(|_| match rng.random_range(0..10) {
            0..=1 => Terrain::Blocked,
            2 => Terrain::Water,
            _ => Terrain::Open,
        })
        .collect();
    let map = TileMap::new(1024, 1024, 5.0, cells).expect("map");
    let mut group = c.benchmark_group("build");
    group.sample_size(10);
    group.bench_function("1024x1024", |b| {
        b.iter(|| Field::new(map.clone(), FieldConfig::default()).expect("field"))
    });
    group.finish();
}

criterion_group!(benches, control_step, sense_only, build);
criterion_main!(benches);
