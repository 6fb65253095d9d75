//! The geometry every message shares: points, poses, wheel commands and angles.
//!
//! Units: centimetres and radians, headings counter-clockwise from +x. The one clamp rule for a
//! wheel command ([`WheelCommand::clamped`]) and the one angle wrap ([`wrap_angle`]) live here so
//! that the simulator, every controller and the monitor apply the same rule.

use std::f64::consts::{PI, TAU};

/// A point or vector in the plane, in centimetres.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Vec2 {
    /// x, cm.
    pub x: f64,
    /// y, cm.
    pub y: f64,
}

impl Vec2 {
    /// The origin.
    pub const ZERO: Vec2 = Vec2 { x: 0.0, y: 0.0 };

    /// The vector (x, y).
    pub fn new(x: f64, y: f64) -> Vec2 {
        Vec2 { x, y }
    }

    /// Euclidean length.
    pub fn length(self) -> f64 {
        self.x.hypot(self.y)
    }

    /// Euclidean distance to `other`.
    pub fn distance(self, other: Vec2) -> f64 {
        (self - other).length()
    }

    /// The angle of this vector from +x, in (-pi, pi].
    pub fn angle(self) -> f64 {
        self.y.atan2(self.x)
    }
}

impl std::ops::Add for Vec2 {
    type Output = Vec2;
    fn add(self, o: Vec2) -> Vec2 {
        Vec2::new(self.x + o.x, self.y + o.y)
    }
}

impl std::ops::Sub for Vec2 {
    type Output = Vec2;
    fn sub(self, o: Vec2) -> Vec2 {
        Vec2::new(self.x - o.x, self.y - o.y)
    }
}

impl std::ops::Mul<f64> for Vec2 {
    type Output = Vec2;
    fn mul(self, k: f64) -> Vec2 {
        Vec2::new(self.x * k, self.y * k)
    }
}

/// Where a robot is and which way it faces, in the world frame.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Pose {
    /// x of the robot's centre, cm.
    pub x: f64,
    /// y of the robot's centre, cm.
    pub y: f64,
    /// Heading, radians counter-clockwise from +x.
    pub theta: f64,
}

impl Pose {
    /// The position, without the heading.
    pub fn position(&self) -> Vec2 {
        Vec2::new(self.x, self.y)
    }

    /// A world-frame point seen from this pose (robot frame: x forward, y left).
    pub fn to_local(&self, p: Vec2) -> Vec2 {
        let d = p - self.position();
        let (s, c) = self.theta.sin_cos();
        Vec2::new(c * d.x + s * d.y, -s * d.x + c * d.y)
    }

    /// A robot-frame point in the world frame.
    pub fn to_world(&self, p: Vec2) -> Vec2 {
        let (s, c) = self.theta.sin_cos();
        Vec2::new(self.x + c * p.x - s * p.y, self.y + s * p.x + c * p.y)
    }
}

/// What a robot's controller asks of its tracks for one control step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WheelCommand {
    /// Forward speed as a fraction of full speed, -1 (full reverse) to 1.
    pub forward: f64,
    /// Turn rate as a fraction of the full turn rate, -1 (clockwise) to 1 (counter-clockwise).
    pub turn: f64,
}

impl WheelCommand {
    /// Stand still.
    pub const STOP: WheelCommand = WheelCommand {
        forward: 0.0,
        turn: 0.0,
    };

    /// A command with each component brought into range by [`unit()`].
    pub fn clamped(forward: f64, turn: f64) -> WheelCommand {
        WheelCommand {
            forward: unit(forward),
            turn: unit(turn),
        }
    }
}

/// The clamp rule for a command component: clamped to [-1, 1], NaN as 0 (stand still rather
/// than guess), so an infinite request is full speed in its direction.
pub fn unit(x: f64) -> f64 {
    if x.is_nan() {
        0.0
    } else {
        x.clamp(-1.0, 1.0)
    }
}

/// Wraps an angle into (-pi, pi]; a non-finite angle is 0.
///
/// ```
/// use colony_proto::wrap_angle;
/// assert!((wrap_angle(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
/// assert_eq!(wrap_angle(f64::NAN), 0.0);
/// ```
pub fn wrap_angle(a: f64) -> f64 {
    if !a.is_finite() {
        return 0.0;
    }
    let r = a.rem_euclid(TAU);
    if r > PI {
        r - TAU
    } else {
        r
    }
}

/// Writes a point as an `[x, y]` pair (for `#[serde(serialize_with)]`): the shape a page
/// draws from.
pub(crate) fn point_as_pair<S: serde::Serializer>(p: &Vec2, s: S) -> Result<S::Ok, S::Error> {
    serde::Serialize::serialize(&(p.x, p.y), s)
}

/// Writes points as `[x, y]` pairs, as [`point_as_pair`] writes one.
pub(crate) fn points_as_pairs<S: serde::Serializer>(
    points: &[Vec2],
    s: S,
) -> Result<S::Ok, S::Error> {
    s.collect_seq(points.iter().map(|p| (p.x, p.y)))
}

/// The gains of the go-to-point steering law every controller that drives a robot to a point
/// uses: turn in proportion to the heading error, drive only when roughly facing the point, with
/// the forward speed scaled by the cosine of the error. Each controller keeps its own gains.
///
/// ```
/// use colony_proto::{Pose, Speed, Steer, Vec2};
/// const GENTLE: Steer = Steer {
///     turn_gain: 1.0,
///     align: 0.5,
///     speed: Speed::Ramp { over_cm: 20.0, base: 0.0, min: 0.1 },
/// };
/// let ahead = GENTLE.toward(Pose::default(), Vec2::new(100.0, 0.0));
/// assert_eq!((ahead.forward, ahead.turn), (1.0, 0.0));
/// let behind = GENTLE.toward(Pose::default(), Vec2::new(-100.0, 0.0));
/// assert_eq!((behind.forward, behind.turn), (0.0, 1.0));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Steer {
    /// Turn per radian of heading error; the turn saturates at a full turn either way.
    pub turn_gain: f64,
    /// The robot drives only while its heading error is below this, rad; otherwise it turns on
    /// the spot.
    pub align: f64,
    /// How fast it goes, by its distance from the point.
    pub speed: Speed,
}

/// A [`Steer`]'s forward speed (a fraction of full speed) by the distance to the point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Speed {
    /// Full speed whatever the distance.
    Full,
    /// `d / over_cm + base` at distance `d` cm, kept between `min` and full speed: slower near
    /// the point.
    Ramp {
        /// The distance over which the speed rises by a full speed, cm.
        over_cm: f64,
        /// The speed at the point itself, before `min` applies.
        base: f64,
        /// The least speed, however close.
        min: f64,
    },
}

impl Speed {
    /// The speed at `distance` cm from the point.
    pub fn at(self, distance: f64) -> f64 {
        match self {
            Speed::Full => 1.0,
            Speed::Ramp { over_cm, base, min } => (distance / over_cm + base).clamp(min, 1.0),
        }
    }
}

impl Steer {
    /// The wheels for a heading error of `error` rad (wrapped, counter-clockwise positive) at
    /// `speed` when aligned.
    pub fn wheels(&self, error: f64, speed: f64) -> WheelCommand {
        WheelCommand {
            forward: if error.abs() < self.align {
                speed * error.cos()
            } else {
                0.0
            },
            turn: (self.turn_gain * error).clamp(-1.0, 1.0),
        }
    }

    /// The wheels that take a robot at `me` to `target`.
    pub fn toward(&self, me: Pose, target: Vec2) -> WheelCommand {
        let to = target - me.position();
        let error = wrap_angle(to.angle() - me.theta);
        self.wheels(error, self.speed.at(to.length()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_nan_command_component_stands_still_and_infinity_is_full_speed() {
        let c = WheelCommand::clamped(f64::NAN, f64::NEG_INFINITY);
        assert_eq!(
            c,
            WheelCommand {
                forward: 0.0,
                turn: -1.0
            }
        );
        assert_eq!(WheelCommand::clamped(0.25, 7.0).turn, 1.0);
    }

    #[test]
    fn pi_stays_pi_and_minus_pi_becomes_pi() {
        assert_eq!(wrap_angle(PI), PI);
        assert_eq!(wrap_angle(-PI), PI);
        assert_eq!(wrap_angle(0.0), 0.0);
        assert_eq!(wrap_angle(f64::INFINITY), 0.0);
    }

    #[test]
    fn pose_frames_round_trip() {
        let pose = Pose {
            x: 3.0,
            y: -2.0,
            theta: 0.7,
        };
        let p = Vec2::new(10.0, 4.0);
        let back = pose.to_world(pose.to_local(p));
        assert!(back.distance(p) < 1e-9);
    }

    proptest! {
        #[test]
        fn a_wrapped_angle_is_in_range_and_points_the_same_way(a in -1e6f64..1e6) {
            let w = wrap_angle(a);
            prop_assert!(w > -PI && w <= PI);
            prop_assert!((w.sin() - a.sin()).abs() < 1e-6 && (w.cos() - a.cos()).abs() < 1e-6);
        }

        #[test]
        fn a_clamped_command_is_always_in_range(f in proptest::num::f64::ANY, t in proptest::num::f64::ANY) {
            let c = WheelCommand::clamped(f, t);
            prop_assert!((-1.0..=1.0).contains(&c.forward) && (-1.0..=1.0).contains(&c.turn));
        }
    }
}
