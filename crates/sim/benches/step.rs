//! Control steps per second: physics plus `observe` for every robot, as a batch
//! experiment runs them.
//!
//! ```text
//! cargo bench -p colony-sim --bench step
//! ```
//!
//! `standard`: the paper's standard configuration (4 robots, 40 pucks, 187 cm).
//! `scaled/N`: N robots, 10 pucks per robot, arena sides scaled by sqrt(N / 4).
//! Robots wander with random commands, each held for about five steps; the worlds
//! are warmed up for 200 steps first so pucks have been pushed into contact.
//! Criterion's throughput line gives control steps per second.

use std::time::Duration;

use colony_sim::{Observation, RobotId, SceneConfig, WheelCommand, World};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

struct Trial {
    world: World,
    rng: ChaCha8Rng,
    commands: Vec<WheelCommand>,
    obs: Observation,
}

impl Trial {
    fn new(cfg: &SceneConfig) -> Trial {
        let world = World::new(cfg, 1).expect("layout");
        let n = cfg.robots.count;
        let mut t = Trial {
            world,
            rng: ChaCha8Rng::seed_from_u64(2),
            commands: vec![WheelCommand::STOP; n],
            obs: Observation::default(),
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
        self.world.step(&self.commands);
        let mut seen = 0;
        for i in 0..self.commands.len() {
            self.world.observe_into(RobotId(i), &mut self.obs);
            seen += self.obs.pucks.len() + self.obs.obstacles.len();
        }
        seen
    }
}

fn control_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("control_step");
    group.throughput(Throughput::Elements(1));
    group.warm_up_time(Duration::from_secs(1));
    group.measurement_time(Duration::from_secs(5));
    let mut standard = Trial::new(&SceneConfig::default());
    group.bench_function("standard", |b| b.iter(|| standard.step()));
    group.sample_size(10);
    for robots in [16, 64, 256] {
        let mut trial = Trial::new(&SceneConfig::scaled(robots));
        group.bench_with_input(BenchmarkId::new("scaled", robots), &robots, |b, _| {
            b.iter(|| trial.step())
        });
    }
    group.finish();
}

fn observe_only(c: &mut Criterion) {
    // Sensing alone, for all robots of the standard configuration at one instant.
    let trial = Trial::new(&SceneConfig::default());
    let mut obs = Observation::default();
    c.bench_function("observe_all_standard", |b| {
        b.iter(|| {
            for i in 0..4 {
                trial.world.observe_into(RobotId(i), &mut obs);
            }
            obs.obstacles.len()
        })
    });
}

criterion_group!(benches, control_step, observe_only);
criterion_main!(benches);
