//! colony's lab: what measures the swarm and the game rather than what they do.
//!
//! - [`sort`]: the sorting experiments (trials run in parallel, their CSV files), the
//!   statistics and figures of the paper's reproduction and its supplementary experiments, two
//!   runs compared, and the launcher of a whole live swarm over a hub.
//! - [`game`]: a whole live match with its supervisor (and the same match fast-forwarded),
//!   and the paper's Tables 3 and 4 measured on one.
//!
//! It is a crate apart from colony-sort and colony-game, which hold the behaviour and the
//! rules, because it links plotting (plotters) and statistics (statrs): the domain crates, and
//! the Python extension built on colony-env, link neither.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod game;
pub mod sort;
