//! Live mode: the world and each robot's controller as separate hub clients.
//!
//! The world publishes each robot's camera view on `camera.<id>` and the
//! global state on `vision`, and drives each robot by the newest `cmd` for it
//! on `radio`. A robot process subscribes to its camera channel, steps its
//! controller and publishes commands and intentions. Either side can be
//! killed and restarted: a robot with no fresh command stops, and a
//! restarted controller picks up from the next observation.
//!
//! Both sides are sans-IO [`colony_node::Node`]s ([`WorldNode`],
//! [`RobotNode`]): [`world::run`] and [`robot::run`] drive them over a real
//! hub with colony-node's runtime, and a test or an experiment runs the same
//! values on colony-node's in-memory [`Bus`](colony_node::Bus) on simulated
//! time, with no socket. colony-lab's `sort::launch` starts a whole swarm of them.
//!
//! Every packet is one of [`colony_proto`]'s messages: [`colony_proto::swarm`] for
//! `camera.N`, `vision`, `debug` and `metrics`, [`colony_proto::radio`] for the commands.

pub mod robot;
mod robot_node;
pub mod world;
mod world_node;

pub use robot_node::RobotNode;
pub use world_node::vision_frame;
pub use world_node::WorldNode;

/// What can stop a live world or robot.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    /// The hub client failed.
    #[error(transparent)]
    Client(#[from] colony_client::ClientError),
    /// A socket wait failed.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// A packet could not be written (a value the format cannot carry).
    #[error("cannot write a packet")]
    Packet(#[from] colony_wire::ParseError),
    /// The options make no sense.
    #[error("{0}")]
    Options(String),
    /// A robot id does not fit the `u32` every message writes ids as.
    #[error("robot {0} has no id on the wire: ids go up to {max}", max = u32::MAX)]
    RobotId(usize),
}

/// colony-node's runtime fails as the hub client underneath it does.
impl From<colony_node::LiveError> for LiveError {
    fn from(e: colony_node::LiveError) -> LiveError {
        match e {
            colony_node::LiveError::Client(e) => LiveError::Client(e),
            colony_node::LiveError::Io(e) => LiveError::Io(e),
        }
    }
}

/// Whether the runtime goes on with a node: on while `on`.
pub(crate) fn go_on(on: bool) -> std::ops::ControlFlow<()> {
    if on {
        std::ops::ControlFlow::Continue(())
    } else {
        std::ops::ControlFlow::Break(())
    }
}

/// `robot` as the `u32` every message writes robot ids as.
pub(crate) fn wire_id(robot: usize) -> Result<u32, LiveError> {
    u32::try_from(robot).map_err(|_| LiveError::RobotId(robot))
}
