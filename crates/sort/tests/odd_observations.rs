//! Every method survives odd (but NaN-free) observations and keeps its
//! commands within [-1, 1].

use colony_sim::{Observation, Pose, PuckKind, SeenPuck, Vec2};
use colony_sort::methods::{build, Method};
use colony_sort::params::SortParams;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn odd_value(r: &mut ChaCha8Rng) -> f64 {
    match r.random_range(0..8) {
        0 => 0.0,
        1 => r.random_range(-1e12..1e12),
        2 => -0.0,
        3 => f64::MAX / 4.0,
        4 => r.random_range(-2.0..2.0),
        _ => r.random_range(-60.0..60.0),
    }
}

fn odd_point(r: &mut ChaCha8Rng) -> Vec2 {
    Vec2::new(odd_value(r), odd_value(r))
}

fn odd_puck(r: &mut ChaCha8Rng) -> SeenPuck {
    SeenPuck {
        kind: PuckKind(if r.random_bool(0.1) {
            255
        } else {
            r.random_range(0..3)
        }),
        pos: odd_point(r),
        held_by_other: r.random_bool(0.2),
    }
}

fn odd_observation(r: &mut ChaCha8Rng) -> Observation {
    let n = r.random_range(0..25);
    let mut pucks: Vec<SeenPuck> = (0..n).map(|_| odd_puck(r)).collect();
    if let Some(first) = pucks.first().copied() {
        pucks.push(first); // a duplicate
    }
    Observation {
        pose: Pose {
            x: odd_value(r),
            y: odd_value(r),
            theta: odd_value(r),
        },
        gripper: r.random_bool(0.4).then(|| odd_puck(r)),
        pucks,
        robots: (0..r.random_range(0..3)).map(|_| odd_point(r)).collect(),
        obstacles: (0..r.random_range(0..60)).map(|_| odd_point(r)).collect(),
    }
}

#[test]
fn no_method_panics_or_leaves_the_command_range_on_odd_observations() {
    let params = SortParams::default();
    for method in Method::ALL {
        for seed in 0..8 {
            let mut world = ChaCha8Rng::seed_from_u64(seed);
            let mut rng = ChaCha8Rng::seed_from_u64(seed + 100);
            let mut robot = build(method, &params, 3, 187.0);
            robot.step(&Observation::default(), &mut rng);
            for _ in 0..150 {
                let obs = odd_observation(&mut world);
                let c = robot.step(&obs, &mut rng);
                assert!(
                    c.forward.is_finite() && c.turn.is_finite(),
                    "{method}: {c:?} for {obs:?}"
                );
                assert!(
                    c.forward.abs() <= 1.0 && c.turn.abs() <= 1.0,
                    "{method}: {c:?}"
                );
                let _ = (robot.state(), robot.cache_points(), robot.target());
            }
        }
    }
}

#[test]
fn every_method_is_deterministic_for_a_seed() {
    let params = SortParams::default();
    for method in Method::ALL {
        let run = || {
            let mut world = ChaCha8Rng::seed_from_u64(3);
            let mut rng = ChaCha8Rng::seed_from_u64(4);
            let mut robot = build(method, &params, 2, 187.0);
            (0..100)
                .map(|_| {
                    let c = robot.step(&odd_observation(&mut world), &mut rng);
                    (c.forward.to_bits(), c.turn.to_bits(), robot.state())
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(run(), run(), "{method}");
    }
}
