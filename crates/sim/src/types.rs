//! The types other crates use to drive and read the world.

pub use colony_proto::geometry::{Pose, Vec2, WheelCommand};
// What a robot senses is a message (the world sends it on `camera.N`), so it lives in proto.
pub use colony_proto::swarm::{Observation, PuckKind, SeenPuck};

/// Index of a robot in the world (0-based, stable for the whole trial).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RobotId(pub usize);

/// Index of a puck in the world (0-based, stable for the whole trial).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PuckId(pub usize);

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
