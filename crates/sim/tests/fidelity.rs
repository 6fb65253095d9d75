//! The disc engine against rapier, the reference: small statistics of what the sorting
//! science rests on, each with its equivalence margin written down before it was run.
//!
//! - **Capture.** A robot drives at a puck from 40 cm, 41 approaches (lateral offset
//!   -4.5 to 4.5 cm by 1.5, heading -30 to 30 degrees by 10, minus the extremes' overlap):
//!   the share captured within 20 control steps differs by at most 0.10, and at least
//!   85 % of the approaches end alike (captured in both or in neither).
//! - **Holding.** A robot holding a puck turns on the spot at four rates, each way, for
//!   40 control steps (more than two full turns at full rate): every turn keeps the puck
//!   with both engines, or the control steps it was held differ by at most 5 on average.
//! - **Coasting.** A robot backs into a puck at three speeds and stops: the puck's slide
//!   after the stop differs by at most 1.0 cm (the slides are a few centimetres).
//! - **Breaking a cluster.** A robot drives through a 4 x 4 cluster of touching pucks at
//!   five lateral offsets: the mean fragment size afterwards (pucks less than 1 cm apart
//!   count as one fragment) differs by at most 30 %, and the share of pucks moved more
//!   than 3 cm by at most 0.15.

use colony_sim::{Engine, Pose, PuckKind, RobotId, SceneConfig, Vec2, WheelCommand, World};

fn world(engine: Engine, robot: Pose, pucks: &[Vec2]) -> World {
    let mut cfg = SceneConfig::default();
    cfg.physics.engine = engine;
    let pucks: Vec<(PuckKind, Vec2)> = pucks.iter().map(|&p| (PuckKind(0), p)).collect();
    World::with_layout(&cfg, &[robot], &pucks).unwrap()
}

fn go(forward: f64, turn: f64) -> WheelCommand {
    WheelCommand { forward, turn }
}

/// For each approach, whether the puck was captured.
fn captures(engine: Engine) -> Vec<bool> {
    let mut out = Vec::new();
    for offset in [-4.5f64, -3.0, -1.5, 0.0, 1.5, 3.0, 4.5] {
        for deg in [-30.0f64, -20.0, -10.0, 0.0, 10.0, 20.0, 30.0] {
            if offset.abs() > 4.0 && deg.abs() > 25.0 {
                continue;
            }
            let theta = deg.to_radians();
            // Start 40 cm short of the puck along the heading, shifted sideways by the offset.
            let (c, s) = (theta.cos(), theta.sin());
            let start = Pose {
                x: -40.0 * c - offset * s,
                y: -40.0 * s + offset * c,
                theta,
            };
            let mut w = world(engine, start, &[Vec2::new(0.0, 0.0)]);
            let mut held = false;
            for _ in 0..20 {
                w.step(&[go(1.0, 0.0)]);
                held |= w.observe(RobotId(0)).gripper.is_some();
            }
            out.push(held);
        }
    }
    out
}

#[test]
fn capture_by_approach_offset_and_angle_matches_rapier() {
    let (a, b) = (captures(Engine::Rapier), captures(Engine::Disc));
    assert_eq!(a.len(), 45);
    let rate = |v: &[bool]| v.iter().filter(|&&x| x).count() as f64 / v.len() as f64;
    let alike = a.iter().zip(&b).filter(|(x, y)| x == y).count() as f64 / a.len() as f64;
    eprintln!(
        "capture rate: rapier {:.3}, disc {:.3}; approaches alike {:.3}",
        rate(&a),
        rate(&b),
        alike
    );
    assert!((rate(&a) - rate(&b)).abs() <= 0.10);
    assert!(alike >= 0.85);
    // Not a vacuous comparison: some approaches capture and some miss.
    assert!(rate(&a) > 0.3 && rate(&a) < 1.0, "rapier {a:?}");
}

/// Control steps a captured puck stays held through a turn on the spot at `rate`.
fn held_through_turn(engine: Engine, rate: f64) -> usize {
    let mut w = world(
        engine,
        Pose {
            x: -20.0,
            y: 0.0,
            theta: 0.0,
        },
        &[Vec2::new(0.0, 0.0)],
    );
    for _ in 0..8 {
        w.step(&[go(1.0, 0.0)]);
    }
    assert!(
        w.observe(RobotId(0)).gripper.is_some(),
        "{engine}: not captured"
    );
    let mut held = 0;
    for _ in 0..40 {
        w.step(&[go(0.0, rate)]);
        if w.observe(RobotId(0)).gripper.is_none() {
            break;
        }
        held += 1;
    }
    held
}

#[test]
fn holding_a_puck_through_turns_matches_rapier() {
    let rates = [-1.0, -0.75, -0.5, -0.25, 0.25, 0.5, 0.75, 1.0];
    let a: Vec<usize> = rates
        .iter()
        .map(|&r| held_through_turn(Engine::Rapier, r))
        .collect();
    let b: Vec<usize> = rates
        .iter()
        .map(|&r| held_through_turn(Engine::Disc, r))
        .collect();
    eprintln!("held through turns: rapier {a:?}, disc {b:?}");
    let mean_gap = a
        .iter()
        .zip(&b)
        .map(|(&x, &y)| x.abs_diff(y))
        .sum::<usize>() as f64
        / a.len() as f64;
    assert!(a == b || mean_gap <= 5.0, "rapier {a:?}, disc {b:?}");
}

/// How far a puck slides after the robot that pushed it at `speed` stops, cm.
fn coast(engine: Engine, speed: f64) -> f64 {
    let mut w = world(
        engine,
        Pose {
            x: 0.0,
            y: 0.0,
            theta: 0.0,
        },
        &[Vec2::new(-15.0, 0.0)],
    );
    for _ in 0..10 {
        w.step(&[go(-speed, 0.0)]);
    }
    let pushed = w.pucks()[0].pos;
    assert!(
        pushed.x < -17.0,
        "{engine}: not pushed at {speed}: {pushed:?}"
    );
    for _ in 0..10 {
        w.step(&[WheelCommand::STOP]);
    }
    w.pucks()[0].pos.distance(pushed)
}

#[test]
fn coasting_after_a_push_matches_rapier() {
    for speed in [0.5, 0.75, 1.0] {
        let (a, b) = (coast(Engine::Rapier, speed), coast(Engine::Disc, speed));
        eprintln!("coast at {speed}: rapier {a:.3} cm, disc {b:.3} cm");
        assert!((a - b).abs() <= 1.0, "at {speed}: rapier {a}, disc {b}");
    }
}

/// Mean fragment size and the share of pucks moved far, after a robot drives through a
/// 4 x 4 cluster at `offset`.
fn break_cluster(engine: Engine, offset: f64) -> (f64, f64) {
    let mut start = Vec::new();
    for i in 0..4 {
        for j in 0..4 {
            start.push(Vec2::new(i as f64 * 6.4, (j as f64 - 1.5) * 6.4));
        }
    }
    let mut w = world(
        engine,
        Pose {
            x: -40.0,
            y: offset,
            theta: 0.0,
        },
        &start,
    );
    for _ in 0..30 {
        w.step(&[go(1.0, 0.0)]);
    }
    let pucks = w.pucks();
    let moved = pucks
        .iter()
        .zip(&start)
        .filter(|(p, s)| p.pos.distance(**s) > 3.0)
        .count() as f64
        / start.len() as f64;
    // Fragments: pucks whose surfaces are under 1 cm apart are joined.
    let n = pucks.len();
    let mut label: Vec<usize> = (0..n).collect();
    fn root(label: &mut [usize], mut i: usize) -> usize {
        while label[i] != i {
            label[i] = label[label[i]];
            i = label[i];
        }
        i
    }
    let reach = 2.0 * 3.15 + 1.0;
    for i in 0..n {
        for j in i + 1..n {
            if pucks[i].pos.distance(pucks[j].pos) < reach {
                let (a, b) = (root(&mut label, i), root(&mut label, j));
                label[a] = b;
            }
        }
    }
    let fragments = (0..n).filter(|&i| root(&mut label, i) == i).count();
    (n as f64 / fragments as f64, moved)
}

#[test]
fn breaking_a_cluster_matches_rapier() {
    let offsets = [-8.0, -4.0, 0.0, 4.0, 8.0];
    let run = |e| -> (f64, f64) {
        let all: Vec<(f64, f64)> = offsets.iter().map(|&o| break_cluster(e, o)).collect();
        let k = all.len() as f64;
        (
            all.iter().map(|x| x.0).sum::<f64>() / k,
            all.iter().map(|x| x.1).sum::<f64>() / k,
        )
    };
    let (a, b) = (run(Engine::Rapier), run(Engine::Disc));
    eprintln!(
        "cluster: mean fragment rapier {:.2}, disc {:.2}; moved rapier {:.2}, disc {:.2}",
        a.0, b.0, a.1, b.1
    );
    assert!(
        (a.0 - b.0).abs() <= 0.3 * a.0,
        "fragments: rapier {}, disc {}",
        a.0,
        b.0
    );
    assert!(
        (a.1 - b.1).abs() <= 0.15,
        "moved: rapier {}, disc {}",
        a.1,
        b.1
    );
    assert!(a.1 > 0.1, "the robot moved pucks: {a:?}");
}
