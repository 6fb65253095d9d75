//! colony's hub: the broker every colony process talks through.
//!
//! [`Hub`] is the whole broker as a state machine with no socket and no
//! clock: feed it `(now, source, bytes)` with [`Hub::handle`] and it says
//! where to repeat the datagram; ask [`Hub::poll_transmit`] for its own
//! replies and [`Hub::poll_timeout`] for when it next needs
//! [`Hub::handle_timeout`]. [`Server`] is the thin UDP runtime around it,
//! [`HubSite`] starts one on a thread for a program that was given none,
//! [`log`] holds the crash-tolerant traffic log and its reader, and
//! [`replay`] publishes a log again with its original timing.
//!
//! What the hub is not: it keeps no message history, retransmits nothing and
//! does not read packet bodies beyond checking that they are well formed.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod access;
mod broker;
mod config;
mod cookie;
mod counters;
mod local;
pub mod log;
mod rate;
pub mod replay;
mod server;

pub use access::{is_bad_source, Cidr, CidrError};
pub use broker::{Hub, Outcome, Transmit, MAX_TAPS};
pub use config::{HubConfig, MIN_LEASE};
pub use counters::DropReason;
pub use local::{HubSite, HubSpec, HubThread, HubThreadError, StartError};
pub use server::Server;
