//! The arena as Foxglove scene entities, built on the monitor's bridge thread with each world
//! frame while a viewer is subscribed to it: the standard swarm (4 robots, 40 pucks), 1,500
//! robots with 3,000 pucks and 1,500 cache points, and `sort live --scale-robots 10000`'s
//! swarm (10,000 robots, 100,000 pucks; the cache points the monitor keeps at most).
//!
//! `cargo bench -p colony-foxglove --bench scene`

use colony_foxglove::scene::arena_scene;
use colony_proto::swarm::{Arena, PuckKind, VisionFrame, VisionPuck, VisionRobot};
use colony_proto::{Pose, Vec2};
use criterion::{criterion_group, criterion_main, Criterion};

fn frame(robots: u32, pucks: u32) -> VisionFrame {
    VisionFrame {
        step: 1,
        robots: (0..robots)
            .map(|id| VisionRobot {
                id,
                pose: Pose {
                    x: f64::from(id % 100) * 9.0,
                    y: f64::from(id / 100) * 9.0,
                    theta: f64::from(id) * 0.1,
                },
                carrying: None,
            })
            .collect(),
        pucks: (0..pucks)
            .map(|id| VisionPuck {
                id,
                kind: PuckKind((id % 2) as u8),
                pos: Vec2 {
                    x: f64::from(id % 100) * 7.0,
                    y: f64::from(id / 100) * 7.0,
                },
            })
            .collect(),
        ..Default::default()
    }
}

fn bench(c: &mut Criterion) {
    let arena = Some(Arena {
        width: 187.0,
        height: 187.0,
        corner: 15.0,
    });
    for (name, robots, pucks) in [
        ("standard", 4, 40),
        ("largest", 1500, 3000),
        ("swarm", 10_000, 100_000),
    ] {
        let f = frame(robots, pucks);
        let caches: Vec<(u32, u8, f64, f64)> = (0..robots.min(1500))
            .map(|r| (r, (r % 2) as u8, f64::from(r), 0.0))
            .collect();
        let bytes = arena_scene(&f, arena, None, caches.iter().copied(), 0).len();
        println!("{name}: {robots} robots, {pucks} pucks: {bytes} bytes of JSON");
        let mut group = c.benchmark_group("arena_scene");
        if robots > 1500 {
            // About 0.1 s a scene: ten samples are enough to see it.
            group.sample_size(10);
        }
        group.bench_function(name, |b| {
            b.iter(|| arena_scene(&f, arena, None, caches.iter().copied(), 0))
        });
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
