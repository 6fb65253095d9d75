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
//! ([`live::Link`]) and over the in-memory [`Bus`] on simulated time, where
//! [`experiment`] reproduces the paper's two experiments.
//!
//! This crate does not plan: a task's decomposition is written by the task's
//! designer (a high-level task announces its sub-tasks as it runs, as the
//! box-pushing watcher does). Nor does it move robots: an [`Agent`] says when
//! to start and stop, and its owner says when the task is done.
//!
//! # Where things are
//!
//! - [`protocol`]: the messages, written and read ([`Message`], [`TaskSpec`]).
//! - [`Agent`], [`Announcer`], [`UserAgent`]: the three roles, each a [`Node`].
//! - [`metric`]: the shared vocabulary robots score themselves with.
//! - [`Bus`]: the in-memory hub on simulated time; [`live`]: the real hub
//!   ([`live::Link`] for one node, [`live::Mux`] for many on one thread).
//! - [`experiment`]: long-term autonomy, box pushing, greedy against optimal;
//!   [`demo`]: the live demonstration `colony tasks demo` runs.
//!
//! # The messages
//!
//! One message per packet, priority 0. Scores are costs: the lowest wins, and
//! equal scores go to the lowest bidder token, so every listener picks the same
//! winner. `deadline_ms` is relative (bids are taken for that long after the
//! announcement is heard), so robots need no common clock.
//!
//! ```text
//! @ <camera> <laser> <mobile> <idle> 0          announcer → capable idle robots
//! task name sentry-duty id 17 negotiation murdoch.user.17.1 deadline_ms 200 length_s 120 announcer user
//! param name x value 350.0
//! param name color value "red"
//! metric name distance weight 1.0
//! metric name battery weight 200.0
//!
//! @ <murdoch.user.17.1> 0                        each capable robot → everyone negotiating
//! bid task 17 bidder r2 score 182.5
//!
//! @ <murdoch.user.17.1> 0                        announcer, at the deadline
//! award task 17 winner r2 score 182.5 bids 3
//!
//! @ <murdoch.user.17.1> 0                        the winner takes it and starts
//! ack task 17 bidder r2
//!
//! @ <murdoch.user.17.1> 0                        a bidder withdraws, or turns an award down
//! decline task 17 bidder r5
//!
//! @ <murdoch.user.17.1> 0                        both ways while the task runs
//! renew task 17 by r2 progress 0.4
//! @ <murdoch.user.17.1> 0
//! renew task 17 by user
//!
//! @ <murdoch.user.17.1> 0                        the winner, at the end
//! done task 17 bidder r2
//!
//! @ <murdoch.user.17.1> 0                        the winner gives up
//! abandon task 17 bidder r2 reason "announcer user silent for 3.0 s"
//!
//! @ <murdoch.user.17.1> 0                        the announcer withdraws it (then auctions it again on .2)
//! cancel task 17 reason "presumed failed: no renewal for 3.0 s"
//!
//! @ <murdoch.user.17.2> 0                        nobody bid
//! unachievable task 17 name sentry-duty reason "no robot with {camera laser mobile} is available"
//! ```
//!
//! [`Message::decode`] refuses anything else with the line and field at
//! fault ([`DecodeError`]) and never panics; a refused packet changes no
//! auction.

#![warn(missing_docs)]

mod agent;
mod announcer;
pub mod bus;
pub mod demo;
pub mod experiment;
pub mod live;
pub mod metric;
mod node;
pub mod protocol;
mod resource;
mod time;
mod user;

pub use agent::{Agent, AgentConfig, AgentEvent, AgentMode, AgentStats, StopReason};
pub use announcer::{Announcer, AnnouncerEvent, AnnouncerStats, AuctionConfig, TaskPhase};
pub use bus::{Bus, BusStats};
pub use metric::{MetricError, Metrics, RobotView};
pub use node::{receives, Node};
pub use protocol::{
    Announcement, Bid, DecodeError, EncodeError, Message, MetricTerm, Negotiation, Param,
    ParamValue, SpecError, TaskSpec,
};
pub use resource::{
    negotiation_subject, ResourceError, ResourceSet, Token, TokenError, IDLE, MAX_TASK_RESOURCES,
    MAX_TOKEN_LEN, NEGOTIATION_PREFIX,
};
pub use time::Time;
pub use user::{Backoff, UserAgent, UserEvent};
