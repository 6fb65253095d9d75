//! Nodes on a live hub: links to a [`HubOnThread`], and a [`Mux`] pumped
//! until its members are settled or a test's condition holds.

use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_node::{Link, Mux, Node};

use crate::HubOnThread;

impl HubOnThread {
    /// A node's link to this hub, its clock started at `epoch`.
    pub fn link(&self, epoch: Instant) -> Link {
        Link::new(UdpClient::connect(self.addr).unwrap(), epoch)
    }
}

/// Pumps the mux until `done` says so or `limit` passes; true if done.
pub fn run_until<N: Node>(
    mux: &mut Mux<N>,
    limit: Duration,
    mut done: impl FnMut(&mut Mux<N>) -> bool,
) -> bool {
    let end = Instant::now() + limit;
    while Instant::now() < end {
        mux.pump().unwrap();
        if done(mux) {
            return true;
        }
        mux.wait(Duration::from_millis(5)).unwrap();
    }
    false
}

/// Lets every member settle its subscriptions with the hub: until each one
/// that subscribes has done the cookie round trip and holds a lease (a
/// generous limit, not a deadline), and a little more for what is in flight.
pub fn settle<N: Node>(mux: &mut Mux<N>) {
    let leased = run_until(mux, Duration::from_secs(30), |m| {
        m.iter_mut().all(|(_, link, _)| {
            let session = link.client().session();
            session.subscriptions().next().is_none() || session.lease().is_some()
        })
    });
    assert!(leased, "members still without a lease after 30 s");
    run_until(mux, Duration::from_millis(100), |_| false);
}
