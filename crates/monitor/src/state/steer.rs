//! The steering law for a held robot the operator sent to a point.

use colony_proto::{Pose, Speed, Steer, Vec2, WheelCommand};

/// A robot steered to a point stops this close to it (cm).
pub const ARRIVED_CM: f64 = 3.0;

/// The gains for a robot the operator sent to a point.
const OPERATOR: Steer = Steer {
    turn_gain: 1.2,
    align: 0.6,
    speed: Speed::Ramp {
        over_cm: 15.0,
        base: 0.0,
        min: 0.15,
    },
};

/// Turns toward `target` in proportion to the heading error, drives only when roughly aligned
/// (slowing near the point and for the remaining error), and stops within [`ARRIVED_CM`] or
/// when the pose or the point is not a number. `turn` > 0 is counter-clockwise.
pub fn steer(pose: Pose, target: Vec2) -> WheelCommand {
    let dist = (target - pose.position()).length();
    if !dist.is_finite() || !pose.theta.is_finite() || dist < ARRIVED_CM {
        return WheelCommand::STOP;
    }
    OPERATOR.toward(pose, target)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(theta: f64) -> Pose {
        Pose {
            x: 0.0,
            y: 0.0,
            theta,
        }
    }

    #[test]
    fn the_steering_law_turns_first_then_drives_and_stops_at_the_point() {
        // Straight ahead, far: full speed, no turn.
        let c = steer(at(0.0), Vec2::new(100.0, 0.0));
        assert!((c.forward - 1.0).abs() < 1e-9 && c.turn.abs() < 1e-9);
        // Behind and to the left: turn counter-clockwise on the spot.
        let c = steer(at(0.0), Vec2::new(-10.0, 1.0));
        assert_eq!((c.forward, c.turn), (0.0, 1.0));
        // To the right: turn clockwise.
        assert_eq!(steer(at(0.0), Vec2::new(0.0, -50.0)).turn, -1.0);
        // Angles wrap: heading pi, target at -x is straight ahead.
        let c = steer(at(std::f64::consts::PI), Vec2::new(-50.0, 0.0));
        assert!(c.forward > 0.9 && c.turn.abs() < 1e-9);
        // Close: slow; arrived: stop.
        let c = steer(at(0.0), Vec2::new(4.0, 0.0));
        assert!(c.forward > 0.0 && c.forward < 0.5);
        assert_eq!(steer(at(0.0), Vec2::new(2.0, 1.0)), WheelCommand::STOP);
        assert_eq!(
            steer(at(f64::NAN), Vec2::new(20.0, 1.0)),
            WheelCommand::STOP
        );
    }
}
