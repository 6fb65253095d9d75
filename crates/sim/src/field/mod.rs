//! The tile-map field: a second kind of world, for the strategy game and the
//! box-pushing experiment.
//!
//! Where [`crate::World`] is the sorting paper's walled arena with grippers and
//! pucks, a [`Field`] is a grid map of open ground, walls and water on which
//! disc-shaped robots drive and push boxes. It knows nothing of teams, flags or
//! health: a game keeps those and tells the field which robots are in play.
//!
//! - **Frame.** Centimetres, seconds, radians. The origin is the map's bottom-left
//!   corner, y up; map cell `(x, y)` counts rows from the top, as map files do
//!   ([`TileMap`]).
//! - **Physics** on rapier2d, as in the arena: walls (the map's edge and
//!   [`Terrain::Blocked`] cells) and water are static colliders made of the map's
//!   cells merged into few rectangles; water stops robots with `amphibious == false`
//!   and boxes, and no one else. Robots are discs driven by velocity, boxes are
//!   rectangles whose floor friction is damping.
//! - **Sensors** ([`Field::sense`]): front and rear bumpers with the contact's bearing,
//!   a sonar cone, and an infrared border detector looking at the ground ahead.
//! - **Inactive robots** (dead in a game, switched off in an experiment) leave the
//!   field: they are taken out of the physics, so nothing meets them, no sensor sees
//!   them and they keep their last pose until [`Field::respawn`] puts them back.
//!   This is the game's view of a dead robot (carried off the battlefield); an
//!   experiment that wants a switched-off robot to stay as an obstacle keeps it
//!   active and sends it [`WheelCommand::STOP`].
//! - **Determinism.** The same map, configuration, placements and commands give
//!   bit-identical poses: rapier with `enhanced-determinism`, no threads, sensing in
//!   `f64` with `libm`.
//!
//! ```
//! use colony_sim::field::{Field, FieldConfig, RobotSpec, Terrain, TileMap};
//! use colony_sim::{Pose, WheelCommand};
//! // 20 x 10 cells of 10 cm, a river down column 10.
//! let map = TileMap::from_fn(20, 10, 10.0, |x, _| {
//!     if x == 10 { Terrain::Water } else { Terrain::Open }
//! }).unwrap();
//! let mut field = Field::new(map, FieldConfig::default()).unwrap();
//! let spec = RobotSpec { radius: 5.0, max_speed: 30.0, max_turn: 2.0, amphibious: false };
//! let id = field.add_robot(spec, Pose { x: 50.0, y: 50.0, theta: 0.0 }).unwrap();
//! for _ in 0..50 {
//!     field.step(&[WheelCommand { forward: 1.0, turn: 0.0 }]);
//! }
//! let pose = field.robot_pose(id).unwrap();
//! assert!((pose.x - 95.0).abs() < 0.5); // stopped at the water's edge (x = 100)
//! assert!(field.sense(id).unwrap().bump_front);
//! ```

mod config;
mod geom;
mod map;
mod physics;
mod place;
mod sense;

use colony_proto::geometry::unit;
use std::fmt;

use rapier2d::prelude::RigidBodyHandle;

pub use config::{BoxSpec, FieldConfig, RobotSpec};
pub use map::{Terrain, TileMap, MAX_MAP_CELLS, MAX_MAP_SIDE_CM};
// The ids and a placement's refusal are shared with the crate's error type, so they live in
// `types`, which names no module of the crate.
pub use crate::types::{FieldBoxId, FieldRobotId, Refusal};
pub use sense::{FieldSense, SonarEcho};

use crate::error::SimError;
use crate::grid::Grid;
use crate::types::{Pose, Vec2, WheelCommand};
use physics::FieldPhysics;

/// A robot as the field knows it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldRobot {
    /// Which robot.
    pub id: FieldRobotId,
    /// Where it is (for an inactive robot, where it was when it left), world frame.
    pub pose: Pose,
    /// Whether it is in play (see the module docs on inactive robots).
    pub active: bool,
    /// Its size, speeds and kind.
    pub spec: RobotSpec,
}

/// A box as the field knows it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldBox {
    /// Which box.
    pub id: FieldBoxId,
    /// Its centre and the direction of its length, world frame.
    pub pose: Pose,
    /// Its size, mass and damping.
    pub spec: BoxSpec,
}

#[derive(Debug, Clone)]
struct RobotSlot {
    body: RigidBodyHandle,
    spec: RobotSpec,
    pose: Pose,
    active: bool,
}

#[derive(Debug, Clone)]
struct BoxSlot {
    body: RigidBodyHandle,
    spec: BoxSpec,
    pose: Pose,
}

/// A tile map with robots and boxes on it, advanced one control step at a time.
///
/// Methods in three kinds: building ([`Field::new`], [`Field::add_robot`],
/// [`Field::add_box`]), inputs ([`Field::step`], [`Field::set_active`],
/// [`Field::respawn`]) and reading ([`Field::sense`], the pose getters).
pub struct Field {
    map: TileMap,
    config: FieldConfig,
    physics: FieldPhysics,
    robots: Vec<RobotSlot>,
    boxes: Vec<BoxSlot>,
    step: u64,
    /// Robots by where they were at the last [`Field::index_robots`]...
    robot_grid: Grid,
    /// ...and those added or moved since, whose place in the grid is missing or stale.
    unindexed: Vec<usize>,
    /// The largest robot radius, so a search for robots touching a disc knows how far to look.
    max_radius: f64,
}

/// Side of the cells of the robot grid, cm (larger on maps wider than
/// `ROBOT_CELL * ROBOT_MAX_CELLS`, so it never has more than that many cells a side).
const ROBOT_CELL: f64 = 25.0;
const ROBOT_MAX_CELLS: f64 = 256.0;
/// Robots added or moved between steps before the grid is rebuilt rather than searched
/// past: keeps placing N robots O(N^2 / this) instead of O(N^2).
const MAX_UNINDEXED: usize = 64;

impl Field {
    /// An empty field on `map`. Fails on an invalid configuration.
    pub fn new(map: TileMap, config: FieldConfig) -> Result<Field, SimError> {
        config.validate()?;
        let physics = FieldPhysics::new(&map, &config);
        let size = map.size_cm();
        let cell = ROBOT_CELL.max(size.x.max(size.y) / ROBOT_MAX_CELLS);
        Ok(Field {
            map,
            config,
            physics,
            robots: Vec::new(),
            boxes: Vec::new(),
            step: 0,
            robot_grid: Grid::over(Vec2::ZERO, size, cell),
            unindexed: Vec::new(),
            max_radius: 0.0,
        })
    }

    /// Adds an active robot at `pose`, at rest. Refuses an invalid spec, and a place
    /// where its disc would overlap the map's edge, a blocked cell, water (unless it
    /// is amphibious), an active robot or a box ([`SimError::Placement`] says which);
    /// touching is allowed.
    pub fn add_robot(&mut self, spec: RobotSpec, pose: Pose) -> Result<FieldRobotId, SimError> {
        spec.validate()?;
        let id = FieldRobotId(self.robots.len());
        self.check_robot_place(id, &spec, pose)?;
        let body = self.physics.add_robot(&spec, pose);
        let pose = self.physics.pose_of(body).unwrap_or(pose);
        self.robots.push(RobotSlot {
            body,
            spec,
            pose,
            active: true,
        });
        self.max_radius = self.max_radius.max(spec.radius);
        self.moved(id.0);
        Ok(id)
    }

    /// Adds a box at `pose` (its length along the heading), at rest. Refuses an
    /// invalid spec, and a place where it would overlap the map's edge, a blocked or
    /// water cell, an active robot or another box.
    pub fn add_box(&mut self, spec: BoxSpec, pose: Pose) -> Result<FieldBoxId, SimError> {
        spec.validate()?;
        let id = FieldBoxId(self.boxes.len());
        self.check_box_place(id, &spec, pose)?;
        let body = self.physics.add_box(&spec, pose);
        let pose = self.physics.pose_of(body).unwrap_or(pose);
        self.boxes.push(BoxSlot { body, spec, pose });
        Ok(id)
    }

    /// Takes a robot out of play or puts it back where it was.
    ///
    /// Deactivating stops it and takes it out of the physics and out of every
    /// sensor; it keeps its last pose. Reactivating puts it back at that pose, at
    /// rest, and fails like [`Field::respawn`] if something now stands there.
    /// Setting the state it already has does nothing.
    pub fn set_active(&mut self, id: FieldRobotId, active: bool) -> Result<(), SimError> {
        let slot = self.robots.get(id.0).ok_or(SimError::UnknownId {
            what: "robot",
            id: id.0,
        })?;
        match (slot.active, active) {
            (true, false) => {
                let body = slot.body;
                self.physics.set_enabled(body, false);
                self.robots[id.0].active = false;
                Ok(())
            }
            (false, true) => self.respawn(id, slot.pose),
            _ => Ok(()),
        }
    }

    /// Puts a robot, active or not, at `pose`, at rest and active: a game's respawn.
    /// Checks the place as [`Field::add_robot`] does (the robot itself aside); on
    /// failure the robot stays as it was.
    pub fn respawn(&mut self, id: FieldRobotId, pose: Pose) -> Result<(), SimError> {
        let slot = self.robots.get(id.0).ok_or(SimError::UnknownId {
            what: "robot",
            id: id.0,
        })?;
        let (body, spec) = (slot.body, slot.spec);
        self.check_robot_place(id, &spec, pose)?;
        self.physics.place(body, pose);
        self.physics.set_enabled(body, true);
        let slot = &mut self.robots[id.0];
        slot.active = true;
        slot.pose = self.physics.pose_of(body).unwrap_or(pose);
        self.moved(id.0);
        Ok(())
    }

    /// Notes that robot `i` is not where the grid has it.
    fn moved(&mut self, i: usize) {
        self.unindexed.push(i);
        if self.unindexed.len() > MAX_UNINDEXED {
            self.index_robots();
        }
    }

    fn index_robots(&mut self) {
        self.robot_grid
            .rebuild(self.robots.iter().map(|r| r.pose.position()));
        self.unindexed.clear();
    }

    /// Active robots other than `except` whose discs may come within `reach` of `c`
    /// (centres within `reach` plus the largest radius, in x and in y), in id order, for
    /// callers to test exactly.
    pub(super) fn robots_near(&self, c: Vec2, reach: f64, except: usize) -> Vec<usize> {
        let d = reach + self.max_radius;
        let mut near: Vec<usize> = self.unindexed.clone();
        self.robot_grid.query(
            Vec2::new(c.x - d, c.y - d),
            Vec2::new(c.x + d, c.y + d),
            |k| near.push(k as usize),
        );
        near.sort_unstable();
        near.dedup();
        near.retain(|&k| k != except && self.robots.get(k).is_some_and(|r| r.active));
        near
    }

    /// Advances the field by one control step (`config.substeps` physics steps).
    ///
    /// `commands[i]` drives robot `i`: values are clamped to [-1, 1] and NaN counts
    /// as 0; a missing command counts as [`WheelCommand::STOP`], extra commands and
    /// commands for inactive robots are ignored.
    pub fn step(&mut self, commands: &[WheelCommand]) {
        let robots = &self.robots;
        self.physics
            .rapier
            .steps(self.config.substeps, |rapier, _| {
                for (i, r) in robots.iter().enumerate() {
                    if !r.active {
                        continue;
                    }
                    let c = commands.get(i).copied().unwrap_or(WheelCommand::STOP);
                    rapier.drive(
                        r.body,
                        unit(c.forward) * r.spec.max_speed,
                        unit(c.turn) * r.spec.max_turn,
                    );
                }
            });
        self.step += 1;
        for r in &mut self.robots {
            if r.active {
                r.pose = self.physics.pose_of(r.body).unwrap_or(r.pose);
            }
        }
        for b in &mut self.boxes {
            b.pose = self.physics.pose_of(b.body).unwrap_or(b.pose);
        }
        self.index_robots();
    }

    /// A robot's pose (its last one if inactive), or `None` for an unknown id.
    pub fn robot_pose(&self, id: FieldRobotId) -> Option<Pose> {
        self.robots.get(id.0).map(|r| r.pose)
    }

    /// Whether a robot is in play, or `None` for an unknown id.
    pub fn is_active(&self, id: FieldRobotId) -> Option<bool> {
        self.robots.get(id.0).map(|r| r.active)
    }

    /// One robot, or `None` for an unknown id.
    pub fn robot(&self, id: FieldRobotId) -> Option<FieldRobot> {
        self.robots.get(id.0).map(|r| FieldRobot {
            id,
            pose: r.pose,
            active: r.active,
            spec: r.spec,
        })
    }

    /// Every robot, active or not, in id order.
    pub fn robots(&self) -> impl Iterator<Item = FieldRobot> + '_ {
        (0..self.robots.len()).filter_map(|i| self.robot(FieldRobotId(i)))
    }

    /// A box's pose, or `None` for an unknown id.
    pub fn box_pose(&self, id: FieldBoxId) -> Option<Pose> {
        self.boxes.get(id.0).map(|b| b.pose)
    }

    /// Every box, in id order.
    pub fn boxes(&self) -> impl Iterator<Item = FieldBox> + '_ {
        self.boxes.iter().enumerate().map(|(i, b)| FieldBox {
            id: FieldBoxId(i),
            pose: b.pose,
            spec: b.spec,
        })
    }

    /// Number of robots, active or not.
    pub fn robot_count(&self) -> usize {
        self.robots.len()
    }

    /// Number of boxes.
    pub fn box_count(&self) -> usize {
        self.boxes.len()
    }

    /// Control steps taken since the field was made.
    pub fn step_count(&self) -> u64 {
        self.step
    }

    /// Simulated time since the field was made, s.
    pub fn time(&self) -> f64 {
        self.step as f64 * self.config.control_step
    }

    /// The map the field was made on.
    pub fn map(&self) -> &TileMap {
        &self.map
    }

    /// The configuration the field was made with.
    pub fn config(&self) -> &FieldConfig {
        &self.config
    }

    /// `pose` (world frame) in the frame centred on the map's middle, as
    /// `vision` draws a world (its arena is centred on the origin).
    ///
    /// ```
    /// # use colony_sim::field::{Field, FieldConfig, TileMap};
    /// # use colony_sim::Pose;
    /// let field = Field::new(TileMap::open(10, 6, 10.0).unwrap(), FieldConfig::default()).unwrap();
    /// let p = field.centred(Pose { x: 20.0, y: 50.0, theta: 1.0 });
    /// assert_eq!((p.x, p.y, p.theta), (-30.0, 20.0, 1.0));
    /// ```
    pub fn centred(&self, pose: Pose) -> Pose {
        let size = self.map.size_cm();
        Pose {
            x: pose.x - size.x / 2.0,
            y: pose.y - size.y / 2.0,
            theta: pose.theta,
        }
    }
}

impl fmt::Debug for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Field")
            .field("map", &(self.map.width(), self.map.height()))
            .field("step", &self.step)
            .field("robots", &self.robots.len())
            .field("boxes", &self.boxes.len())
            .finish_non_exhaustive()
    }
}
