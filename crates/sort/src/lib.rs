//! colony's swarm sorting: the methods of the cache-consensus paper.
//!
//! A sorting method is a [`Controller`]: a plain value that maps one
//! robot's [`Observation`] to a [`WheelCommand`] each control step. The same
//! controllers run in batch experiments (in-process, no hub) and in live
//! mode (one hub client per robot).

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
