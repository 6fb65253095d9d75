//! colony's strategy game, after Hristoskova, Junqué de Fortuny and De Turck,
//! "Subsumption Architecture for Enabling Strategic Coordination of Robot
//! Swarms in a Gaming Scenario".
//!
//! - [`map`]: battlefield maps in the Moving AI grid format, with teams, bases
//!   and flags.
//! - [`path`]: optimal 8-connected path finding without corner cutting, its
//!   faster variant, replanning, and turn points; [`nav`] puts it in
//!   centimetres for the swarm intelligence.
//! - [`formation`]: line, circle, half circle and the wedges, slot assignment,
//!   and formations that bend with the path.
//! - [`rules`]: the data model: robot types, budgets, squads.
//! - [`protocol`]: the game's messages (their home is `colony_proto::game`, one module per
//!   channel) and the map message built from a [`map::Battlefield`].
//! - [`robot`]: robot intelligence, reflexes over commands ([`robot_node`], its part of the game).
//! - [`squad`]: server-side swarm intelligence, one squad arbitrator per squad.
//! - [`logic`]: the referee: health, shots, flags, score, the end.
//! - [`server`]: game logic and swarm intelligence as one part of the game.
//! - [`world`]: the battlefield in the simulator.
//! - [`bot`]: the built-in scripted player.
//! - [`matches`]: the parts wired together in memory, fast-forwarded;
//!   [`live`] runs them over the hub.
//!
//! This crate holds the rules and the behaviour. A whole live match with its supervisor and
//! the paper's measurements of one are in colony-lab, the game as a learning environment in
//! colony-env.
//!
//! Every part of a match (the [`world::GameWorld`], the [`server::Server`],
//! each [`robot_node::RobotNode`], the [`bot::Bot`]) is a
//! [`colony_node::Node`]: packets and time in, packets and its next deadline
//! out. The same values run on colony-node's in-memory bus on simulated time
//! ([`matches`]) and over a real hub with its runtime ([`live`]); only the
//! world has a timer, its control step.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod bot;
pub mod formation;
pub mod live;
pub mod lobby;
pub mod logic;
pub mod map;
pub mod matches;
pub mod nav;
pub mod path;
pub mod protocol;
pub mod robot;
pub mod robot_node;
pub mod rules;
pub mod server;
pub mod squad;
pub mod world;
