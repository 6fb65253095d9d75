//! The tile-map field's sensors: sonar, bumpers, border detector.

use std::f64::consts::{FRAC_PI_2, PI};

use colony_sim::field::{BoxSpec, Field, FieldConfig, RobotSpec, Terrain, TileMap};
use colony_sim::{Pose, WheelCommand};

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

const BACK: WheelCommand = WheelCommand {
    forward: -1.0,
    turn: 0.0,
};

fn pose(x: f64, y: f64, theta: f64) -> Pose {
    Pose { x, y, theta }
}

/// A field of `w` x 10 cells of 10 cm whose column `x` is `column(x)`.
fn field(w: usize, column: impl Fn(usize) -> Terrain) -> Field {
    let map = TileMap::from_fn(w, 10, 10.0, |x, _| column(x)).unwrap();
    Field::new(map, FieldConfig::default()).unwrap()
}

fn open(_: usize) -> Terrain {
    Terrain::Open
}

#[test]
fn the_sonar_sees_a_wall_ahead_at_the_right_distance_and_not_one_behind() {
    // A wall of blocked cells at column 20 (x from 200), the map's edge at 0 and 400.
    let mut f = field(40, |x| {
        if x == 20 {
            Terrain::Blocked
        } else {
            Terrain::Open
        }
    });
    let ahead = f.add_robot(LAND, pose(160.0, 50.0, 0.0)).unwrap();
    let behind = f.add_robot(LAND, pose(160.0, 80.0, PI)).unwrap();
    let edge = f.add_robot(LAND, pose(360.0, 20.0, 0.0)).unwrap();
    let echo = f.sense(ahead).unwrap().sonar.expect("wall ahead");
    assert!((echo.distance - 35.0).abs() < 1.0, "{echo:?}");
    assert!(echo.bearing.abs() < 1e-9, "{echo:?}");
    // Facing away from the wall 35 cm behind it, and 155 cm from the edge ahead.
    assert_eq!(f.sense(behind).unwrap().sonar, None);
    let echo = f.sense(edge).unwrap().sonar.expect("map edge ahead");
    assert!((echo.distance - 35.0).abs() < 1.0, "{echo:?}");
    // Out of range (60 cm) after backing off.
    f.respawn(ahead, pose(130.0, 50.0, 0.0)).unwrap();
    assert_eq!(f.sense(ahead).unwrap().sonar, None);
    // At an angle, the nearest ray is the one closest to the wall's normal.
    f.respawn(ahead, pose(160.0, 50.0, 0.2)).unwrap();
    let echo = f.sense(ahead).unwrap().sonar.unwrap();
    assert!(echo.bearing < 0.0, "{echo:?}");
    assert!(echo.distance > 35.0 && echo.distance < 41.0, "{echo:?}");
}

#[test]
fn the_sonar_sees_robots_boxes_and_water_but_amphibians_ignore_water() {
    let mut f = field(40, |x| {
        if x == 20 {
            Terrain::Water
        } else {
            Terrain::Open
        }
    });
    let land = f.add_robot(LAND, pose(160.0, 20.0, 0.0)).unwrap();
    let amphibian = f.add_robot(AMPHIBIAN, pose(160.0, 50.0, 0.0)).unwrap();
    let echo = f.sense(land).unwrap().sonar.expect("water ahead");
    assert!((echo.distance - 35.0).abs() < 1.0, "{echo:?}");
    assert_eq!(f.sense(amphibian).unwrap().sonar, None);
    // A robot, then a box, in front of the amphibian.
    let other = f.add_robot(LAND, pose(190.0, 52.0, 0.0)).unwrap();
    let echo = f.sense(amphibian).unwrap().sonar.expect("robot ahead");
    assert!(echo.distance > 19.0 && echo.distance < 21.0, "{echo:?}");
    f.set_active(other, false).unwrap();
    let spec = BoxSpec {
        half_length: 5.0,
        half_width: 5.0,
        mass: 50.0,
        damping: 2.0,
    };
    f.add_box(spec, pose(185.0, 50.0, 0.0)).unwrap();
    let echo = f.sense(amphibian).unwrap().sonar.expect("box ahead");
    assert!((echo.distance - 15.0).abs() < 1e-6, "{echo:?}");
}

#[test]
fn the_border_detector_sees_water_before_the_robot_reaches_it() {
    // Water from x = 200.
    let mut f = field(40, |x| {
        if x >= 20 {
            Terrain::Water
        } else {
            Terrain::Open
        }
    });
    let land = f.add_robot(LAND, pose(100.0, 20.0, 0.0)).unwrap();
    let amphibian = f.add_robot(AMPHIBIAN, pose(100.0, 60.0, 0.0)).unwrap();
    let mut first = None;
    for step in 0..60 {
        let s = f.sense(land).unwrap();
        if s.border_ahead && first.is_none() {
            first = Some((step, s.pose));
        }
        assert!(!f.sense(amphibian).unwrap().border_ahead);
        f.step(&[FORWARD, FORWARD]);
    }
    let (_, at) = first.expect("the border detector fired");
    let front = at.x + LAND.radius;
    assert!(
        (195.0..198.0).contains(&front),
        "fired with the front edge at {front}"
    );
    let s = f.sense(land).unwrap();
    assert!(s.border_ahead && s.bump_front, "{s:?}");
    assert!((s.pose.x - 195.0).abs() < 0.3, "{s:?}");
    // The detector also sees the map's edge and walls.
    let edge = f
        .add_robot(LAND, pose(9.0, 50.0, PI))
        .expect("room by the left edge");
    assert!(f.sense(edge).unwrap().border_ahead);
}

#[test]
fn bumpers_tell_front_from_rear_and_give_the_bearing() {
    let mut f = field(20, open);
    let id = f.add_robot(LAND, pose(100.0, 50.0, FRAC_PI_2)).unwrap();
    let s = f.sense(id).unwrap();
    assert!(!s.bump_front && !s.bump_rear && s.contact_bearing.is_none());
    // Backing into the bottom edge (y = 0).
    f.respawn(id, pose(100.0, 20.0, FRAC_PI_2)).unwrap();
    for _ in 0..20 {
        f.step(&[BACK]);
    }
    let s = f.sense(id).unwrap();
    assert!(s.bump_rear && !s.bump_front, "{s:?}");
    assert!(
        (s.contact_bearing.unwrap().abs() - PI).abs() < 0.05,
        "{s:?}"
    );
    assert!((s.pose.y - 5.0).abs() < 0.3, "{s:?}");
    // Another robot touching its left side, facing the other way.
    f.respawn(id, pose(100.0, 50.0, FRAC_PI_2)).unwrap();
    let other = f.add_robot(LAND, pose(90.0, 50.5, PI)).unwrap();
    let s = f.sense(id).unwrap();
    let bearing = s.contact_bearing.unwrap();
    assert!(s.bump_front && !s.bump_rear, "{s:?}");
    assert!(bearing > 1.4 && bearing < FRAC_PI_2, "{s:?}");
    let o = f.sense(other).unwrap();
    assert!(o.bump_rear && !o.bump_front, "{o:?}");
}
