//! A serialisable picture of the world at one instant, for live mode and plots.

use serde::{Deserialize, Serialize};

use crate::config::ArenaConfig;
use crate::types::{Pose, PuckKind, Vec2};

/// The world at one control step: what a viewer draws and a plot needs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WorldSnapshot {
    /// Control steps taken.
    pub step: u64,
    /// Simulated time, s.
    pub time: f64,
    /// The arena's outline.
    pub arena: ArenaConfig,
    /// Every robot, in id order.
    pub robots: Vec<RobotSnapshot>,
    /// Every puck, in id order.
    pub pucks: Vec<PuckSnapshot>,
}

/// One robot in a [`WorldSnapshot`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RobotSnapshot {
    /// The robot's id (`RobotId.0`).
    pub id: usize,
    /// World-frame pose.
    pub pose: Pose,
    /// The id of the puck it carries (`PuckId.0`), if any.
    pub carrying: Option<usize>,
}

/// One puck in a [`WorldSnapshot`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PuckSnapshot {
    /// The puck's id (`PuckId.0`).
    pub id: usize,
    /// Its type (colour).
    pub kind: PuckKind,
    /// World-frame position of its centre.
    pub pos: Vec2,
}
