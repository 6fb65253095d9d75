//! colony's node runtime: one shape for every participant in a colony
//! protocol, and the two places it runs.
//!
//! A [`Node`] is a hub client with no socket and no clock, in the quinn-proto
//! manner: packets and time go in ([`Node::handle_packet`],
//! [`Node::handle_timeout`]), packets and the next deadline come out
//! ([`Node::poll_transmit`], [`Node::poll_timeout`]), and the subjects it wants
//! are a getter ([`Node::subscriptions`]). The same value then runs
//!
//! - on simulated time, in tests and batch experiments, over the in-memory
//!   [`Bus`]: it routes every packet through the real sans-IO
//!   [`Hub`](colony_hub::Hub), with a real client
//!   [`Session`](colony_client::Session) per node, so a batch run sees the
//!   subject sets, leases, limits, minimum priority and drop counters of a
//!   live system, deterministically and as fast as the computation goes;
//! - over a real hub, on UDP: a [`Link`] per node, driven by [`run`] on a
//!   thread of the caller's or, many on one thread, by a [`Mux`] (one mio
//!   loop).
//!
//! [`Time`] is the protocol's clock: microseconds since an epoch the caller
//! picks (the start of a simulation, or when the runner started).
//!
//! What this crate is not: it knows no message of any protocol (those live
//! with their protocols), it never starts a thread or owns a loop of its own,
//! and the [`Bus`] is no network simulator: its one fault is a cut link
//! ([`Bus::set_reachable`]), its latency is fixed, and it loses nothing else.
//!
//! ```
//! use std::collections::BTreeSet;
//! use std::time::Duration;
//! use colony_node::{Bus, Node, Time};
//! use colony_wire::{Packet, Subject};
//!
//! /// Answers every `ping` with a `pong`.
//! struct Echo { subs: BTreeSet<Subject>, outbox: Vec<Vec<u8>> }
//! impl Node for Echo {
//!     fn subscriptions(&self) -> &BTreeSet<Subject> { &self.subs }
//!     fn handle_packet(&mut self, _: Time, _: &Packet<'_>) {
//!         self.outbox.push(b"@ <pong> 0\npong\n".to_vec());
//!     }
//!     fn handle_timeout(&mut self, _: Time) {}
//!     fn poll_timeout(&self) -> Option<Time> { None }
//!     fn poll_transmit(&mut self) -> Option<Vec<u8>> { self.outbox.pop() }
//! }
//!
//! let mut echo = Echo { subs: [Subject::new("ping").unwrap()].into(), outbox: vec![] };
//! let mut bus = Bus::new(Duration::from_millis(2));
//! bus.record();
//! bus.run_until(&mut [&mut echo], Time::ZERO);
//! bus.publish(b"@ <ping> 0\nping\n".to_vec());
//! bus.run_until(&mut [&mut echo], Time::from_secs_f64(1.0));
//! let sent: Vec<(u64, Vec<u8>)> = bus.take_recorded().into_iter()
//!     .map(|(t, p)| (t.as_micros(), p)).collect();
//! assert_eq!(sent[1], (2_000, b"@ <pong> 0\npong\n".to_vec()));
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod bus;
mod live;
mod node;
mod ports;
mod time;

pub use bus::{Bus, BusStats};
pub use live::{run, Link, LiveError, Mux};
pub use node::Node;
pub use time::Time;
