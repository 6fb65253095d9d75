//! colony's multi-agent environments, the cores of the Python package (`crates/py`).
//!
//! - [`sort`]: the sorting swarm, one agent per robot ([`sort::SortEnv`]).
//! - [`game`]: a match of the strategy game, the agents one team's robots
//!   ([`game::GameEnv`]).
//!
//! Each is sans-IO and deterministic: it owns a world, takes every agent's action at once and
//! writes every agent's observation into buffers the caller owns. The behaviour and the rules
//! underneath are colony-sort's and colony-game's; this crate is apart from them so that they
//! hold behaviour and rules only, and apart from colony-lab so that the extension links no
//! plotting or statistics library.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod game;
pub mod sort;
