//! The paper's two experiments, and MURDOCH's greedy allocation against the optimum.
//!
//! - [`longterm`]: section 6.2, seven agents and four task types for hours,
//!   with batteries, chargers and failures (abstract robots on a plane).
//! - `boxpush`: section 6.1, a watcher and two pushers moving a long box in
//!   the physics field, with a pusher switched off and on again (with the
//!   `field` feature, which brings in the physics engine).
//! - [`optimal`]: the same stream of tasks allocated by MURDOCH's auctions and
//!   by the optimal assignment (Kuhn-Munkres) with full knowledge.

#[cfg(feature = "field")]
pub mod boxpush;
pub mod longterm;
pub mod optimal;
