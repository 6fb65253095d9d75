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
//! It reproduces the simulator behind the cache-consensus paper (Vardy, Vorobyev
//! and Banzhaf 2014) on a contact engine chosen per world ([`Engine`]: colony's own
//! `disc` engine, the default, or rapier2d, the reference): a rounded-square arena (187 cm, corner radius
//! 15), SRV-1 robots (12.5 x 10.8 cm) with a passive C-shaped gripper that holds
//! one puck, and pucks 6.3 cm across whose floor friction is modelled as damping.
//! A control step is 3 physics steps of 1/14 s. [`SceneConfig`] holds every value
//! with its source; `configs/scene.toml` is the standard configuration written out.
//!
//! - **Engines.** Both step the same bodies with the same masses, frictions and
//!   damping; the `disc` engine is written for exactly these shapes (see the `disc`
//!   module) and is several times faster on large swarms. `tests/fidelity.rs` holds it to
//!   rapier's behaviour where the sorting science rests on it.
//! - **Units.** Centimetres, seconds, grams, everywhere, rapier included: its
//!   `length_unit` is 100 (units per metre), which scales its tolerances. Two of
//!   those tolerances are changed for bodies this small: contact recycling keeps a
//!   pair's contacts until the bodies moved 0.05 cm (rapier's default, scaled, would
//!   be 5 cm) and continuous collision detection is off (nothing moves 1.5 cm in a
//!   physics step; walls are 10 cm thick).
//! - **Driving.** At each physics step a robot's velocity is set from its command:
//!   `forward * full_speed` along its heading, nothing sideways (tracks do not slide),
//!   and `turn * full_turn_rate`. Contacts act within the step, so robots push pucks
//!   and clusters (and break them), are stopped by walls and shove each other. A
//!   robot's centre of mass is its body's centre, so it turns on the spot.
//! - **Gripper.** A pocket of radius 3.6 in front of the body, open over 130
//!   degrees at the front (see the `body` module's picture): driving over a puck
//!   captures it, turning keeps it, backing away leaves it. A puck counts as carried
//!   when it covers more than 0.4 of the pocket's disc and stays carried while it
//!   covers more than 0.1 ([`CarryingConfig`]).
//! - **Determinism.** rapier's `enhanced-determinism` feature is on (libm and scalar
//!   maths in rapier, parry and glam; it cost about 1 % here), the disc engine uses
//!   only arithmetic IEEE rounds exactly, and this crate's own trigonometry uses `libm`,
//!   so a seed fixes a trial bit for bit across machines and thread counts.
//!   All randomness comes from `ChaCha8Rng::seed_from_u64(seed)`.
//! - **Threads.** The disc engine finds contacts and solves strips of the arena on
//!   rayon's threads, in an order fixed by the world alone. By default rapier steps on
//!   the calling thread. The `parallel-physics`
//!   feature turns on rapier's `parallel` feature, each control step's physics running in
//!   a thread pool lent to that world for the step (the caller's rayon context's threads,
//!   shared among the steps in flight). That pays for one sorting swarm of a few hundred
//!   robots and more at a time, and costs small or sparse worlds, and trials run side by
//!   side, the hand-over (BENCHMARKS.md, "Swarms of thousands"). Results are the default
//!   build's, bit for bit, whatever the thread count.
//! - **Sensing** is computed from the geometry, not by rendering (see
//!   [`World::observe`]): a few hundred nanoseconds per robot.
//!
//! # The tile-map field
//!
//! The [`field`] module holds a second kind of world for the strategy game and the
//! box-pushing experiment: a [`field::Field`] on a grid map of open ground, walls
//! and water, with disc robots (land or amphibious), pushable boxes, and the game
//! paper's sensors (bumpers, sonar, border detector). It follows the same rules:
//! rapier2d underneath, centimetres, a step function fed one [`WheelCommand`] per
//! robot, bit-identical results for identical inputs.
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
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod arena;
mod body;
pub mod canvas;
mod config;
mod config_load;
mod disc;
mod error;
pub mod field;
mod grid;
mod layout;
mod physics;
#[cfg(feature = "parallel-physics")]
mod pools;
mod rapier;
mod sense;
mod snapshot;
mod types;
mod world;

pub use config::{
    ArenaConfig, CameraConfig, CarryingConfig, Engine, Footprint, PhysicsConfig, PuckConfig,
    RobotConfig, SceneConfig, MAX_ARENA_SIDE,
};
pub use error::{ConfigError, SimError};
pub use physics::PhysicsStats;
pub use snapshot::{PuckSnapshot, RobotSnapshot, WorldSnapshot};
pub use types::*;
pub use world::{RobotShape, World};
