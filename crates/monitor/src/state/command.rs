//! What the browser may ask the monitor to do, already checked, and why a request could not be
//! done.

use crate::game::orders::GameOrder;

/// A request the browser made, already checked ([`crate::protocol::parse_message`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Publish this packet (already parsed once) as it stands.
    Publish(Vec<u8>),
    /// Hold these robots (stopped until driven).
    Take(Vec<u32>),
    /// Hold every robot, and raise the hub's minimum priority.
    TakeAll,
    /// Hand these robots back to their controllers.
    Release(Vec<u32>),
    /// Hand every robot back, and restore the hub's minimum priority.
    ReleaseAll,
    /// Drive held robots (those among `ids`, or all held ones).
    Drive {
        /// Which held robots; `None`: all of them.
        ids: Option<Vec<u32>>,
        /// Forward speed, -1 to 1.
        forward: f64,
        /// Turn rate, -1 to 1 (counter-clockwise positive).
        turn: f64,
    },
    /// Steer held robots (those among `ids`, or all held ones) to a point.
    Goto {
        /// Which held robots; `None`: all of them.
        ids: Option<Vec<u32>>,
        /// The point's x, cm.
        x: f64,
        /// The point's y, cm.
        y: f64,
    },
    /// A player's order for the strategy game, or a chat line (the bridge publishes it).
    Game(GameOrder),
}

/// Why a request could not be carried out; the message is for the operator to read.
#[derive(Debug, thiserror::Error)]
pub enum CommandError {
    /// "Take control" with no robot named.
    #[error("no robot selected: click robots or type their ids")]
    NoneSelected,
    /// Holding one more would exceed [`MAX_HELD`](super::MAX_HELD).
    #[error("at most {} robots can be held", super::MAX_HELD)]
    TooMany,
    /// None of the robots named is held (the text names them).
    #[error("{0} not held")]
    NotHeld(String),
    /// A robot would have to be held first to `{0}` it.
    #[error("no held robot to {0}: take control first")]
    NoneHeld(&'static str),
    /// The packet could not be written (its message says why).
    #[error("cannot write the squad command: {0}")]
    Write(colony_wire::ParseError),
    /// The packet is not one (its message says where).
    #[error("{0}")]
    Packet(colony_wire::ParseError),
    /// The hub client could not send it (its message says why).
    #[error("cannot publish: {0}")]
    Publish(colony_client::ClientError),
}
