//! The types other crates use to drive and read the world.

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
