//! A robot's shape: the body rectangle and the passive C-shaped gripper.
//!
//! Robot frame: origin at the body rectangle's centre, x forward, y left.
//!
//! ```text
//!            y
//!            ^        shoulder
//!   +--------+--.__
//!   |        |  (  `-.   mouth (130 degrees, about 6.5 cm wide)
//!   |  body  | (  o  )  <- pocket: disc of radius 3.6 centred 3.6 cm ahead of the front
//!   |        |  (  .-'
//!   +--------+--'
//! ```
//!
//! The gripper is an arc of short capsules whose inner surface lies on the pocket's
//! circle, open over the mouth angle at the front, plus two shoulder triangles joining
//! the arc's lips to the body's front corners. A puck (radius 3.15) passes through
//! the mouth when the robot drives over it and is then held: it can only leave
//! through the mouth again, which happens when the robot backs away from it.
//! A "bow" disc filling the pocket collides with walls and robots but not with
//! pucks, so other robots cannot poke into the pocket (as in PuckSwarm).

use crate::config::SceneConfig;
use crate::types::Vec2;

/// Thickness of the gripper's lips, cm.
pub(crate) const ARC_THICKNESS: f64 = 0.5;

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
            bounding_radius: hl.hypot(hw).max(pocket.x + rg),
            outline,
            carry_start_distance: start,
            carry_keep_distance: keep,
        }
    }

    /// The solid parts, robot frame: the body and the gripper's two jaws.
    pub fn parts(&self) -> Vec<Part> {
        let r = self.pocket_radius;
        let m = self.mouth_half_angle;
        let t = ARC_THICKNESS;
        let n: usize = std::env::var("CHORDS")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(2);
        let mut parts = vec![Part::Rectangle {
            half_extents: Vec2::new(self.half_length, self.half_width),
        }];
        let c = self.pocket;
        let pi = std::f64::consts::PI;
        for s in [1.0, -1.0] {
            for k in 0..n {
                let a0 = pi - (pi - m) * k as f64 / n as f64;
                let a1 = pi - (pi - m) * (k + 1) as f64 / n as f64;
                let p0 = c + crate::arena::polar(r, a0);
                let p1 = c + crate::arena::polar(r, a1);
                let q0 = c + crate::arena::polar(r + t, a0);
                let q1 = c + crate::arena::polar(r + t, a1);
                let flip = |p: Vec2| Vec2::new(p.x, s * p.y);
                parts.push(Part::Polygon(vec![flip(p0), flip(p1), flip(q1), flip(q0)]));
            }
            let ro = r + t;
            if self.half_width > ro {
                let lip = c + crate::arena::polar(ro, m);
                parts.push(Part::Polygon(vec![
                    Vec2::new(self.half_length, s * self.half_width),
                    Vec2::new(self.half_length, s * ro),
                    Vec2::new(lip.x, s * lip.y),
                ]));
            }
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
