//! What a field robot's sensors report (the game paper's Table 1: bumpers, sonar,
//! infrared border detector; the pose stands for the overhead tracker).
//!
//! Computed from the geometry in `f64` rather than from rapier's contact lists and
//! ray casts: the result then depends only on the poses the field reports (rapier's
//! broad phase lags a step behind them), and a sensor reads the same before the
//! first step as after. Water is an obstacle to every sensor of a land robot and
//! to none of an amphibian's. Inactive robots are seen by no one.

use super::geom::{ray_disc, unit, Obb};
use super::map::{Terrain, TileMap};
use super::place::box_obb;
use super::{Field, FieldRobotId};
use crate::types::{Pose, Vec2};

/// One robot's sensor readings after a step. Bearings are in the robot frame:
/// radians counter-clockwise from the heading, in [-pi, pi].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FieldSense {
    /// Exact pose, world frame (the overhead tracker).
    pub pose: Pose,
    /// A touch sensor on the front half (bearings from -90 to 90 degrees) is
    /// pressed: something that stops this robot is within `bumper_margin` of it.
    pub bump_front: bool,
    /// A touch sensor on the rear half is pressed.
    pub bump_rear: bool,
    /// Bearing of the nearest contact, when a bumper is pressed.
    pub contact_bearing: Option<f64>,
    /// The nearest echo within the sonar's range and cone.
    pub sonar: Option<SonarEcho>,
    /// The border detector sees, `border_lookahead` ahead of the front edge, ground
    /// this robot cannot enter: off the map, blocked, or water for a land robot.
    pub border_ahead: bool,
}

/// A sonar echo.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SonarEcho {
    /// From the robot's edge to the obstacle along the ray that met it, cm (0 when touching).
    pub distance: f64,
    /// Bearing of that ray (one of `sonar_rays` spread evenly across the cone).
    pub bearing: f64,
}

impl Field {
    /// What robot `id`'s sensors report now, or `None` for an unknown or inactive
    /// robot (switched off, it senses nothing).
    ///
    /// Bumpers and sonar react to walls (blocked cells and the map's edge), other
    /// active robots, boxes and, for a land robot, water. The sonar casts
    /// `sonar_rays` rays from the robot's centre across ±`sonar_half_angle` and
    /// reports the shortest, less the robot's radius.
    pub fn sense(&self, id: FieldRobotId) -> Option<FieldSense> {
        let me = self.robots.get(id.0).filter(|r| r.active)?;
        let pose = me.pose;
        let c = pose.position();
        let r = me.spec.radius;
        let heading = unit(pose.theta);
        let amphibious = me.spec.amphibious;
        let stops = |t: Terrain| match t {
            Terrain::Open => false,
            Terrain::Blocked => true,
            Terrain::Water => !amphibious,
        };
        let cfg = &self.config;

        // Bumpers: everything within `margin` of the disc.
        let margin = cfg.bumper_margin;
        let mut out = FieldSense {
            pose,
            ..FieldSense::default()
        };
        let mut nearest = f64::INFINITY;
        let mut touch = |gap: f64, toward: Vec2| {
            if gap > margin {
                return;
            }
            let bearing = bearing_of(heading, toward);
            if bearing.abs() <= std::f64::consts::FRAC_PI_2 {
                out.bump_front = true;
            } else {
                out.bump_rear = true;
            }
            if gap < nearest {
                nearest = gap;
                out.contact_bearing = Some(bearing);
            }
        };
        let map = &self.map;
        let cell = map.cell_cm();
        let reach = r + margin;
        let (w, h) = (map.width() as i64, map.height() as i64);
        // Cells round the map stand for everything beyond its edge.
        let span = |lo: f64, hi: f64, n: i64| {
            let a = ((lo / cell).floor() as i64).clamp(-1, n);
            let b = ((hi / cell).floor() as i64).clamp(-1, n);
            a..=b
        };
        for j in span(c.y - reach, c.y + reach, h) {
            for i in span(c.x - reach, c.x + reach, w) {
                if stops(map.terrain_ij(i, j)) {
                    let q = Vec2::new(
                        c.x.clamp(i as f64 * cell, (i + 1) as f64 * cell),
                        c.y.clamp(j as f64 * cell, (j + 1) as f64 * cell),
                    );
                    touch(q.distance(c) - r, q - c);
                }
            }
        }
        let range = cfg.sonar_range;
        let max_t = r + range;
        let near = self.robots_near(c, reach.max(max_t), id.0);
        for &k in &near {
            let other = &self.robots[k];
            let d = other.pose.position() - c;
            touch(d.length() - r - other.spec.radius, d);
        }
        for b in &self.boxes {
            let q = box_obb(&b.spec, b.pose).closest_point(c);
            touch(q.distance(c) - r, q - c);
        }

        // Sonar.
        let robots: Vec<(Vec2, f64)> = near
            .iter()
            .map(|&k| &self.robots[k])
            .filter(|o| o.pose.position().distance(c) <= max_t + o.spec.radius)
            .map(|o| (o.pose.position(), o.spec.radius))
            .collect();
        let boxes: Vec<Obb> = self
            .boxes
            .iter()
            .filter(|b| {
                let diag = b.spec.half_length.hypot(b.spec.half_width);
                b.pose.position().distance(c) <= max_t + diag
            })
            .map(|b| box_obb(&b.spec, b.pose))
            .collect();
        let n = cfg.sonar_rays.max(1);
        for k in 0..n {
            let phi = if n == 1 {
                0.0
            } else {
                cfg.sonar_half_angle * (2.0 * k as f64 / (n - 1) as f64 - 1.0)
            };
            let dir = unit(pose.theta + phi);
            let mut t = march(map, c, dir, max_t, stops).unwrap_or(f64::INFINITY);
            for &(centre, radius) in &robots {
                if let Some(u) = ray_disc(c, dir, centre, radius) {
                    t = t.min(u);
                }
            }
            for b in &boxes {
                if let Some(u) = b.ray_hit(c, dir) {
                    t = t.min(u);
                }
            }
            if t <= max_t {
                let distance = (t - r).max(0.0);
                if out.sonar.is_none_or(|e| distance < e.distance) {
                    out.sonar = Some(SonarEcho {
                        distance,
                        bearing: phi,
                    });
                }
            }
        }

        // Border detector.
        let ahead = c + heading * (r + cfg.border_lookahead);
        out.border_ahead = stops(map.terrain_at(ahead));
        Some(out)
    }
}

/// The robot-frame bearing of a world-frame direction, for a robot facing `heading`.
fn bearing_of(heading: Vec2, toward: Vec2) -> f64 {
    if toward.x == 0.0 && toward.y == 0.0 {
        // The centre itself is inside the obstacle: call it straight ahead.
        return 0.0;
    }
    let along = heading.x * toward.x + heading.y * toward.y;
    let left = heading.x * toward.y - heading.y * toward.x;
    libm::atan2(left, along)
}

/// Walks the cells a ray from `origin` along unit `dir` crosses (Amanatides and
/// Woo) and returns the distance at which it enters the first cell that `stops`
/// (0 if it starts in one), or `None` within `max_t`. Off the map counts as
/// blocked, so the walk never leaves the map.
fn march(
    map: &TileMap,
    origin: Vec2,
    dir: Vec2,
    max_t: f64,
    stops: impl Fn(Terrain) -> bool,
) -> Option<f64> {
    let cell = map.cell_cm();
    let mut i = (origin.x / cell).floor() as i64;
    let mut j = (origin.y / cell).floor() as i64;
    if stops(map.terrain_ij(i, j)) {
        return Some(0.0);
    }
    let axis = |o: f64, d: f64, k: i64| -> (i64, f64, f64) {
        if d > 0.0 {
            (1, ((k + 1) as f64 * cell - o) / d, cell / d)
        } else if d < 0.0 {
            (-1, (k as f64 * cell - o) / d, -cell / d)
        } else {
            (0, f64::INFINITY, f64::INFINITY)
        }
    };
    let (si, mut tx, dx) = axis(origin.x, dir.x, i);
    let (sj, mut ty, dy) = axis(origin.y, dir.y, j);
    // A ray leaves the map after crossing at most width + height cells.
    let limit = (map.width() + map.height() + 4) as u64;
    for _ in 0..limit {
        let t = tx.min(ty);
        if t.is_nan() || t > max_t {
            return None;
        }
        if tx < ty {
            i += si;
            tx += dx;
        } else {
            j += sj;
            ty += dy;
        }
        if stops(map.terrain_ij(i, j)) {
            return Some(t);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_march_stops_at_the_first_stopping_cell() {
        // 10 x 1 cells of 10 cm; a wall at column 6.
        let map = TileMap::from_fn(10, 1, 10.0, |x, _| {
            if x == 6 {
                Terrain::Blocked
            } else {
                Terrain::Open
            }
        })
        .unwrap();
        let blocked = |t: Terrain| t == Terrain::Blocked;
        let o = Vec2::new(15.0, 5.0);
        assert_eq!(
            march(&map, o, Vec2::new(1.0, 0.0), 100.0, blocked),
            Some(45.0)
        );
        assert_eq!(march(&map, o, Vec2::new(1.0, 0.0), 40.0, blocked), None);
        // Backwards it meets the map's edge.
        assert_eq!(
            march(&map, o, Vec2::new(-1.0, 0.0), 100.0, blocked),
            Some(15.0)
        );
        // Diagonally it leaves the single row at y = 10.
        let d = unit(std::f64::consts::FRAC_PI_4);
        let t = march(&map, o, d, 100.0, blocked).unwrap();
        assert!((t - 5.0 * 2f64.sqrt()).abs() < 1e-9, "{t}");
        assert_eq!(
            march(&map, Vec2::new(65.0, 5.0), d, 100.0, blocked),
            Some(0.0)
        );
    }

    #[test]
    fn bearings_are_counter_clockwise_from_the_heading() {
        let h = Vec2::new(0.0, 1.0);
        assert_eq!(bearing_of(h, Vec2::new(0.0, 3.0)), 0.0);
        assert!((bearing_of(h, Vec2::new(-1.0, 0.0)) - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((bearing_of(h, Vec2::new(0.0, -1.0)).abs() - std::f64::consts::PI).abs() < 1e-12);
    }
}
