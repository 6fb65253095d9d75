//! The parts of the game over the real hub, each behind a hub client of its
//! own, so they can run as separate processes and any of them can restart.
//! The caller owns the loop's thread; `stop` ends it.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use colony_client::{ClientError, UdpClient};

use crate::node::Node;
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

/// The longest a loop sleeps before looking at `stop` again.
const TICK: Duration = Duration::from_millis(50);

/// Runs a part that only answers packets until `stop`.
pub fn run_node(
    node: &mut dyn Node,
    client: &mut UdpClient,
    stop: &AtomicBool,
) -> Result<(), LiveError> {
    for s in node.subscriptions() {
        client.subscribe(&s)?;
    }
    let mut out = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        let wake = client
            .next_deadline()
            .map_or(now + TICK, |d| d.min(now + TICK));
        client.wait(Some(wake))?;
        client.poll(Instant::now())?;
        pump(node, client, &mut out)?;
    }
    Ok(())
}

/// Hands every packet waiting to `node`, then sends what it answered.
fn pump(
    node: &mut dyn Node,
    client: &mut UdpClient,
    out: &mut Vec<Vec<u8>>,
) -> Result<(), LiveError> {
    while let Some(packet) = client.recv()? {
        node.handle(&packet, out);
    }
    for p in out.drain(..) {
        client.publish(&p)?;
    }
    Ok(())
}

/// Runs the world in real time times `speed` until `stop` or `max_steps`.
pub fn run_world(
    world: &mut GameWorld,
    client: &mut UdpClient,
    step_seconds: f64,
    speed: f64,
    max_steps: Option<u64>,
    stop: &AtomicBool,
) -> Result<(), LiveError> {
    if !(speed.is_finite() && speed > 0.0) {
        return Err(LiveError::Options(format!(
            "speed must be a positive number, not {speed}"
        )));
    }
    for s in Node::subscriptions(world) {
        client.subscribe(&s)?;
    }
    let period = Duration::from_secs_f64(step_seconds / speed);
    let start = Instant::now();
    let mut done = 0u64;
    let mut out = Vec::new();
    while !stop.load(Ordering::Relaxed) && max_steps.is_none_or(|m| done < m) {
        let due = start + period.mul_f64(done as f64);
        loop {
            let now = Instant::now();
            client.poll(now)?;
            pump(world, client, &mut out)?;
            if now >= due || stop.load(Ordering::Relaxed) {
                break;
            }
            let wake = client.next_deadline().map_or(due, |d| d.min(due));
            client.wait(Some(wake))?;
        }
        world.step(&mut out);
        for p in out.drain(..) {
            client.publish(&p)?;
        }
        done += 1;
    }
    Ok(())
}
