//! VFH+ obstacle avoidance (Ulrich and Borenstein 1998) over obstacle points
//! in the robot frame, and the steering law that turns a direction into a
//! [`WheelCommand`].
//!
//! The stages are pure functions over a polar histogram of `sectors` sectors
//! spanning [-half_range, +half_range] (sector 0 is the right-most):
//! [`primary_histogram`] (cell magnitude `1 - d^2 / zero^2`, a sector takes
//! the maximum, obstacles enlarged by `asin(r / d)`), [`binary_histogram`]
//! (hysteresis between `tau_low` and `tau_high`), [`turning_limits`] and
//! [`masked_histogram`] (directions behind an obstacle inside a turning
//! circle are blocked), [`candidate_sectors`] (narrow and wide openings) and
//! [`choose_direction`] (the three-weight cost). [`Vfh`] keeps the two things
//! that persist between steps: the binary histogram and the previous choice.
//!
//! ```
//! use colony_sim::Vec2;
//! use colony_sort::params::SortParams;
//! use colony_sort::vfh::{Obstacle, Vfh};
//! let p = SortParams::default();
//! let mut vfh = Vfh::new(&p.vfh, &p.robot);
//! assert_eq!(vfh.direction(&[], 0.0), Some(0.0)); // nothing in the way
//! let wall: Vec<Obstacle> = (-6..=6).map(|i| Obstacle::point(Vec2::new(22.0, i as f64))).collect();
//! let d = vfh.direction(&wall, 0.0).unwrap();
//! assert!(d.abs() > 0.3); // steers around it
//! ```

use std::f64::consts::PI;

use colony_proto::wrap_angle;
use colony_sim::{Vec2, WheelCommand};

use crate::params::{RobotParams, SteeringParams, VfhParams};

/// Something to avoid, in the robot frame (x forward, y left, cm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Obstacle {
    /// Its position (robot frame, cm).
    pub pos: Vec2,
    /// 0 for an occupancy point (wall, robot body), the puck radius for a puck.
    pub radius: f64,
}

impl Obstacle {
    /// An obstacle point with no extent.
    pub fn point(pos: Vec2) -> Obstacle {
        Obstacle { pos, radius: 0.0 }
    }
}

fn half_range(p: &VfhParams) -> f64 {
    p.half_range_deg.to_radians()
}

fn sector_width(p: &VfhParams) -> f64 {
    2.0 * half_range(p) / (p.sectors.max(2) - 1) as f64
}

/// The direction (radians, robot frame) at the centre of sector `k`.
pub fn sector_angle(p: &VfhParams, k: usize) -> f64 {
    -half_range(p) + k as f64 * sector_width(p)
}

/// The sector whose centre is nearest `angle` (clamped into the histogram's range).
pub fn nearest_sector(p: &VfhParams, angle: f64) -> usize {
    let h = half_range(p);
    let a = if angle.is_finite() {
        angle.clamp(-h, h)
    } else {
        0.0
    };
    let k = ((a + h) / sector_width(p)).round();
    (k.max(0.0) as usize).min(p.sectors.saturating_sub(1))
}

/// Stage 1: each sector holds the largest magnitude of the (enlarged)
/// obstacles covering it. Distances and angles are taken from the camera
/// (`robot.camera_x_cm` ahead of the centre), the origin of the authors' map.
pub fn primary_histogram(p: &VfhParams, robot: &RobotParams, obstacles: &[Obstacle]) -> Vec<f64> {
    let mut h = vec![0.0; p.sectors];
    let half = half_range(p);
    let w = sector_width(p);
    let zero2 = p.magnitude_zero_cm * p.magnitude_zero_cm;
    for o in obstacles {
        let rel = o.pos - Vec2::new(robot.camera_x_cm, 0.0);
        let d = rel.length();
        if !d.is_finite() {
            continue;
        }
        let edge = (d - o.radius.max(0.0)).max(0.0);
        let magnitude = 1.0 - edge * edge / zero2;
        if magnitude <= 0.0 {
            continue;
        }
        let beta = rel.angle();
        let reach = o.radius.max(0.0) + p.enlargement_cm;
        let gamma = if d <= reach {
            PI / 2.0
        } else {
            (reach / d).asin()
        };
        let lo = ((beta - gamma + half) / w).ceil().max(0.0);
        let hi = ((beta + gamma + half) / w)
            .floor()
            .min(p.sectors.saturating_sub(1) as f64);
        let mut mark = |k: usize| h[k] = f64::max(h[k], magnitude);
        if lo <= hi {
            for k in lo as usize..=hi as usize {
                mark(k);
            }
        } else if beta.abs() <= half {
            mark(nearest_sector(p, beta));
        }
    }
    h
}

/// Stage 2: blocked above `tau_high`, free below `tau_low`, otherwise as
/// `previous` was (free if `previous` is too short).
pub fn binary_histogram(p: &VfhParams, primary: &[f64], previous: &[bool]) -> Vec<bool> {
    primary
        .iter()
        .enumerate()
        .map(|(k, &m)| {
            if m > p.tau_high {
                true
            } else if m < p.tau_low {
                false
            } else {
                previous.get(k).copied().unwrap_or(false)
            }
        })
        .collect()
}

/// Stage 3a: the right and left limit angles (right <= 0 <= left). An
/// obstacle on the left (right) inside the left (right) turning circle,
/// enlarged by the safety margin, blocks every direction beyond it.
pub fn turning_limits(p: &VfhParams, robot: &RobotParams, obstacles: &[Obstacle]) -> (f64, f64) {
    let half = half_range(p);
    let (mut right, mut left) = (-half, half);
    let r = robot.turning_radius_cm;
    let reach = r + p.safety_margin_cm;
    let left_centre = Vec2::new(robot.turning_centre_x_cm, r);
    let right_centre = Vec2::new(robot.turning_centre_x_cm, -r);
    for o in obstacles {
        let beta = (o.pos - Vec2::new(robot.camera_x_cm, 0.0)).angle();
        let radius = o.radius.max(0.0);
        if beta > 0.0 && beta < left && o.pos.distance(left_centre) - radius < reach {
            left = beta;
        }
        if beta < 0.0 && beta > right && o.pos.distance(right_centre) - radius < reach {
            right = beta;
        }
    }
    (right, left)
}

/// Stage 3b: blocked where the binary histogram is, and beyond the limits.
pub fn masked_histogram(p: &VfhParams, binary: &[bool], limits: (f64, f64)) -> Vec<bool> {
    let (right, left) = limits;
    binary
        .iter()
        .enumerate()
        .map(|(k, &b)| {
            let a = sector_angle(p, k);
            b || a > left || a < right
        })
        .collect()
}

/// Stage 4: candidate sectors. A narrow opening (fewer than `s_max` free
/// sectors) offers its centre; a wide one offers the sectors `s_max / 2`
/// inside each border, and the target sector if it lies within.
pub fn candidate_sectors(p: &VfhParams, masked: &[bool], target_sector: usize) -> Vec<usize> {
    let mut out = Vec::new();
    let mut k = 0;
    while k < masked.len() {
        if masked[k] {
            k += 1;
            continue;
        }
        let lo = k;
        while k < masked.len() && !masked[k] {
            k += 1;
        }
        let hi = k - 1;
        if hi - lo + 1 < p.s_max {
            out.push((lo + hi) / 2);
        } else {
            out.push(lo + p.s_max / 2);
            out.push(hi - p.s_max / 2);
            if (lo..=hi).contains(&target_sector) {
                out.push(target_sector);
            }
        }
    }
    out
}

/// Stage 5: the candidate of least cost
/// `mu_target |c - target| + mu_heading |c| + mu_previous |c - previous|`,
/// or `None` when every sector is blocked.
pub fn choose_direction(p: &VfhParams, masked: &[bool], target: f64, previous: f64) -> Option<f64> {
    let target = if target.is_finite() { target } else { 0.0 };
    let previous = if previous.is_finite() { previous } else { 0.0 };
    let mut best: Option<(f64, f64)> = None;
    for k in candidate_sectors(p, masked, nearest_sector(p, target)) {
        let a = sector_angle(p, k);
        let cost = p.mu_target * wrap_angle(a - target).abs()
            + p.mu_heading * a.abs()
            + p.mu_previous * wrap_angle(a - previous).abs();
        if best.is_none_or(|(c, _)| cost < c) {
            best = Some((cost, a));
        }
    }
    best.map(|(_, a)| a)
}

/// VFH+ with the state it keeps between steps.
#[derive(Debug, Clone)]
pub struct Vfh {
    params: VfhParams,
    robot: RobotParams,
    binary: Vec<bool>,
    previous: f64,
}

impl Vfh {
    /// A VFH+ with no history: nothing blocked, previous direction straight ahead.
    pub fn new(params: &VfhParams, robot: &RobotParams) -> Vfh {
        Vfh {
            params: params.clone(),
            robot: robot.clone(),
            binary: vec![false; params.sectors],
            previous: 0.0,
        }
    }

    /// The direction to drive (radians, robot frame, 0 = straight ahead)
    /// toward `target` around `obstacles`, or `None` when boxed in.
    pub fn direction(&mut self, obstacles: &[Obstacle], target: f64) -> Option<f64> {
        let p = &self.params;
        let primary = primary_histogram(p, &self.robot, obstacles);
        self.binary = binary_histogram(p, &primary, &self.binary);
        let limits = turning_limits(p, &self.robot, obstacles);
        let masked = masked_histogram(p, &self.binary, limits);
        let choice = choose_direction(p, &masked, target, self.previous);
        if let Some(a) = choice {
            self.previous = a;
        }
        choice
    }

    /// The binary histogram kept from the last call (true = blocked).
    pub fn binary(&self) -> &[bool] {
        &self.binary
    }

    /// The last direction chosen (0 before any).
    pub fn previous(&self) -> f64 {
        self.previous
    }

    /// Forgets the hysteresis and the previous choice.
    pub fn reset(&mut self) {
        self.binary.iter_mut().for_each(|b| *b = false);
        self.previous = 0.0;
    }
}

/// The steering law: turn = sat(theta / full_turn_angle, -1, 1), forward =
/// sat((slow_angle - |theta|) / slow_angle, min_forward, 1).
pub fn steer_toward(theta: f64, s: &SteeringParams) -> WheelCommand {
    let theta = if theta.is_finite() { theta } else { 0.0 };
    let full = s.full_turn_angle_deg.to_radians();
    let slow = s.slow_angle_deg.to_radians();
    WheelCommand {
        forward: ((slow - theta.abs()) / slow).clamp(s.min_forward, 1.0),
        turn: (theta / full).clamp(-1.0, 1.0),
    }
}

/// [`steer_toward`] a VFH+ direction, or, when VFH+ is blocked, a hard turn
/// toward `freer_side` (+1 left, -1 right) at `blocked_forward` speed.
pub fn steer(direction: Option<f64>, freer_side: f64, s: &SteeringParams) -> WheelCommand {
    match direction {
        Some(theta) => steer_toward(theta, s),
        None => WheelCommand {
            forward: s.blocked_forward,
            turn: if freer_side < 0.0 { -1.0 } else { 1.0 },
        },
    }
}
