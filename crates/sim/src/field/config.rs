//! What a field, its robots and its boxes are made of, with the checks that keep
//! the physics and the sensors finite.

use serde::{Deserialize, Serialize};

use crate::error::SimError;

/// Time stepping, sensor geometry and material constants of a [`super::Field`].
///
/// Every field has a default, so an empty TOML table is a usable field:
///
/// ```
/// let cfg: colony_sim::field::FieldConfig = toml::from_str("sonar_range = 80.0").unwrap();
/// assert_eq!(cfg.sonar_range, 80.0);
/// assert_eq!(cfg.substeps, 2);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FieldConfig {
    /// Length of a control step, s: how long one set of commands acts (default 0.1).
    pub control_step: f64,
    /// Physics steps per control step (default 2). More give stiffer contacts at
    /// higher speeds, at proportional cost.
    pub substeps: u32,
    /// Farthest the sonar reports an echo, cm from the robot's edge (default 60).
    pub sonar_range: f64,
    /// Half the sonar's cone, rad, either side of the heading (default 15 degrees).
    pub sonar_half_angle: f64,
    /// Rays cast evenly across the sonar's cone (default 9; with 1, just the heading).
    /// Nine across 30 degrees leave gaps under 5 cm at 60 cm, narrower than a robot.
    pub sonar_rays: u32,
    /// Gap, cm, under which a bumper counts as pressed (default 0.2): the contact
    /// solver leaves bodies resting this close rather than exactly touching.
    pub bumper_margin: f64,
    /// How far ahead of the robot's front edge the infrared border sensor looks at
    /// the ground, cm (default 5, about a small robot's radius).
    pub border_lookahead: f64,
    /// Robots' mass per unit of footprint, g/cm² (default 2.5, an SRV-1's). Only
    /// its ratio to box masses matters: it sets how much a pushed box slows a robot.
    pub robot_density: f64,
    /// Coulomb friction between bodies and against walls (default 0.3): low, so a
    /// robot sliding along a wall or a box sliding along a robot does not stick.
    pub friction: f64,
}

impl Default for FieldConfig {
    fn default() -> Self {
        FieldConfig {
            control_step: 0.1,
            substeps: 2,
            sonar_range: 60.0,
            sonar_half_angle: 15f64.to_radians(),
            sonar_rays: 9,
            bumper_margin: 0.2,
            border_lookahead: 5.0,
            robot_density: 2.5,
            friction: 0.3,
        }
    }
}

impl FieldConfig {
    /// Checks every value; the error names the field and the limit.
    pub fn validate(&self) -> Result<(), SimError> {
        in_range("field.control_step", self.control_step, 1e-4, 10.0)?;
        if !(1..=1000).contains(&self.substeps) {
            return Err(SimError::invalid(
                "field.substeps",
                format!("{} is not between 1 and 1000", self.substeps),
            ));
        }
        in_range("field.sonar_range", self.sonar_range, 0.0, 1e5)?;
        in_range(
            "field.sonar_half_angle",
            self.sonar_half_angle,
            0.0,
            std::f64::consts::PI,
        )?;
        if !(1..=256).contains(&self.sonar_rays) {
            return Err(SimError::invalid(
                "field.sonar_rays",
                format!("{} is not between 1 and 256", self.sonar_rays),
            ));
        }
        in_range("field.bumper_margin", self.bumper_margin, 0.0, 100.0)?;
        in_range("field.border_lookahead", self.border_lookahead, 0.0, 1e5)?;
        positive("field.robot_density", self.robot_density)?;
        in_range("field.friction", self.friction, 0.0, 100.0)?;
        Ok(())
    }

    /// Length of one physics step, s.
    pub fn physics_dt(&self) -> f64 {
        self.control_step / self.substeps.max(1) as f64
    }
}

/// A robot of the field: a disc driven like a tracked vehicle.
///
/// Each physics step sets its velocity to `forward · max_speed` along its heading
/// (nothing sideways: tracks do not slide) and its turn rate to `turn · max_turn`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RobotSpec {
    /// Radius of its footprint, cm.
    pub radius: f64,
    /// Speed at `forward = 1`, cm/s.
    pub max_speed: f64,
    /// Turn rate at `turn = 1`, rad/s.
    pub max_turn: f64,
    /// Crosses water; land robots are stopped at its edge.
    pub amphibious: bool,
}

impl RobotSpec {
    pub(crate) fn validate(&self) -> Result<(), SimError> {
        in_range("robot.radius", self.radius, 1e-3, 1e4)?;
        in_range("robot.max_speed", self.max_speed, 0.0, 1e5)?;
        in_range("robot.max_turn", self.max_turn, 0.0, 1e4)?;
        Ok(())
    }
}

/// A box to be pushed: a rectangle sliding on the floor.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BoxSpec {
    /// Half its length along its own x axis (the pose's heading), cm.
    pub half_length: f64,
    /// Half its width, cm.
    pub half_width: f64,
    /// Mass, g.
    pub mass: f64,
    /// Floor friction as damping, 1/s: a box left sliding loses speed as
    /// `exp(-damping · t)`, whatever the step length. 0 slides for ever.
    pub damping: f64,
}

impl BoxSpec {
    pub(crate) fn validate(&self) -> Result<(), SimError> {
        in_range("box.half_length", self.half_length, 1e-3, 1e5)?;
        in_range("box.half_width", self.half_width, 1e-3, 1e5)?;
        in_range("box.mass", self.mass, 1e-6, 1e9)?;
        in_range("box.damping", self.damping, 0.0, 1e4)?;
        Ok(())
    }
}

fn in_range(field: &str, value: f64, lo: f64, hi: f64) -> Result<(), SimError> {
    if value >= lo && value <= hi {
        Ok(())
    } else {
        Err(SimError::invalid(
            field,
            format!("{value} is not between {lo} and {hi}"),
        ))
    }
}

fn positive(field: &str, value: f64) -> Result<(), SimError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(SimError::invalid(
            field,
            format!("{value} is not a positive number"),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_configuration_is_valid() {
        FieldConfig::default().validate().unwrap();
        assert!((FieldConfig::default().physics_dt() - 0.05).abs() < 1e-12);
    }

    #[test]
    fn bad_values_name_their_field() {
        let bad = [
            FieldConfig {
                control_step: 0.0,
                ..Default::default()
            },
            FieldConfig {
                substeps: 0,
                ..Default::default()
            },
            FieldConfig {
                sonar_range: f64::NAN,
                ..Default::default()
            },
            FieldConfig {
                sonar_rays: 0,
                ..Default::default()
            },
            FieldConfig {
                robot_density: f64::INFINITY,
                ..Default::default()
            },
        ];
        let fields = [
            "field.control_step",
            "field.substeps",
            "field.sonar_range",
            "field.sonar_rays",
            "field.robot_density",
        ];
        for (cfg, field) in bad.iter().zip(fields) {
            let e = cfg.validate().unwrap_err().to_string();
            assert!(e.contains(field), "{e}");
        }
        let spec = RobotSpec {
            radius: -1.0,
            max_speed: 10.0,
            max_turn: 1.0,
            amphibious: false,
        };
        assert!(spec
            .validate()
            .unwrap_err()
            .to_string()
            .contains("robot.radius"));
        let b = BoxSpec {
            half_length: 5.0,
            half_width: 5.0,
            mass: 0.0,
            damping: 1.0,
        };
        assert!(b.validate().unwrap_err().to_string().contains("box.mass"));
    }
}
