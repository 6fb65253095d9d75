//! The paper's two experiments, and MURDOCH's greedy allocation against the optimum.
//!
//! - [`longterm`]: section 6.2, seven agents and four task types for hours,
//!   with batteries, chargers and failures (robots as bodies in the physics
//!   field; the run needs the `field` feature, its settings and report do not).
//! - `boxpush`: section 6.1, a watcher and two pushers moving a long box in
//!   the physics field, with a pusher switched off and on again (with the
//!   `field` feature, which brings in the physics engine).
//! - [`optimal`]: the same stream of tasks allocated by MURDOCH's auctions and
//!   by the optimal assignment (Kuhn-Munkres) with full knowledge.

#[cfg(feature = "field")]
pub mod boxpush;
pub mod longterm;
pub mod optimal;

/// Where a run stands after a `step`: the experiments are values advanced a
/// step at a time, so a caller can watch a run or stop it part-way.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Progress {
    /// More to do: step again.
    Running,
    /// The run is over: `finish` gives its outcome; further steps do nothing.
    Done,
}
