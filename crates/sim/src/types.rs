//! The types other crates use to drive and read the world.

pub use colony_proto::geometry::{Pose, Vec2, WheelCommand};

/// Index of a robot in the world (0-based, stable for the whole trial).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RobotId(pub usize);

/// Index of a puck in the world (0-based, stable for the whole trial).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PuckId(pub usize);

/// A puck's type (its colour), 0-based.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
pub struct PuckKind(pub u8);

/// A puck as the world (the "global map") knows it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Puck {
    /// Which puck.
    pub id: PuckId,
    /// Its type (colour).
    pub kind: PuckKind,
    /// World-frame position of its centre, cm.
    pub pos: Vec2,
}

/// A robot as the world knows it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobotState {
    /// Which robot.
    pub id: RobotId,
    /// Where it is, world frame.
    pub pose: Pose,
    /// The puck in its gripper, if any.
    pub carrying: Option<PuckId>,
}

/// A puck the forward camera sees, in the robot frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeenPuck {
    /// Its type (colour).
    pub kind: PuckKind,
    /// Its centre in the robot frame, cm.
    pub pos: Vec2,
    /// It lies in another robot's gripper (the paper's perception drops such pucks).
    pub held_by_other: bool,
}

/// What one robot's sensors report after a step; everything but `pose` is in the robot frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Observation {
    /// The pose a localisation system (overhead tracker) reports, in the world frame.
    pub pose: Pose,
    /// The puck in this robot's own gripper, at the gripper's position.
    pub gripper: Option<SeenPuck>,
    /// Pucks inside the camera's ground footprint, the carried one excluded.
    pub pucks: Vec<SeenPuck>,
    /// Centres of other robots inside the footprint.
    pub robots: Vec<Vec2>,
    /// Points on walls and on other robots' bodies inside the footprint,
    /// about 1 cm apart: the occupancy grid's obstacle cells.
    pub obstacles: Vec<Vec2>,
}
