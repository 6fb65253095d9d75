//! colony's system monitor: a web page that shows what the hub carries.
//!
//! The monitor is an ordinary hub client (two, in fact: one for data, one for
//! control requests) and a small web server on 127.0.0.1. The page, plain
//! HTML, CSS and JavaScript compiled into the binary, shows
//!
//! - the arena to scale: walls, pucks by colour, robots with their heading
//!   and what they carry, cache points, and each controller's intentions
//!   (FSM state and target) from the `debug` channel;
//! - the hub: every channel with its rate and last packet, clients and their
//!   subscriptions, drops by reason, what the monitor itself turned away or
//!   dropped (refused web requests, Foxglove viewers past the cap or too
//!   slow), and a box to forge and publish a packet;
//! - the percentage completion of a sorting run over time;
//! - a "stale since ..." banner when the hub or the vision falls silent.
//!
//! An operator can take control of one robot, a selection or all of them
//! and drive them with the keyboard or send them to a clicked point. This is
//! the Broker paper's override: the monitor publishes the held robots'
//! commands on `radio` at priority [`state::OVERRIDE_PRIORITY`] (above the
//! controllers' 0) every control step, and "take control of all" also raises
//! the hub's minimum priority to that value, restoring the old one on release.
//!
//! The web server answers only to its own host names, refuses WebSockets
//! from other sites' pages, and (unless told otherwise) needs a random token
//! that the printed address carries (see [`gate`]). An override belongs to the
//! page that took it and ends when that page's WebSocket closes, or when the page
//! stops answering pings or taking messages ([`Liveness`]): a frozen page cannot
//! hold the robots.
//!
//! The game page (`/game`) is the strategy game's player client: the
//! battlefield, every robot and squad with its behaviour and planned path,
//! and squad commands sent on `game.player.<team>` (see [`game`]).
//!
//! The task board (`/tasks`) shows MURDOCH's auctions: every task with its
//! state, bids, winner, renewals and timeline, and every robot's mode,
//! battery and resources (see [`tasks`]). To see every negotiation subject
//! as it appears, the monitor asks its hub to let it tap (every forwarded
//! packet); a hub that already has its most taps leaves it with its
//! subscriptions, and the board then sees only what those carry.
//!
//! Foxglove and Lichtblick connect to `ws://HOST:PORT/foxglove?token=...`
//! ([`Monitor::foxglove_url`]): every channel the monitor receives, as colony-schema's JSON,
//! the arena and the battlefield as scene entities, and the override for a viewer to publish.
//! The endpoint is the crate [`colony_foxglove`]; the monitor serves it, feeds it from its hub
//! link and carries out a viewer's override as a page's (`server::viewer`).
//!
//! [`state`], [`game`] and [`tasks`] are the logic without sockets or clocks; the hub link
//! (`hub_link`: its timers and subscriptions as a sans-IO core, and the thread that runs it with
//! the two hub clients) feeds them from the hub; the web server (axum) hands snapshots to
//! each browser tab.
//!
//! ```no_run
//! let monitor = colony_monitor::Monitor::start(&colony_monitor::MonitorConfig {
//!     hub: "127.0.0.1:7400".into(),
//!     bind: "127.0.0.1:8080".into(),
//!     ..Default::default()
//! })?;
//! // `http://127.0.0.1:8080/?token=...`: the pages need the token.
//! println!("open {}", monitor.url());
//! # monitor.shutdown()?;
//! # Ok::<(), colony_monitor::MonitorError>(())
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod game;
pub mod gate;
mod hub_link;
pub mod protocol;
mod request;
mod server;
pub mod state;
pub mod tasks;

pub use colony_foxglove::Liveness;
pub use hub_link::{EXTRA_CHANNELS, LEASE_CHANNEL};
pub use server::{Monitor, MonitorConfig, MonitorError};
