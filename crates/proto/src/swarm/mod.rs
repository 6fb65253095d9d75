//! The swarm channels: what the sorting world, its robots' controllers and the monitor say to
//! each other.
//!
//! | channel | module | what it carries | written by | read by |
//! |---|---|---|---|---|
//! | `camera.N` | [`camera`] | robot N's [`Observation`] | the world | robot N's controller |
//! | `radio` | [`crate::radio`] | wheel commands | controllers, the monitor | the world |
//! | `debug` | [`debug`] | each controller's [`Intentions`] | controllers | the monitor |
//! | `vision` | [`vision`] | the whole world, in parts ([`VisionFrame`]) | the world | the monitor |
//! | `metrics` | [`metrics`] | sorting [`Progress`] | the world | the monitor |
//!
//! ```text
//! @ <camera.2> 0                       what robot 2's sensors report
//! step n 1200
//! pose x 12.5 y -40.1 theta 1.57
//! gripper kind 0 x 8.1 y 0.0
//! puck kind 1 x 20.3 y -4.0 held 0
//! robot x 30.0 y 10.0
//! obstacle x 35.0 y -12.0
//!
//! @ <debug> 0                          what robot 2 intends (for the monitor)
//! robot id 2 state "HOMING" tx 40.0 ty 20.0
//! cache id 2 kind 0 x 40.0 y 20.0
//!
//! @ <vision> 20                        the whole world (split into parts for big swarms)
//! step n 1200 part 0 parts 1
//! arena width 187 height 187 corner 15  (first part only: the walls and body sizes, cm)
//! sizes robot_length 12.5 robot_width 10.8 gripper_radius 3.6 puck_diameter 6.3
//! robot id 0 x 12.5 y -40.1 theta 1.57 carrying 7
//! puck id 7 kind 0 x 20.0 y -38.0
//!
//! @ <metrics> 0                        sorting progress
//! sort step 1200 pc 87.5
//! ```
//!
//! # One rule for every field
//!
//! Every decoder here reads fields by the same rules, written once in [`crate::fields`]:
//!
//! - a number must be finite: a NaN or an infinity makes its line bad (it is never read as 0);
//! - a position (`x`, `y`, `tx`, ...) lies within [`MAX_COORD`](crate::fields::MAX_COORD) of the
//!   origin; an angle is any finite number;
//! - robot and puck ids are `u32`, puck kinds `u8` ([`PuckKind`]), steps and counts
//!   non-negative integers, flags `0` or `1`;
//! - numbers are written rounded to 0.01 (cm or rad).
//!
//! Each message has one encoder and one decoder. A node acts on what it reads, so its decoder
//! (`decode`) refuses a packet with any bad line; a viewer's (`skim`, where one is needed) reads
//! the same lines by the same rules but skips a bad one and counts it ([`Skimmed`]). Lines with
//! labels a message does not know are ignored by both, so a writer may add lines.
//!
//! [`Skimmed`]: crate::error::Skimmed

use crate::fields::{bad, Source};
use crate::DecodeError;

pub mod assemble;
pub mod camera;
pub mod debug;
pub mod metrics;
pub mod vision;

pub use assemble::VisionAssembler;
pub use camera::{camera_channel, CameraView, Observation, SeenPuck};
pub use debug::{CachePoint, Intent, Intentions, DEBUG};
pub use metrics::{Progress, METRICS};
pub use vision::{
    Arena, Sizes, VisionBox, VisionFrame, VisionPart, VisionPuck, VisionRobot, VISION,
};

/// A puck's type (its colour), 0-based.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
pub struct PuckKind(pub u8);

/// A puck kind (0 to 255).
pub(crate) fn puck_kind(line: &impl Source, name: &str) -> Result<PuckKind, DecodeError> {
    let v = line.i64(name)?;
    u8::try_from(v)
        .map(PuckKind)
        .map_err(|_| bad(line, format!("{name} {v} is not a puck kind")))
}
