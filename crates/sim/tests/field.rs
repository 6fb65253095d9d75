//! The tile-map field: driving, water, walls, boxes, placement, activity, determinism.

use colony_sim::field::{
    BoxSpec, Field, FieldBoxId, FieldConfig, FieldRobotId, Refusal, RobotSpec, Terrain, TileMap,
};
use colony_sim::{Pose, SimError, WheelCommand};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use colony_testkit::sim::{bits, pose};

/// A map from rows of text, top row first: `#` blocked, `~` water, anything else open.
fn map(rows: &[&str], cell: f64) -> TileMap {
    TileMap::from_fn(rows[0].len(), rows.len(), cell, |x, y| {
        match rows[y].as_bytes()[x] {
            b'#' => Terrain::Blocked,
            b'~' => Terrain::Water,
            _ => Terrain::Open,
        }
    })
    .unwrap()
}

/// A map of `w` x `h` cells of 10 cm whose column `x` is `column(x)`.
fn columns(w: usize, h: usize, column: impl Fn(usize) -> Terrain) -> TileMap {
    TileMap::from_fn(w, h, 10.0, |x, _| column(x)).unwrap()
}

const LAND: RobotSpec = RobotSpec {
    radius: 5.0,
    max_speed: 30.0,
    max_turn: 2.0,
    amphibious: false,
};

const AMPHIBIAN: RobotSpec = RobotSpec {
    amphibious: true,
    ..LAND
};

const FORWARD: WheelCommand = WheelCommand {
    forward: 1.0,
    turn: 0.0,
};

fn field(map: TileMap) -> Field {
    Field::new(map, FieldConfig::default()).unwrap()
}

fn run(field: &mut Field, commands: &[WheelCommand], steps: usize) {
    for _ in 0..steps {
        field.step(commands);
    }
}

fn refusal(e: SimError) -> Refusal {
    match e {
        SimError::Placement { reason, .. } => reason,
        other => panic!("expected a placement error, got {other}"),
    }
}

#[test]
fn a_land_robot_stops_at_the_water_while_an_amphibian_crosses() {
    // Water in columns 15..18 (x from 150 to 180).
    let map = columns(30, 5, |x| {
        if (15..18).contains(&x) {
            Terrain::Water
        } else {
            Terrain::Open
        }
    });
    let mut f = field(map);
    let land = f.add_robot(LAND, pose(50.0, 15.0, 0.0)).unwrap();
    let amphibian = f.add_robot(AMPHIBIAN, pose(50.0, 35.0, 0.0)).unwrap();
    run(&mut f, &[FORWARD; 2], 100);
    let l = f.robot_pose(land).unwrap();
    let a = f.robot_pose(amphibian).unwrap();
    assert!((l.x - 145.0).abs() < 0.3, "land robot at {l:?}");
    assert!((l.y - 15.0).abs() < 0.1 && l.theta.abs() < 0.01, "{l:?}");
    // The amphibian crossed and is stopped by the map's edge at x = 300.
    assert!((a.x - 295.0).abs() < 0.3, "amphibian at {a:?}");
}

#[test]
fn a_robot_driving_into_a_wall_stops_with_its_front_bumper_pressed() {
    // A wall of blocked cells in column 15 (x from 150 to 160).
    let map = columns(20, 10, |x| {
        if x == 15 {
            Terrain::Blocked
        } else {
            Terrain::Open
        }
    });
    let mut f = field(map);
    let id = f.add_robot(LAND, pose(50.0, 45.0, 0.0)).unwrap();
    assert!(!f.sense(id).unwrap().bump_front);
    run(&mut f, &[FORWARD], 60);
    let p = f.robot_pose(id).unwrap();
    assert!((p.x - 145.0).abs() < 0.3, "{p:?}");
    let s = f.sense(id).unwrap();
    assert!(s.bump_front && !s.bump_rear, "{s:?}");
    assert!(s.contact_bearing.unwrap().abs() < 0.05, "{s:?}");
    // Still pressing: it does not creep into the wall.
    run(&mut f, &[FORWARD], 40);
    assert!((f.robot_pose(id).unwrap().x - p.x).abs() < 0.1);
}

#[test]
fn a_pushed_box_moves_and_is_stopped_by_a_wall() {
    let map = columns(30, 10, |x| {
        if x == 25 {
            Terrain::Blocked
        } else {
            Terrain::Open
        }
    });
    let mut f = field(map);
    let spec = BoxSpec {
        half_length: 10.0,
        half_width: 10.0,
        mass: 200.0,
        damping: 5.0,
    };
    let b = f.add_box(spec, pose(100.0, 50.0, 0.0)).unwrap();
    let r = f.add_robot(LAND, pose(84.0, 50.0, 0.0)).unwrap();
    run(&mut f, &[FORWARD], 20);
    let moved = f.box_pose(b).unwrap();
    assert!(moved.x > 120.0, "box at {moved:?}");
    run(&mut f, &[FORWARD], 200);
    let stopped = f.box_pose(b).unwrap();
    // Against the wall at x = 250 (a slight turn would leave it a little short).
    assert!(
        stopped.x + 10.0 <= 250.3 && stopped.x + 10.0 > 248.0,
        "{stopped:?}"
    );
    let robot = f.robot_pose(r).unwrap();
    assert!(
        robot.x < stopped.x - 10.0,
        "robot {robot:?} box {stopped:?}"
    );
    assert!(f.sense(r).unwrap().bump_front);
    // Left alone, it stays.
    run(&mut f, &[WheelCommand::STOP], 20);
    assert!((f.box_pose(b).unwrap().x - stopped.x).abs() < 0.5);
}

#[test]
fn boxes_stop_at_water_and_walls_stop_boxes_turned_at_an_angle() {
    let map = columns(30, 10, |x| {
        if x >= 20 {
            Terrain::Water
        } else {
            Terrain::Open
        }
    });
    let mut f = field(map);
    let spec = BoxSpec {
        half_length: 5.0,
        half_width: 5.0,
        mass: 50.0,
        damping: 2.0,
    };
    let b = f.add_box(spec, pose(100.0, 50.0, 0.0)).unwrap();
    f.add_robot(AMPHIBIAN, pose(89.0, 50.0, 0.0)).unwrap();
    run(&mut f, &[FORWARD], 100);
    let p = f.box_pose(b).unwrap();
    assert!(p.x + 5.0 <= 200.3, "box went into the water: {p:?}");
}

/// A 64 x 48 field with a river (two bridges) and scattered walls, `n` robots
/// spread over the land and a few boxes.
fn busy_field(n: usize) -> Field {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let map = TileMap::from_fn(64, 48, 10.0, |x, y| {
        let river = (x as i64 - 30 - (y as i64 / 8)).abs() <= 1;
        let bridge = (10..13).contains(&y) || (34..37).contains(&y);
        if river && !bridge {
            Terrain::Water
        } else if rng.random_bool(0.04) {
            Terrain::Blocked
        } else {
            Terrain::Open
        }
    })
    .unwrap();
    let mut f = field(map);
    let mut placed = 0;
    let mut k = 0;
    while placed < n {
        let x = 15.0 + (k % 30) as f64 * 21.0;
        let y = 15.0 + (k / 30) as f64 * 21.0;
        let spec = if placed % 4 == 0 { AMPHIBIAN } else { LAND };
        if f.add_robot(spec, pose(x, y, k as f64)).is_ok() {
            placed += 1;
        }
        k += 1;
        assert!(k < 10_000);
    }
    let spec = BoxSpec {
        half_length: 8.0,
        half_width: 4.0,
        mass: 100.0,
        damping: 3.0,
    };
    for k in 0..20 {
        let _ = f.add_box(spec, pose(25.0 + 31.0 * k as f64, 400.0, 0.3 * k as f64));
    }
    f
}

fn trace(seed: u64) -> Vec<u64> {
    let mut f = busy_field(24);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut commands = vec![WheelCommand::STOP; 24];
    let mut out = Vec::new();
    for step in 0..300 {
        for c in &mut commands {
            if rng.random_bool(0.2) {
                *c = WheelCommand {
                    forward: rng.random_range(-1.0..1.0),
                    turn: rng.random_range(-1.0..1.0),
                };
            }
        }
        if step == 100 {
            f.set_active(FieldRobotId(3), false).unwrap();
        }
        f.step(&commands);
        for r in f.robots() {
            out.extend(bits(r.pose));
            if let Some(s) = f.sense(r.id) {
                out.push(u64::from(s.bump_front) | u64::from(s.bump_rear) << 1);
                out.push(s.sonar.map_or(0, |e| e.distance.to_bits()));
            }
        }
        for b in f.boxes() {
            out.extend(bits(b.pose));
        }
    }
    out
}

#[test]
fn the_same_inputs_give_bit_identical_runs() {
    let a = trace(5);
    let b = trace(5);
    assert_eq!(a.len(), b.len());
    assert!(a == b, "runs differ");
    assert_ne!(trace(6), a);
}

#[test]
fn robots_on_a_busy_field_stay_on_land_or_amphibious() {
    let mut f = busy_field(24);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut commands = vec![WheelCommand::STOP; 24];
    for _ in 0..500 {
        for c in &mut commands {
            if rng.random_bool(0.2) {
                *c = WheelCommand {
                    forward: rng.random_range(-1.0..1.0),
                    turn: rng.random_range(-1.0..1.0),
                };
            }
        }
        f.step(&commands);
        for r in f.robots() {
            let t = f.map().terrain_at(r.pose.position());
            assert_ne!(t, Terrain::Blocked, "{r:?}");
            if !r.spec.amphibious {
                assert_ne!(t, Terrain::Water, "{r:?}");
            }
        }
    }
}

#[test]
fn placement_is_refused_with_a_clear_reason() {
    let mut f = field(map(
        &[
            "..........", //
            "..#.......",
            "......~~..",
            "..........",
        ],
        10.0,
    ));
    // Cell (2, 1) covers x 20..30, y 20..30.
    let e = f.add_robot(LAND, pose(25.0, 25.0, 0.0)).unwrap_err();
    assert_eq!(
        e.to_string(),
        "cannot place robot 0 at (25, 25): it would overlap blocked cell (2, 1)"
    );
    assert_eq!(refusal(e), Refusal::Blocked { x: 2, y: 1 });
    // Near but not on the wall: the disc still overlaps it.
    let e = f.add_robot(LAND, pose(34.0, 25.0, 0.0)).unwrap_err();
    assert_eq!(refusal(e), Refusal::Blocked { x: 2, y: 1 });
    // Touching is fine.
    f.add_robot(LAND, pose(35.0, 25.0, 0.0)).unwrap();
    // Water: cells (6, 2) and (7, 2), x 60..80, y 10..20.
    let e = f.add_robot(LAND, pose(65.0, 15.0, 0.0)).unwrap_err();
    assert!(e.to_string().contains("water cell (6, 2)"), "{e}");
    assert_eq!(refusal(e), Refusal::Water { x: 6, y: 2 });
    let amphibian = f.add_robot(AMPHIBIAN, pose(65.0, 15.0, 0.0)).unwrap();
    assert_eq!(amphibian, FieldRobotId(1));
    let e = f.add_robot(LAND, pose(40.0, 25.0, 0.0)).unwrap_err();
    assert_eq!(refusal(e), Refusal::Robot(FieldRobotId(0)));
    let e = f.add_robot(LAND, pose(3.0, 25.0, 0.0)).unwrap_err();
    assert_eq!(refusal(e), Refusal::OffMap);
    let e = f.add_robot(LAND, pose(f64::NAN, 25.0, 0.0)).unwrap_err();
    assert_eq!(refusal(e), Refusal::NotFinite);
    let e = f
        .add_robot(
            RobotSpec {
                radius: 0.0,
                ..LAND
            },
            pose(50.0, 35.0, 0.0),
        )
        .unwrap_err();
    assert!(
        matches!(e, SimError::Config(_)) && e.to_string().contains("robot.radius"),
        "{e}"
    );
    // Boxes: not on water, not on robots, not on each other.
    let spec = BoxSpec {
        half_length: 4.0,
        half_width: 2.0,
        mass: 10.0,
        damping: 1.0,
    };
    let e = f.add_box(spec, pose(75.0, 18.0, 0.0)).unwrap_err();
    assert_eq!(refusal(e), Refusal::Water { x: 7, y: 2 });
    let e = f.add_box(spec, pose(40.0, 25.0, 0.0)).unwrap_err();
    assert_eq!(refusal(e), Refusal::Robot(FieldRobotId(0)));
    let b = f.add_box(spec, pose(90.0, 30.0, 1.0)).unwrap();
    let e = f.add_box(spec, pose(91.0, 31.0, 0.0)).unwrap_err();
    assert_eq!(
        e.to_string(),
        "cannot place box 1 at (91, 31): it would overlap box 0"
    );
    assert_eq!(refusal(e), Refusal::Box(b));
    let e = f.add_robot(LAND, pose(90.0, 34.0, 0.0)).unwrap_err();
    assert_eq!(refusal(e), Refusal::Box(FieldBoxId(0)));
    assert_eq!(f.robot_count(), 2);
    assert_eq!(f.box_count(), 1);
}

#[test]
fn commands_of_the_wrong_length_or_value_do_not_panic() {
    let mut f = field(TileMap::open(20, 10, 10.0).unwrap());
    let start: Vec<Pose> = (0..3)
        .map(|i| {
            let id = f
                .add_robot(LAND, pose(30.0 + 40.0 * i as f64, 50.0, 0.0))
                .unwrap();
            f.robot_pose(id).unwrap()
        })
        .collect();
    // Missing commands count as stop.
    run(&mut f, &[], 10);
    for (i, p) in start.iter().enumerate() {
        assert_eq!(f.robot_pose(FieldRobotId(i)), Some(*p));
    }
    f.step(&[FORWARD]);
    assert!(f.robot_pose(FieldRobotId(0)).unwrap().x > start[0].x);
    assert_eq!(f.robot_pose(FieldRobotId(2)), Some(start[2]));
    // Extra commands are ignored; NaN is zero, infinities are clamped.
    f.step(&[FORWARD; 10]);
    let nan = WheelCommand {
        forward: f64::NAN,
        turn: f64::NAN,
    };
    let before = f.robot_pose(FieldRobotId(1)).unwrap();
    f.step(&[nan, nan, nan]);
    assert_eq!(f.robot_pose(FieldRobotId(1)), Some(before));
    let wild = WheelCommand {
        forward: f64::INFINITY,
        turn: f64::NEG_INFINITY,
    };
    run(&mut f, &[wild; 3], 5);
    assert!(f
        .robots()
        .all(|r| r.pose.x.is_finite() && r.pose.theta.is_finite()));
    assert_eq!(f.step_count(), 18);
    assert!((f.time() - 1.8).abs() < 1e-9);
    // Unknown ids are answered, not panicked on.
    assert_eq!(f.robot_pose(FieldRobotId(99)), None);
    assert_eq!(f.sense(FieldRobotId(99)), None);
    assert_eq!(f.box_pose(FieldBoxId(0)), None);
    assert!(matches!(
        f.set_active(FieldRobotId(7), false),
        Err(SimError::UnknownId {
            what: "robot",
            id: 7
        })
    ));
    assert!(f.respawn(FieldRobotId(7), pose(50.0, 50.0, 0.0)).is_err());
}

#[test]
fn an_inactive_robot_stays_put_and_is_not_met_until_respawned() {
    let mut f = field(TileMap::open(30, 10, 10.0).unwrap());
    let a = f.add_robot(LAND, pose(50.0, 50.0, 0.0)).unwrap();
    let b = f.add_robot(LAND, pose(100.0, 50.0, 0.0)).unwrap();
    let echo = f.sense(a).unwrap().sonar.expect("a sees b");
    assert!((echo.distance - 40.0).abs() < 0.01, "{echo:?}");

    f.set_active(b, false).unwrap();
    f.set_active(b, false).unwrap(); // again: nothing changes
    assert_eq!(f.is_active(b), Some(false));
    assert_eq!(f.sense(b), None, "a switched-off robot senses nothing");
    assert_eq!(f.sense(a).unwrap().sonar, None, "nor is it sensed");
    let parked = f.robot_pose(b).unwrap();
    // a drives through where b stands; b ignores its command.
    run(&mut f, &[FORWARD, FORWARD], 30);
    assert_eq!(f.robot_pose(b), Some(parked));
    let pa = f.robot_pose(a).unwrap();
    assert!(pa.x > 130.0, "{pa:?}");
    assert!(f
        .robots()
        .any(|r| r.id == b && !r.active && r.pose == parked));

    // Back where it was: refused while a is there... (a is at about x = 140)
    f.respawn(a, pose(100.0, 50.0, 0.0)).unwrap();
    let e = f.set_active(b, true).unwrap_err();
    assert_eq!(refusal(e), Refusal::Robot(a));
    assert_eq!(f.is_active(b), Some(false));
    // ...and accepted elsewhere, after which it drives again.
    f.respawn(b, pose(200.0, 50.0, std::f64::consts::PI))
        .unwrap();
    assert_eq!(f.is_active(b), Some(true));
    run(&mut f, &[WheelCommand::STOP, FORWARD], 10);
    let pb = f.robot_pose(b).unwrap();
    assert!((pb.x - 170.0).abs() < 0.3, "{pb:?}");
    assert!(f.sense(b).is_some());
}

#[test]
fn a_large_random_map_builds_and_runs() {
    let mut s = 7u64;
    let map = TileMap::from_fn(1024, 1024, 5.0, |_, _| {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        match (s >> 33) % 10 {
            0..=1 => Terrain::Blocked,
            2 => Terrain::Water,
            _ => Terrain::Open,
        }
    })
    .unwrap();
    let mut f = field(map);
    let small = RobotSpec {
        radius: 2.0,
        ..LAND
    };
    let ids: Vec<_> = (0..200)
        .filter_map(|k| {
            let p = f.map().cell_center(k * 5 % 1024, k * 3 % 1024);
            f.add_robot(small, pose(p.x, p.y, 0.0)).ok()
        })
        .collect();
    assert!(!ids.is_empty());
    run(&mut f, &[FORWARD; 200], 5);
    for id in ids {
        assert!(f.sense(id).is_some());
    }
}

#[test]
fn robots_placed_or_moved_between_steps_are_found_by_placement_and_sensing() {
    // A 10 m square; 150 robots on a 40 cm lattice, more than the field leaves out of its
    // index between steps, so some are found in the index and some past it.
    let mut f = field(columns(100, 100, |_| Terrain::Open));
    for i in 0..150 {
        let (x, y) = (20.0 + 40.0 * (i % 20) as f64, 20.0 + 40.0 * (i / 20) as f64);
        f.add_robot(LAND, pose(x, y, 0.0)).unwrap();
    }
    for probe in [3, 77, 149] {
        let p = f.robot_pose(FieldRobotId(probe)).unwrap();
        let e = f.add_robot(LAND, pose(p.x + 6.0, p.y, 0.0)).unwrap_err();
        assert_eq!(refusal(e), Refusal::Robot(FieldRobotId(probe)));
    }
    // Robot 5 moves before any step: its new place is taken, its old one free.
    let old = f.robot_pose(FieldRobotId(5)).unwrap();
    f.respawn(FieldRobotId(5), pose(900.0, 900.0, 0.0)).unwrap();
    let e = f.add_robot(LAND, pose(905.0, 900.0, 0.0)).unwrap_err();
    assert_eq!(refusal(e), Refusal::Robot(FieldRobotId(5)));
    let newcomer = f.add_robot(LAND, pose(old.x, old.y, 0.0)).unwrap();
    // One just behind robot 5's new place bumps it, before and after a step.
    let behind = f.add_robot(LAND, pose(889.9, 900.0, 0.0)).unwrap();
    assert!(f.sense(behind).unwrap().bump_front);
    f.step(&[]);
    assert!(f.sense(behind).unwrap().bump_front);
    assert!(!f.sense(newcomer).unwrap().bump_front);
    // Switched off, robot 5 is no obstacle.
    f.set_active(FieldRobotId(5), false).unwrap();
    assert!(!f.sense(behind).unwrap().bump_front);
    f.add_robot(LAND, pose(905.0, 900.0, 0.0)).unwrap();
}
