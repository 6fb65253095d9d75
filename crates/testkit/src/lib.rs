//! What colony's tests share, so each helper is written once: a real hub on
//! a thread of the test ([`hub`]), clients that wait for it ([`client`]),
//! the `colony` binary's processes ([`cli`]), a plain HTTP and WebSocket
//! client ([`web`]), the monitor joined to a hub ([`monitor`]), nodes on a
//! live hub ([`node`]), simulated scenes ([`sim`]) and free ports ([`net`]).
//!
//! A dev-dependency only. Each part but [`net`] is behind a feature of the
//! same name (see Cargo.toml), so a crate's tests build just what they use.

#[cfg(feature = "hub")]
pub mod cli;
#[cfg(feature = "hub")]
pub mod client;
#[cfg(feature = "hub")]
pub mod hub;
#[cfg(feature = "monitor")]
pub mod monitor;
pub mod net;
#[cfg(feature = "node")]
pub mod node;
#[cfg(feature = "sim")]
pub mod sim;
#[cfg(feature = "web")]
pub mod web;

#[cfg(feature = "hub")]
pub use hub::HubOnThread;
