//! colony's client library: talk to a hub without giving up your main loop.
//!
//! [`Session`] is the protocol alone, sans I/O: which subscriptions to
//! refresh and when, when a silent channel needs a fresh subscribe (the hub
//! may have restarted), and whether the hub is answering. [`UdpClient`] puts
//! a non-blocking socket under it: it hands out its file descriptor
//! ([`AsFd`](std::os::fd::AsFd)) and its [`next_deadline`](UdpClient::next_deadline),
//! and does work only when you call [`poll`](UdpClient::poll),
//! [`recv`](UdpClient::recv) or [`publish`](UdpClient::publish). It starts no
//! thread and never blocks. With the `tokio` feature, [`AsyncClient`] wraps it
//! in `AsyncFd`. [`status`] asks a hub what it knows; [`rate`] measures
//! channel rates, from the hub's status reports or from the packets
//! received; [`rpc`] is request and reply between clients, over
//! publish/subscribe.
//!
//! ```no_run
//! use std::time::Instant;
//! use colony_client::UdpClient;
//! let mut client = UdpClient::connect("127.0.0.1:7400")?;
//! client.subscribe("vision_out")?;
//! loop {
//!     client.wait(client.next_deadline())?; // or your own poll/epoll/mio loop
//!     client.poll(Instant::now())?;
//!     while let Some(packet) = client.recv()? {
//!         println!("{packet}");
//!     }
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
// The one exception, behind the `tokio` feature: registering the socket
// with tokio's reactor, which tokio marks unsafe (see tokio_client.rs).
#![cfg_attr(not(feature = "tokio"), forbid(unsafe_code))]
#![cfg_attr(feature = "tokio", deny(unsafe_code))]
#![warn(missing_docs)]

pub mod rate;
pub mod rpc;
mod session;
pub mod status;
mod udp;

#[cfg(feature = "tokio")]
mod tokio_client;

pub use session::{ClientConfig, HubState, Incoming, Session};
pub use udp::{ClientError, ConnectError, Delivery, UdpClient};

#[cfg(feature = "tokio")]
pub use tokio_client::AsyncClient;
