//! Runs a node over a hub client the caller lends, with colony-node's runtime.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use colony_client::UdpClient;
use colony_node::{Link, Node, Time};

use super::LiveError;

/// Runs `node` over `client` with [`colony_node::run`] until `stop` is set
/// or `go_on` (called after every round) says no. The link's clock starts now.
/// The link borrows the caller's client, which keeps the subscriptions the node
/// made.
pub(super) fn serve<N: Node>(
    node: &mut N,
    client: &mut UdpClient,
    stop: &AtomicBool,
    mut go_on: impl FnMut(&mut N, Time) -> bool,
) -> Result<(), LiveError> {
    let mut link = Link::new(client, Instant::now());
    let halt = AtomicBool::new(stop.load(Ordering::Relaxed));
    let result = colony_node::run(node, &mut link, &halt, |node, now| {
        if stop.load(Ordering::Relaxed) || !go_on(node, now) {
            halt.store(true, Ordering::Relaxed);
        }
    });
    Ok(result?)
}
