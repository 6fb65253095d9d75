//! The tasks lab: the paper's two experiments with MURDOCH, its greedy allocation against the
//! optimum, and the live demonstration. The roles they run (agents, announcers, user agents)
//! are colony-tasks'.
//!
//! - [`longterm`]: section 6.2, seven agents and four task types for hours,
//!   with batteries, chargers and failures (robots as bodies in the physics
//!   field).
//! - [`boxpush`]: section 6.1, a watcher and two pushers moving a long box in
//!   the physics field, with a pusher switched off and on again.
//! - [`optimal`]: the same stream of tasks allocated by MURDOCH's auctions and
//!   by the optimal assignment (Kuhn-Munkres) with full knowledge.
//! - [`demo`]: the live demonstration `colony tasks demo` runs: the long-term
//!   experiment's roster over a real hub.
//! - [`room`]: a room of robot bodies in the physics field over the hub
//!   (`colony tasks room`), for agents that drive one each.

pub mod boxpush;
pub mod demo;
pub mod longterm;
pub mod optimal;
pub mod room;

/// Where a run stands after a `step`: the experiments are values advanced a
/// step at a time, so a caller can watch a run or stop it part-way.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Progress {
    /// More to do: step again.
    Running,
    /// The run is over: `finish` gives its outcome; further steps do nothing.
    Done,
}
