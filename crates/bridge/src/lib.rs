//! colony's federation over Zenoh: one bridge per hub, so that hubs on
//! several networks or sites share channels, each packet crossing each link
//! once, and only toward sites whose clients subscribe to it.
//!
//! The Broker paper runs one hub per fast network domain and leaves
//! forwarding between them to future work; colony does it with Zenoh, the
//! engine ROS 2's rmw_zenoh runs on, instead of a mesh of its own: Zenoh's
//! peers and routers carry the packets, its liveliness tokens carry each
//! site's interest, and its priorities carry the packets' (see
//! [`keys`] for the key layout and the priority table).
//!
//! Every decision a bridge makes is in a sans-IO core, [`relay::Relay`] (what arrived and the
//! time in; what to do on the hub and on Zenoh, and the next deadline, out); [`Bridge`] is the
//! thread that runs it between a hub client and a Zenoh session.
//!
//! ```no_run
//! use colony_bridge::{Bridge, BridgeConfig, Site};
//! use std::sync::atomic::AtomicBool;
//!
//! let mut config = BridgeConfig::new("127.0.0.1:7400", Site::new("lab").unwrap());
//! config.connect = vec!["tcp/10.0.0.2:7447".into()];
//! let mut bridge = Bridge::start(config, None).unwrap();
//! bridge.run(&AtomicBool::new(false)).unwrap();
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod config;
#[cfg(test)]
mod fixtures;
pub mod interest;
pub mod keys;
pub mod relay;
mod run;
mod stats;
pub mod track;
pub mod wants;
mod zenoh_io;

pub use config::{BridgeConfig, ConfigError, Mode, Pattern};
pub use keys::Site;
pub use run::Bridge;
pub use stats::{BridgeError, Stats};
