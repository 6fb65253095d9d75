//! colony's 2D world: a deterministic simulator of small robots and pucks.
//!
//! A [`World`] holds the arena, the robots and the pucks; [`World::step`]
//! advances it by one control step given one [`WheelCommand`] per robot, and
//! [`World::observe`] gives a robot what its sensors report, as an
//! [`Observation`] in the robot's own frame. The same seed gives the same
//! trial on every machine and thread count.
//!
//! Units: centimetres, seconds, radians. World frame: origin at the arena's
//! centre, x to the right, y up, heading measured counter-clockwise from +x.
//! Robot frame: origin at the robot's centre, x forward, y to the left.
//!
//! This crate knows nothing of sorting, tasks or games.

mod types;

pub use types::*;
