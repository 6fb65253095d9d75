//! A real hub in this process on a free loopback port, and live agents on it.
#![allow(dead_code)]

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_hub::{HubConfig, Server};
use colony_node::{Link, Mux};
use colony_tasks::{AgentConfig, AuctionConfig, Node};

pub struct Hub {
    pub addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<std::io::Result<()>>>,
}

impl Hub {
    pub fn start() -> Hub {
        let mut server = Server::bind("127.0.0.1:0", HubConfig::default()).unwrap();
        let addr = server.local_addr().unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let s = stop.clone();
        let thread = Some(std::thread::spawn(move || server.run(&s)));
        Hub { addr, stop, thread }
    }

    pub fn link(&self, epoch: Instant) -> Link {
        Link::new(UdpClient::connect(self.addr).unwrap(), epoch)
    }
}

impl Drop for Hub {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Short timings, so that tests on loopback take fractions of a second.
pub fn quick_agent() -> AgentConfig {
    AgentConfig {
        renew_interval: Duration::from_millis(50),
        renew_timeout: Duration::from_millis(300),
        award_grace: Duration::from_millis(300),
        battery_check: Duration::from_millis(20),
        linger: Duration::from_millis(300),
        ..AgentConfig::default()
    }
}

pub fn quick_auction() -> AuctionConfig {
    AuctionConfig {
        bid_window: Duration::from_millis(80),
        ack_timeout: Duration::from_millis(300),
        renew_interval: Duration::from_millis(50),
        renew_timeout: Duration::from_millis(300),
        max_attempts: 16,
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
