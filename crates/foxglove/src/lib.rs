//! colony's Foxglove WebSocket endpoint (`/foxglove` on the monitor's own server): the hub's
//! channels for Foxglove, Lichtblick and any other `foxglove.websocket.v1` viewer.
//!
//! - **Channels as they appear.** The monitor's hub link writes every packet the monitor
//!   receives into a [`Feed`]: each topic (a channel, or a subject set joined by `+`, as
//!   [`colony_schema::topic`] names it) becomes a channel the first time it is seen (at most
//!   [`MAX_CHANNELS`]), advertised at once to every viewer, with encoding `json` and
//!   colony-schema's JSON Schema. Besides the hub's channels, three scene topics: the arena
//!   ([`ARENA_TOPIC`]) and the battlefield ([`BATTLEFIELD_TOPIC`], [`TERRAIN_TOPIC`]) as
//!   `foxglove.SceneUpdate` (see [`scene`]), and their frames placed in `world`
//!   ([`FRAMES_TOPIC`], `foxglove.FrameTransforms`); a new subscriber gets each one's newest at
//!   once.
//! - **Receive timestamps.** Each message carries the wall-clock time the monitor received it.
//! - **Nothing waits for a viewer.** The feed is a `tokio` broadcast: the hub link never blocks
//!   on it, and does nothing for it beyond noting a topic while no viewer is connected. A viewer
//!   that falls behind the broadcast misses messages, and each connection keeps at most the
//!   few newest messages of each channel waiting ([`session`]); both are counted and told to the
//!   viewer.
//!   JSON is written on the web server's threads, for the channels a viewer subscribed to.
//! - **Publishing is the override.** A viewer may publish only the operator's override
//!   ([`session::OVERRIDE_TOPIC`] or `radio`), which the monitor reads as its page's own
//!   commands and carries out for this connection exactly as for a page, letting go what it
//!   held when it closes or stops answering pings or taking messages (see [`Liveness`]). The
//!   monitor's server passes the endpoint's requests through the same gate as its page's
//!   WebSocket: the monitor's host names, a same-site `Origin` if there is one, and the token.
//!
//! # Why a crate of its own, and its seam with the monitor
//!
//! The endpoint is a job of its own (a protocol, a sans-IO session per viewer, scenes, a feed),
//! so it sits below colony-monitor, which serves it; it knows nothing of the monitor's types.
//! What it needs from the monitor comes through what it owns:
//!
//! - the hub link writes packets and scenes into the [`Feed`]; scenes are built from proto's
//!   types ([`scene`]), which the monitor's views keep;
//! - a viewer's override is handed to an [`Operator`], one per connection, which the monitor
//!   implements: it reads a [`session::Request`] as its page's commands (with the page's own
//!   parser and limits, so the rules are written once, in the monitor), carries each out on
//!   the hub side and answers, and lets go what the connection held when it ends;
//! - pinging ([`liveness`]) is here, not in the monitor, because both WebSockets need it, this
//!   endpoint's loop and the monitor page's, and this crate is the lower of the two.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod connection;
mod feed;
pub mod liveness;
pub mod protocol;
pub mod scene;
pub mod session;

pub use connection::{run, Link, Operator};
pub use feed::{
    feed, now_ns, Feed, PacketText, Payload, SceneBudget, Viewers, SCENE_EVERY, SCENE_SHARE,
};
pub use liveness::Liveness;

/// The path the endpoint is served at.
pub const PATH: &str = "/foxglove";
/// The arena's scene topic.
pub const ARENA_TOPIC: &str = "/colony/arena";
/// The battlefield's robots and flags.
pub const BATTLEFIELD_TOPIC: &str = "/colony/battlefield";
/// The battlefield's terrain (sent when the map changes).
pub const TERRAIN_TOPIC: &str = "/colony/battlefield/terrain";
/// The scene frames placed in a common `world` frame (`foxglove.FrameTransforms`).
pub const FRAMES_TOPIC: &str = "/colony/frames";
/// Channels advertised at most (the hub counts at most 1,024 channels of its own).
pub const MAX_CHANNELS: usize = 1024;
/// Channels kept for topics of one subject (the monitor subscribes to well under this many
/// subjects): subject-set topics, which a forger can make by the thousand, stop short of them.
pub const SINGLE_SUBJECT_RESERVE: usize = 256;
/// Foxglove viewers connected at once, at most; further connections are closed with a reason.
pub const MAX_VIEWERS: u64 = 16;
/// A viewer's own message is read up to this size (an override request is a few dozen bytes).
pub const MAX_VIEWER_MESSAGE: usize = 64 * 1024;
