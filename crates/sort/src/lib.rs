//! colony's swarm sorting: the methods of the cache-consensus paper.
//!
//! A sorting method is a [`Controller`]: a plain value that maps one
//! robot's [`Observation`] to a [`WheelCommand`] each control step. The same
//! controllers run in batch experiments (in-process, no hub) and in live
//! mode (one hub client per robot).
//!
//! The controllers' parts, one idea per module: [`params`] (every value the
//! paper leaves open, `configs/sort.toml`), [`perception`] (the local map,
//! on [`cluster`]'s graph clusters), [`vfh`] (VFH+ and the steering law),
//! [`deneubourg`] (pick-up and deposit probabilities), [`methods`] (BHD,
//! PROBSEEK, CACHECONS and its variants as explicit state machines) and
//! [`metrics`] (PC, STC, TWC, cache convergence). [`swarm`] holds the per-robot random
//! streams every runner makes, and [`live`] the world and a robot's controller as hub nodes.
//!
//! This crate holds behaviour only. The experiments, statistics, figures, reports and the
//! launcher of a whole live swarm are in colony-lab, which links the plotting and statistics
//! libraries a controller has no use for; the Python environment's core is in colony-env, so
//! the extension links neither.
//!
//! ```
//! use colony_sim::Observation;
//! use colony_sort::{build, Method, SortParams};
//! use rand::SeedableRng;
//! let params = SortParams::default(); // or SortParams::load("configs/sort.toml")?
//! let mut robot = build("probseek".parse::<Method>().unwrap(), &params, 2, 187.0);
//! let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
//! let command = robot.step(&Observation::default(), &mut rng);
//! assert_eq!(robot.state(), "PU_SCAN"); // wandering: a random goal fed to VFH+
//! assert!(command.forward > 0.0);
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod live;

pub mod cluster;
pub mod deneubourg;
pub mod methods;
pub mod metrics;
pub mod params;
pub mod perception;
pub mod swarm;
pub mod vfh;

pub use methods::{build, Method, UnknownMethod};
pub use params::{ParamsError, SortParams};

use colony_sim::{Observation, PuckKind, Vec2, WheelCommand};
use rand_chacha::ChaCha8Rng;

/// One robot's sorting behaviour, stepped once per control step.
pub trait Controller: Send {
    /// Decides this step's command from what the robot senses.
    fn step(&mut self, obs: &Observation, rng: &mut ChaCha8Rng) -> WheelCommand;
    /// The finite state machine's current state, for display (`PU_SCAN`, `HOMING`, ...).
    fn state(&self) -> &'static str;
    /// This robot's cache points (world frame), one per puck kind it has one for.
    fn cache_points(&self) -> Vec<(PuckKind, Vec2)> {
        Vec::new()
    }
    /// Where the robot is heading (world frame), if it has a target.
    fn target(&self) -> Option<Vec2> {
        None
    }
}
