//! A real hub serving on a thread of the test, on a free loopback port.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_hub::{HubConfig, Server};

/// A hub in this process on a free loopback port, stopped when dropped.
///
/// Unlike [`colony_hub::HubThread`] it hands its [`Server`] back when it
/// stops ([`stop_within`](Self::stop_within)), so a test can read the hub's
/// counters, and a hub that panicked fails the test that dropped it.
pub struct HubOnThread {
    /// Where it listens.
    pub addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<(std::io::Result<()>, Server)>>,
}

impl HubOnThread {
    /// A hub with the default limits.
    pub fn start() -> HubOnThread {
        HubOnThread::start_with(HubConfig::default())
    }

    /// A hub that takes operator requests from loopback.
    pub fn with_console() -> HubOnThread {
        HubOnThread::start_with(HubConfig {
            consoles: vec!["127.0.0.1/32".parse().unwrap()],
            ..HubConfig::default()
        })
    }

    /// A hub with these limits.
    pub fn start_with(config: HubConfig) -> HubOnThread {
        let mut server = Server::bind("127.0.0.1:0", config).unwrap();
        let addr = server.local_addr().unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let s = stop.clone();
        let thread = Some(std::thread::spawn(move || (server.run(&s), server)));
        HubOnThread { addr, stop, thread }
    }

    /// A client of this hub.
    pub fn client(&self) -> UdpClient {
        UdpClient::connect(self.addr).unwrap()
    }

    /// Tells the hub to stop and waits up to `limit` for it: its server,
    /// or `None` if it still runs (its thread is then left to itself).
    /// Panics if the hub failed.
    pub fn stop_within(mut self, limit: Duration) -> Option<Server> {
        self.stop.store(true, Ordering::SeqCst);
        let thread = self.thread.take()?;
        let deadline = Instant::now() + limit;
        while !thread.is_finished() {
            if Instant::now() > deadline {
                return None;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        let (ran, server) = thread.join().expect("the hub's thread panicked");
        ran.expect("the hub failed");
        Some(server)
    }

    /// A client subscribed to `subject`, once the hub has granted it.
    pub fn ear(&self, subject: &str) -> UdpClient {
        let mut c = UdpClient::connect(self.addr).unwrap();
        c.subscribe(subject).unwrap();
        // The hub handles datagrams in order; a round trip through it makes
        // sure the subscription is in place before anyone publishes.
        let mut probe = UdpClient::connect(self.addr).unwrap();
        let until = Instant::now() + Duration::from_secs(5);
        loop {
            probe
                .publish(format!("@ <{subject}> 0\nprobe\n").as_bytes())
                .unwrap();
            c.wait(Some(Instant::now() + Duration::from_millis(20)))
                .unwrap();
            c.poll(Instant::now()).unwrap();
            if c.recv().unwrap().is_some() {
                while c.recv().unwrap().is_some() {}
                return c;
            }
            assert!(Instant::now() < until, "the hub never subscribed the ear");
        }
    }

    /// Every packet `c` receives in the next `d`, by first line, leaving out the probes
    /// [`ear`](Self::ear) sent (on a loaded machine some arrive after the first).
    pub fn hear(c: &mut UdpClient, d: Duration) -> Vec<String> {
        let until = Instant::now() + d;
        let mut got = Vec::new();
        while Instant::now() < until {
            c.wait(Some(until)).unwrap();
            c.poll(Instant::now()).unwrap();
            while let Some(p) = c.recv().unwrap() {
                let label = p.lines().next().map_or("", |l| l.label());
                if label != "probe" {
                    got.push(label.to_string());
                }
            }
        }
        got
    }
}

impl Drop for HubOnThread {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            // A second panic while the test unwinds would abort the whole run.
            if t.join().is_err() && !std::thread::panicking() {
                panic!("the hub's thread panicked");
            }
        }
    }
}
