//! MURDOCH for colony: resource-centric task allocation by one-round auctions
//! over the hub, after Gerkey and Matarić, "Principled Communication for
//! Dynamic Multi-Robot Task Allocation".
//!
//! There is no central allocator. Every message is addressed by resources,
//! never by a robot's name: an [`Agent`] (a robot, or any machine with
//! resources) subscribes to its resources (`camera`, `laser`, `mobile`, ...)
//! and, while free, to [`IDLE`]; a task announcement goes to the task's
//! resources and `idle`, so only robots that could do it now hear it. Each
//! scores itself with the task's [`metric`]s and bids on the task's fresh
//! negotiation subject; every bidder hears every bid and so knows the winner
//! (losers drop out at once); the [`Announcer`] closes the auction at its
//! deadline with an award, the winner acknowledges and starts, and the two
//! renew to each other until it is done. A winner that stops renewing is
//! presumed failed and the task is auctioned again; a task whose announcer
//! falls silent is abandoned; a task no robot bids for is reported
//! unachievable with the reason, and a [`UserAgent`] introduces it again with
//! randomized exponential backoff.
//!
//! Everything is sans-IO ([`Node`]): the same values run over the real hub
//! ([`Link`]) and over the in-memory [`Bus`] on simulated time, where
//! colony-lab's `lab::tasks` reproduces the paper's two experiments.
//!
//! This crate does not plan: a task's decomposition is written by the task's
//! designer (a high-level task announces its sub-tasks as it runs, as the
//! box-pushing watcher does). Nor does it move robots: an [`Agent`] says when
//! to start and stop, and its owner says when the task is done.
//!
//! # Where things are
//!
//! - [`protocol`]: the messages, written and read ([`Message`], [`TaskSpec`]),
//!   at home in [`colony_proto::murdoch`].
//! - [`Agent`], [`Announcer`], [`UserAgent`]: the three roles, each a [`Node`].
//! - [`metric`]: the shared vocabulary robots score themselves with.
//! - [`Node`], [`Bus`], [`Link`], [`Mux`], [`Time`]: colony's one node runtime
//!   ([`colony_node`], re-exported here): the in-memory hub on simulated time,
//!   which routes through the real sans-IO hub, and the real hub ([`Link`] for
//!   one node, [`Mux`] for many on one thread).
//! - [`robot`]: one robot's agent as its own process, with an abstract body
//!   or one of the bodies of a world on `vision` and `radio` (such as
//!   colony-lab's room), driven over `radio` from what it sees on `vision`.
//!
//! The experiments (long-term autonomy, box pushing, greedy against optimal),
//! the live demonstration `colony tasks demo` runs and the room of bodies in the
//! physics field are colony-lab's (`lab::tasks`): this crate links no simulator.
//!
//! # The messages
//!
//! MURDOCH's messages, its resource sets and tokens live in
//! [`colony_proto::murdoch`] (re-exported here as [`protocol`]), with the
//! packets they travel as: one home, used by this crate and the fuzz targets
//! alike.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod agent;
mod announcer;
pub mod metric;
pub mod request;
pub mod robot;
#[cfg(test)]
mod test_keys;
mod user;

pub use agent::{Agent, AgentConfig, AgentEvent, AgentMode, AgentStats, StopReason};
pub use announcer::{Announcer, AnnouncerEvent, AnnouncerStats, AuctionConfig, TaskPhase};
pub use colony_node::{Bus, BusStats, Link, LiveError, Mux, Node, Time};
pub use colony_proto::murdoch as protocol;
pub use colony_proto::DecodeError;
pub use metric::{MetricError, Metrics, RobotView};
pub use protocol::{
    negotiation_subject, Announcement, Bid, EncodeError, Message, MetricTerm, Negotiation, Param,
    ParamValue, ResourceError, ResourceSet, SpecError, TaskSpec, Token, TokenError, IDLE,
    MAX_TASK_RESOURCES, MAX_TOKEN_LEN, NEGOTIATION_PREFIX,
};
pub use user::{Backoff, UserAgent, UserEvent};
