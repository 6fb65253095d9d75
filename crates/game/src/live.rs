//! The parts of the game over the real hub, each behind a hub client of its
//! own, so they can run as separate processes and any of them can restart.
//! They run on colony-node's runtime ([`colony_node::run`] over a
//! [`Link`]); the world's real-time pace is its timer. The caller owns the
//! loop's thread; `stop` ends it.

use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use colony_client::{ClientError, UdpClient};
use colony_node::{Link, Node, Time};

use crate::world::GameWorld;

/// What can stop a live part.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    /// The hub client failed.
    #[error(transparent)]
    Client(#[from] ClientError),
    /// The socket failed.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// A bad option.
    #[error("{0}")]
    Options(String),
}

impl From<colony_node::LiveError> for LiveError {
    fn from(e: colony_node::LiveError) -> LiveError {
        match e {
            colony_node::LiveError::Client(e) => LiveError::Client(e),
            colony_node::LiveError::Io(e) => LiveError::Io(e),
        }
    }
}

/// Runs a part until `stop`.
pub fn run_node(
    node: &mut dyn Node,
    client: &mut UdpClient,
    stop: &AtomicBool,
) -> Result<(), LiveError> {
    run_node_since(node, client, Instant::now(), stop)
}

/// Runs a part until `stop`, its clock counting from `epoch`: parts given the same epoch
/// read the same time, so the moments they record can be compared (the game's timings).
pub fn run_node_since(
    node: &mut dyn Node,
    client: &mut UdpClient,
    epoch: Instant,
    stop: &AtomicBool,
) -> Result<(), LiveError> {
    let mut link = Link::new(client, epoch);
    colony_node::run(&mut &mut *node, &mut link, stop, |_, _| {
        ControlFlow::Continue(())
    })?;
    Ok(())
}

/// Runs the world in real time times `speed` until `stop` or `max_steps`:
/// one control step of `step_seconds` of game time every
/// `step_seconds / speed` seconds, the first at once.
pub fn run_world(
    world: &mut GameWorld,
    client: &mut UdpClient,
    step_seconds: f64,
    speed: f64,
    max_steps: Option<u64>,
    stop: &AtomicBool,
) -> Result<(), LiveError> {
    let period = (speed.is_finite() && speed > 0.0)
        .then(|| Duration::try_from_secs_f64(step_seconds / speed).ok())
        .flatten()
        .ok_or_else(|| {
            LiveError::Options(format!("speed must be a positive number, not {speed}"))
        })?;
    world.set_pace(period, Time::ZERO);
    let start = world.field().step_count();
    let finished = |w: &GameWorld| max_steps.is_some_and(|m| w.field().step_count() - start >= m);
    if stop.load(Ordering::Relaxed) || finished(world) {
        return Ok(());
    }
    let mut link = Link::new(client, Instant::now());
    colony_node::run(world, &mut link, stop, |w, _| {
        if finished(w) {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    })?;
    Ok(())
}
