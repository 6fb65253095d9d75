//! colony's lab: what measures the swarm and the game rather than what they do.
//!
//! - [`sort`]: the sorting experiments (trials run in parallel, their CSV files), the
//!   statistics and figures of the paper's reproduction and its supplementary experiments, two
//!   runs compared, and the launcher of a whole live swarm over a hub.
//! - [`game`]: a whole live match with its supervisor (and the same match fast-forwarded),
//!   and the paper's Tables 3 and 4 measured on one.
//! - [`tasks`]: MURDOCH's two experiments in the physics field (box pushing, the long-term
//!   run), its greedy auctions against the optimal assignment, the live demonstration, and a
//!   room of robot bodies over a hub.
//!
//! It is a crate apart from colony-sort, colony-game and colony-tasks, which hold the behaviour,
//! the rules and the protocol, because it links plotting (plotters) and statistics (statrs), and
//! runs the tasks' robots as bodies in the physics field: the domain crates, and the Python
//! extension built on colony-env, link neither, and colony-tasks no simulator.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod game;
pub mod sort;
pub mod tasks;
