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
//!
//! # The model
//!
//! It reproduces the simulator of the cache-consensus paper (Vardy, Vorobyev and
//! Banzhaf 2014) on rapier2d: a rounded-square arena (187 cm, corner radius 15),
//! SRV-1 robots (12.5 x 10.8 cm) with a passive C-shaped gripper that holds one
//! puck, and pucks 6.3 cm across whose floor friction is modelled as damping. A
//! control step is 3 physics steps of 1/14 s. [`SceneConfig`] holds every value,
//! with its source; `configs/scene.toml` is the standard configuration.
//!
//! - Driving: at each physics step a robot's velocity is set from its command,
//!   `forward * full_speed` along its heading and `turn * full_turn_rate`; contacts
//!   then act within the step, so robots push pucks and clusters, are stopped by
//!   walls and shove each other.
//! - Physics runs in centimetres (rapier's `length_unit` is 100) and grams, in f32.
//!   rapier's `enhanced-determinism` feature is on, and this crate's own trigonometry
//!   uses `libm`, so a seed fixes a trial bit for bit across machines; rapier's
//!   `parallel` feature is off, so the thread count cannot matter.
//! - Sensing is computed from the geometry, not by rendering (see [`World::observe`]).
//!
//! ```
//! use colony_sim::{RobotId, SceneConfig, WheelCommand, World};
//! let mut world = World::new(&SceneConfig::default(), 42).unwrap();
//! for _ in 0..10 {
//!     world.step(&[WheelCommand { forward: 1.0, turn: 0.2 }; 4]);
//! }
//! let obs = world.observe(RobotId(0));
//! println!("robot 0 at {:?} sees {} pucks", obs.pose, obs.pucks.len());
//! ```

mod arena;
mod body;
mod config;
mod error;
mod grid;
mod physics;
mod sense;
mod snapshot;
mod types;
mod world;

pub use config::{
    ArenaConfig, CameraConfig, CarryingConfig, Footprint, PhysicsConfig, PuckConfig, RobotConfig,
    SceneConfig,
};
pub use error::{ConfigError, SimError};
pub use snapshot::{PuckSnapshot, RobotSnapshot, WorldSnapshot};
pub use types::*;
pub use world::{RobotShape, World};
