//! A robot's shape: the body rectangle and the passive C-shaped gripper.
//!
//! Robot frame: origin at the body rectangle's centre, x forward, y left. With the
//! standard values (body 12.5 x 10.8 cm, pocket radius 3.6, mouth 130 degrees):
//!
//! ```text
//!                 y
//!   +---------+   ^  shoulder
//!   |         |\__      lip (x 11.4, y +-3.3)
//!   |         |   ' .
//!   |  body   |  .-.  )   <- pocket: a disc of radius 3.6 centred at (9.85, 0),
//!   |    +----|-( o )-(--> x  its back on the body's front (x 6.25)
//!   |         |  '-'  )   mouth about 6.5 cm wide, 130 degrees seen from the centre
//!   |         | __. '
//!   +---------+/
//! ```
//!
//! The pocket's back is the body's front; its sides run straight along `y = +-3.6`
//! to the pocket centre's x, and then curve inwards along the pocket's circle to the
//! lips, as PuckSwarm's arc does. A puck (radius 3.15) passes through the mouth when
//! the robot drives over it and is then held, turns included: it leaves only
//! through the mouth, which happens when the robot backs away from it. The curved
//! lips matter: with straight jaws a turning robot flings its puck out (a pushed
//! puck coasts a little, and nothing with an inward-facing normal stops it).
//! A "bow" disc filling the pocket collides with walls and robots but not with
//! pucks, so other robots cannot poke into the pocket (as in PuckSwarm).

use crate::arena::polar;
use crate::config::SceneConfig;
use crate::types::Vec2;

/// Thickness of the gripper's lips, cm.
pub(crate) const ARC_THICKNESS: f64 = 0.5;

/// Capsules per lip. One lets a puck work loose after about two and a half full
/// turns on the spot; two hold it however long the robot spins, for 15 % more
/// physics time than one (and 25 % less than a full twelve-piece arc).
pub(crate) const LIP_SEGMENTS: usize = 2;

/// A robot's shape, in the robot frame.
#[derive(Debug, Clone)]
pub(crate) struct RobotGeometry {
    pub half_length: f64,
    pub half_width: f64,
    /// Centre of the gripper's pocket.
    pub pocket: Vec2,
    pub pocket_radius: f64,
    /// Half the mouth's angle, rad.
    pub mouth_half_angle: f64,
    /// A circle round the origin that contains the whole robot.
    pub bounding_radius: f64,
    /// Points on the body rectangle's outline (what other robots' cameras see).
    pub outline: Vec<Vec2>,
    /// Pocket-to-puck centre distances below which a puck starts / keeps being carried.
    pub carry_start_distance: f64,
    pub carry_keep_distance: f64,
}

/// A convex piece of the robot's solid shape.
#[derive(Debug, Clone)]
pub(crate) enum Part {
    Rectangle { half_extents: Vec2 },
    Capsule { a: Vec2, b: Vec2, radius: f64 },
    Polygon(Vec<Vec2>),
}

impl RobotGeometry {
    pub fn new(cfg: &SceneConfig) -> RobotGeometry {
        let hl = cfg.robots.length / 2.0;
        let hw = cfg.robots.width / 2.0;
        let rg = cfg.robots.gripper_radius;
        let pocket = Vec2::new(hl + rg, 0.0);
        let spacing = cfg.camera.obstacle_spacing;
        let mut outline = Vec::new();
        let corners = [
            Vec2::new(hl, -hw),
            Vec2::new(hl, hw),
            Vec2::new(-hl, hw),
            Vec2::new(-hl, -hw),
        ];
        for k in 0..4 {
            let (a, b) = (corners[k], corners[(k + 1) % 4]);
            let n = (a.distance(b) / spacing).ceil().max(1.0) as usize;
            for j in 0..n {
                outline.push(a + (b - a) * (j as f64 / n as f64));
            }
        }
        let rp = cfg.puck_radius();
        let start = distance_for_fraction(rp, rg, cfg.carrying.start_fraction);
        let keep = distance_for_fraction(rp, rg, cfg.carrying.keep_fraction);
        RobotGeometry {
            half_length: hl,
            half_width: hw,
            pocket,
            pocket_radius: rg,
            mouth_half_angle: cfg.robots.gripper_mouth_deg.to_radians() / 2.0,
            bounding_radius: hl.hypot(hw).max(pocket.x + rg + ARC_THICKNESS),
            outline,
            carry_start_distance: start,
            carry_keep_distance: keep,
        }
    }

    /// The solid parts, robot frame: the body and the gripper's two jaws.
    ///
    /// Each jaw is a convex side piece, whose inner face runs straight along
    /// `y = +-r` from the body's front to the pocket centre's x and whose outer face
    /// (the shoulder) runs from the lip back to the body's front corner, plus a lip:
    /// [`LIP_SEGMENTS`] capsules whose inner surface follows the pocket's circle from
    /// 90 degrees to half the mouth angle.
    pub fn parts(&self) -> Vec<Part> {
        let r = self.pocket_radius;
        let m = self.mouth_half_angle;
        let t = ARC_THICKNESS;
        let c = self.pocket;
        let rc = r + t / 2.0;
        let outer = self.half_width.max(r + t);
        let quarter = std::f64::consts::FRAC_PI_2;
        let mut parts = vec![Part::Rectangle {
            half_extents: Vec2::new(self.half_length, self.half_width),
        }];
        for s in [1.0, -1.0] {
            let flip = |p: Vec2| Vec2::new(p.x, s * p.y);
            for j in 0..LIP_SEGMENTS {
                let a0 = quarter - (quarter - m) * j as f64 / LIP_SEGMENTS as f64;
                let a1 = quarter - (quarter - m) * (j + 1) as f64 / LIP_SEGMENTS as f64;
                parts.push(Part::Capsule {
                    a: flip(c + polar(rc, a0)),
                    b: flip(c + polar(rc, a1)),
                    radius: t / 2.0,
                });
            }
            parts.push(Part::Polygon(vec![
                flip(Vec2::new(self.half_length, r)),
                flip(Vec2::new(c.x, r)),
                flip(c + polar(r + t, m)),
                flip(Vec2::new(self.half_length, outer)),
            ]));
        }
        parts
    }
}

/// Area of the intersection of two discs of radii `r1`, `r2` whose centres are `d` apart.
pub(crate) fn lens_area(r1: f64, r2: f64, d: f64) -> f64 {
    use std::f64::consts::PI;
    if d >= r1 + r2 {
        return 0.0;
    }
    if d <= (r1 - r2).abs() {
        let r = r1.min(r2);
        return PI * r * r;
    }
    let a1 = libm::acos(((d * d + r1 * r1 - r2 * r2) / (2.0 * d * r1)).clamp(-1.0, 1.0));
    let a2 = libm::acos(((d * d + r2 * r2 - r1 * r1) / (2.0 * d * r2)).clamp(-1.0, 1.0));
    let k = (-d + r1 + r2) * (d + r1 - r2) * (d - r1 + r2) * (d + r1 + r2);
    r1 * r1 * a1 + r2 * r2 * a2 - 0.5 * k.max(0.0).sqrt()
}

/// The share of the gripper's disc (radius `rg`) a puck (radius `rp`) covers at distance `d`.
pub(crate) fn covered_fraction(rp: f64, rg: f64, d: f64) -> f64 {
    lens_area(rp, rg, d) / (std::f64::consts::PI * rg * rg)
}

/// The centre distance at which a puck covers `fraction` of the gripper (the
/// covered fraction falls as the distance grows); found by bisection.
pub(crate) fn distance_for_fraction(rp: f64, rg: f64, fraction: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, rp + rg);
    for _ in 0..60 {
        let mid = (lo + hi) / 2.0;
        if covered_fraction(rp, rg, mid) > fraction {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (lo + hi) / 2.0
}
