//! Live mode: the world and each robot's controller as separate hub clients.
//!
//! The world publishes each robot's camera view on `camera.<id>` and the
//! global state on `vision`, and drives each robot by the newest `cmd` for it
//! on `radio`. A robot process subscribes to its camera channel, steps its
//! controller and publishes commands and intentions. Either side can be
//! killed and restarted: a robot with no fresh command stops, and a
//! restarted controller picks up from the next observation.

pub mod codec;
pub mod launch;
pub mod robot;
pub mod world;

/// What can stop a live world or robot.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    #[error(transparent)]
    Client(#[from] colony_client::ClientError),
    #[error(transparent)]
    Io(#[from] std::io::Error),
    #[error("cannot write a packet: {0}")]
    Packet(#[from] colony_wire::ParseError),
    #[error("{0}")]
    Options(String),
}
