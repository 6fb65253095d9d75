//! Formations that bend with the path and squeeze through narrow places.

use colony_sim::Vec2;

use super::{Formation, Slots};

/// Segments shorter than this (cm) have no direction.
const MIN_SEGMENT_CM: f64 = 1e-9;

/// Sampling step when pulling a slot in, as a fraction of the spacing `d`.
const SQUEEZE_STEPS_PER_D: f64 = 8.0;

/// However far a slot is from the centre, it is sampled at most this many
/// times, so a huge formation cannot stall the caller.
const MAX_SQUEEZE_SAMPLES: f64 = 4096.0;

/// The waypoints that take a squad along a path in formation: `result[i][k]`
/// is where the robot in slot `i` should be when the squad's centre is at
/// `turn_points[k]`.
///
/// At each turn point the formation is centred on the point and faces along
/// the next segment; the last point faces along the final approach. A point
/// with no direction (a single-point path, or only zero-length segments
/// around it) takes the nearest direction after it, else before it, else
/// `start_facing`.
///
/// `is_free` says whether a robot's *centre* may be at a point, so obstacles
/// should already be grown by the robot's radius, as for path finding. A
/// slot is kept only if the straight line from the formation's centre to it
/// is free; otherwise it is pulled in along that line to just before the
/// first blocked point (sampled every `d/8`), so in a narrow passage the
/// formation squeezes instead of sending robots into or through walls. This is
/// stricter than checking the slot alone: a free slot just beyond a thin wall
/// is pulled to this side too. Squeezed robots may end up closer than `d` to
/// each other; the robots' collision reflexes handle that. When the centre
/// itself is blocked a blocked slot is pulled in to the first free point from
/// its end, or falls back to the centre.
///
/// Returns `n` lists (none for `n = 0`) of `turn_points.len()` waypoints; with
/// `d <= 0` every waypoint is the turn point itself.
///
/// # Example
///
/// A line of three turning left at (100, 0), in a world where y < -15 is
/// blocked:
///
/// ```
/// use colony_game::formation::{along_path, Formation};
/// use colony_sim::Vec2;
///
/// let path = [Vec2::new(0.0, 0.0), Vec2::new(100.0, 0.0), Vec2::new(100.0, 100.0)];
/// let waypoints = along_path(&path, Formation::Line, 3, 20.0, 0.0, |p| p.y >= -15.0);
/// // Heading east, slot 2 is on the right (south), pulled in to the free side.
/// assert!(waypoints[2][0].y >= -15.0 && waypoints[2][0].y < 0.0);
/// // Heading north at the corner, the line runs east-west.
/// assert!((waypoints[2][1].x - 120.0).abs() < 1e-9);
/// ```
pub fn along_path(
    turn_points: &[Vec2],
    formation: Formation,
    n: usize,
    d: f64,
    start_facing: f64,
    is_free: impl Fn(Vec2) -> bool,
) -> Vec<Vec<Vec2>> {
    let resolution = if d.is_finite() && d > 0.0 {
        d / SQUEEZE_STEPS_PER_D
    } else {
        0.0
    };
    let mut waypoints: Vec<Vec<Vec2>> = (0..n)
        .map(|_| Vec::with_capacity(turn_points.len()))
        .collect();
    if n == 0 {
        return waypoints;
    }
    for (&centre, facing) in turn_points.iter().zip(facings(turn_points, start_facing)) {
        let slots = formation.slots(centre, facing, n, d);
        for (robot, slot) in waypoints.iter_mut().zip(slots) {
            robot.push(squeeze(centre, slot, resolution, &is_free));
        }
    }
    waypoints
}

/// The facing at each turn point: along the next segment that has a
/// direction, else the last one before, else `start_facing`.
fn facings(points: &[Vec2], start_facing: f64) -> Vec<f64> {
    let segment: Vec<Option<f64>> = points
        .windows(2)
        .map(|w| {
            let v = w[1] - w[0];
            (v.length() > MIN_SEGMENT_CM).then(|| v.angle())
        })
        .collect();
    let mut ahead = vec![None; points.len()];
    for k in (0..segment.len()).rev() {
        ahead[k] = segment[k].or(ahead[k + 1]);
    }
    let mut behind = None;
    let mut out = Vec::with_capacity(points.len());
    for (k, next) in ahead.into_iter().enumerate() {
        if k > 0 {
            behind = segment[k - 1].or(behind);
        }
        out.push(next.or(behind).unwrap_or(start_facing));
    }
    out
}

/// `slot`, or the farthest point towards it from `centre` that is reachable
/// in a straight line through free space.
fn squeeze(centre: Vec2, slot: Vec2, resolution: f64, is_free: &impl Fn(Vec2) -> bool) -> Vec2 {
    let span = slot - centre;
    let length = span.length();
    if !(length > 0.0 && resolution > 0.0) {
        return centre;
    }
    let steps = (length / resolution).ceil().clamp(1.0, MAX_SQUEEZE_SAMPLES) as usize;
    let at = |s: usize| {
        if s == steps {
            slot
        } else {
            centre + span * (s as f64 / steps as f64)
        }
    };
    if is_free(centre) {
        let mut reached = centre;
        for s in 1..=steps {
            let p = at(s);
            if !is_free(p) {
                break;
            }
            reached = p;
        }
        reached
    } else {
        (1..=steps)
            .rev()
            .map(at)
            .find(|&p| is_free(p))
            .unwrap_or(centre)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::FRAC_PI_2;

    fn rotate(v: Vec2, angle: f64) -> Vec2 {
        let (s, c) = angle.sin_cos();
        Vec2::new(c * v.x - s * v.y, s * v.x + c * v.y)
    }

    fn close(a: Vec2, b: Vec2) -> bool {
        a.distance(b) < 1e-9
    }

    #[test]
    fn straight_path_keeps_the_shape() {
        let path = [
            Vec2::new(0.0, 0.0),
            Vec2::new(150.0, 0.0),
            Vec2::new(400.0, 0.0),
        ];
        for f in Formation::ALL {
            let wp = along_path(&path, f, 5, 20.0, 1.0, |_| true);
            assert_eq!(wp.len(), 5);
            for (k, &centre) in path.iter().enumerate() {
                let expected = f.slots(centre, 0.0, 5, 20.0);
                for (i, slot) in expected.iter().enumerate() {
                    assert!(close(wp[i][k], *slot), "{f}: robot {i} at point {k}");
                }
            }
        }
    }

    #[test]
    fn right_angle_turn_rotates_the_shape() {
        let path = [
            Vec2::new(0.0, 0.0),
            Vec2::new(200.0, 0.0),
            Vec2::new(200.0, 200.0),
        ];
        for f in Formation::ALL {
            let wp = along_path(&path, f, 6, 15.0, 0.0, |_| true);
            for robot in &wp {
                let before = robot[0] - path[0];
                let at_corner = robot[1] - path[1];
                let after = robot[2] - path[2];
                assert!(close(rotate(before, FRAC_PI_2), at_corner), "{f}");
                assert!(
                    close(at_corner, after),
                    "{f}: the last point keeps the approach"
                );
            }
        }
    }

    /// A corridor one 10 cm cell wide: east from (0, 0) to (300, 0), then
    /// north to (300, 300).
    fn in_corridor(p: Vec2) -> bool {
        let east = (-5.0..=305.0).contains(&p.x) && p.y.abs() <= 5.0;
        let north = (p.x - 300.0).abs() <= 5.0 && (-5.0..=305.0).contains(&p.y);
        east || north
    }

    #[test]
    fn narrow_corridor_squeezes_every_waypoint_into_free_space() {
        let path = [
            Vec2::new(0.0, 0.0),
            Vec2::new(150.0, 0.0),
            Vec2::new(300.0, 0.0),
            Vec2::new(300.0, 300.0),
        ];
        for f in Formation::ALL {
            for n in [1, 2, 5, 8] {
                let wp = along_path(&path, f, n, 25.0, 0.0, in_corridor);
                for (i, robot) in wp.iter().enumerate() {
                    assert_eq!(robot.len(), path.len());
                    for (k, p) in robot.iter().enumerate() {
                        assert!(
                            in_corridor(*p),
                            "{f} n={n}: robot {i} at point {k} is at {p:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn free_slot_behind_a_thin_wall_is_pulled_to_the_near_side() {
        // Facing north, the line runs east-west; a wall at 17 <= x <= 24
        // cuts the eastern slot (x = 30) off from the centre.
        let wall = |p: Vec2| !(17.0..=24.0).contains(&p.x);
        let wp = along_path(&[Vec2::ZERO], Formation::Line, 3, 30.0, FRAC_PI_2, wall);
        assert!(close(wp[0][0], Vec2::new(-30.0, 0.0)));
        assert!(close(wp[1][0], Vec2::ZERO));
        assert!(wp[2][0].x < 17.0 && wp[2][0].x > 10.0, "{:?}", wp[2][0]);
    }

    #[test]
    fn blocked_centre_keeps_free_slots_and_pulls_blocked_ones_in() {
        // Only the half-plane x <= -10 is free; the centre is not.
        let free = |p: Vec2| p.x <= -10.0;
        let wp = along_path(&[Vec2::ZERO], Formation::Line, 3, 30.0, FRAC_PI_2, free);
        assert!(close(wp[0][0], Vec2::new(-30.0, 0.0)));
        assert!(close(wp[1][0], Vec2::ZERO), "nothing free: the centre");
        assert!(close(wp[2][0], Vec2::ZERO));
    }

    #[test]
    fn single_point_uses_the_start_facing() {
        let wp = along_path(
            &[Vec2::new(5.0, 5.0)],
            Formation::Line,
            2,
            10.0,
            FRAC_PI_2,
            |_| true,
        );
        assert_eq!(
            wp,
            Formation::Line
                .slots(Vec2::new(5.0, 5.0), FRAC_PI_2, 2, 10.0)
                .into_iter()
                .map(|p| vec![p])
                .collect::<Vec<_>>()
        );
    }

    #[test]
    fn repeated_points_take_the_direction_of_the_next_real_segment() {
        let p = Vec2::new(10.0, 0.0);
        let q = Vec2::new(10.0, 10.0);
        let (east, north) = (0.0, FRAC_PI_2);
        assert_eq!(
            facings(&[Vec2::ZERO, Vec2::ZERO, p, p, q, q], 3.0),
            [east, east, north, north, north, north]
        );
        assert_eq!(facings(&[p, p], 3.0), [3.0, 3.0]);
    }

    #[test]
    fn degenerate_inputs_do_not_panic() {
        assert!(along_path(&[Vec2::ZERO], Formation::Wedge, 0, 10.0, 0.0, |_| true).is_empty());
        let empty_path = along_path(&[], Formation::Wedge, 3, 10.0, 0.0, |_| true);
        assert_eq!(empty_path, vec![Vec::<Vec2>::new(); 3]);
        let path = [Vec2::ZERO, Vec2::new(10.0, 0.0)];
        for d in [0.0, -1.0, f64::NAN] {
            let wp = along_path(&path, Formation::Circle, 4, d, 0.0, |_| false);
            assert!(wp.iter().all(|robot| robot == &path));
        }
    }

    proptest! {
        #[test]
        fn waypoints_are_free_wherever_the_path_is(
            f in prop::sample::select(Formation::ALL.to_vec()),
            n in 0usize..10,
            d in 1.0f64..40.0,
            rocks in prop::collection::vec((-200.0f64..200.0, -200.0f64..200.0, 5.0f64..60.0), 0..8),
            path in prop::collection::vec((-200.0f64..200.0, -200.0f64..200.0), 0..6),
        ) {
            let free = |p: Vec2| rocks.iter().all(|&(x, y, r)| p.distance(Vec2::new(x, y)) > r);
            let path: Vec<Vec2> = path.into_iter().map(|(x, y)| Vec2::new(x, y)).filter(|&p| free(p)).collect();
            let wp = along_path(&path, f, n, d, 0.0, free);
            prop_assert_eq!(wp.len(), n);
            for robot in &wp {
                prop_assert_eq!(robot.len(), path.len());
                prop_assert!(robot.iter().all(|&p| free(p)));
            }
        }
    }
}
