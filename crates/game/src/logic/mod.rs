//! Game logic: who is where, health, shots, flags, score and the end of the
//! game. It is the referee: robots and players ask, it decides, and it
//! refuses what the rules don't allow with a reason.
//!
//! - [`roster`]: who plays, with which ids, starting where.
//! - [`referee`]: what happens to them.

mod referee;
mod roster;

pub use referee::{Referee, RobotTally, BASE_RADIUS, FLAG_REACH};
pub use roster::{roster, RobotEntry, SetupError};

#[cfg(test)]
mod tests;
