//! The types other crates use to drive and read the world.

use std::fmt;

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

/// Index of a robot in a [`Field`](crate::field::Field) (0-based, in the order added, never reused).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FieldRobotId(pub usize);

/// Index of a box in a [`Field`](crate::field::Field) (0-based, in the order added, never reused).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FieldBoxId(pub usize);

impl fmt::Display for FieldRobotId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "robot {}", self.0)
    }
}

impl fmt::Display for FieldBoxId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "box {}", self.0)
    }
}

/// Why a robot or box cannot be put somewhere: the first obstacle found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refusal {
    /// The pose holds a NaN or an infinity.
    NotFinite,
    /// The body would stick out of the map.
    OffMap,
    /// The body would overlap this blocked cell (map coordinates, row from the top).
    Blocked {
        /// Column.
        x: usize,
        /// Row from the top.
        y: usize,
    },
    /// A land robot or a box would overlap this water cell.
    Water {
        /// Column.
        x: usize,
        /// Row from the top.
        y: usize,
    },
    /// The body would overlap this active robot.
    Robot(FieldRobotId),
    /// The body would overlap this box.
    Box(FieldBoxId),
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::NotFinite => write!(f, "the pose is not finite"),
            Refusal::OffMap => write!(f, "it would stick out of the map"),
            Refusal::Blocked { x, y } => write!(f, "it would overlap blocked cell ({x}, {y})"),
            Refusal::Water { x, y } => write!(
                f,
                "it would overlap water cell ({x}, {y}) and cannot enter water"
            ),
            Refusal::Robot(id) => write!(f, "it would overlap {id}"),
            Refusal::Box(id) => write!(f, "it would overlap {id}"),
        }
    }
}
