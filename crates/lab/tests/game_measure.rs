//! The paper's Tables 3 and 4 measured through a real hub: each hop of a player's command
//! timed on a live match.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use colony_game::rules::{Mode, Rules, TeamSetup};
use colony_hub::{HubConfig, Server};
use colony_lab::game::live_match::MatchPlan;
use colony_lab::game::measure::{run_series, SeriesSpec};

/// A hub in this process on a free loopback port.
struct Hub {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<std::io::Result<()>>>,
}

impl Hub {
    fn start() -> Hub {
        let mut server = Server::bind("127.0.0.1:0", HubConfig::default()).unwrap();
        let addr = server.local_addr().unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let s = stop.clone();
        let thread = Some(std::thread::spawn(move || server.run(&s)));
        Hub { addr, stop, thread }
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

#[test]
fn each_hop_of_a_players_command_is_timed_through_the_real_hub() {
    let hub = Hub::start();
    let map = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/ctf.map");
    let teams = [
        TeamSetup::parse("red", "alpha:infantry,infantry,infantry").unwrap(),
        TeamSetup::parse("blue", "alpha:scout").unwrap(),
    ];
    let plan = MatchPlan::new(&map, Rules::new(Mode::CaptureTheFlag), &teams).unwrap();
    let series = run_series(
        &plan,
        &hub.addr.to_string(),
        &SeriesSpec {
            think_every: 3,
            interval: Duration::from_millis(400),
            commands: 4,
            capture: false,
            spread: true,
        },
    )
    .unwrap();
    hub.stop.store(true, Ordering::Relaxed);
    assert_eq!(series.sent, 4);
    // Loopback may still drop a datagram on a loaded machine: most, not all, must come through.
    assert!(
        series.samples.len() >= 2,
        "commands followed to the robots: {series:?}"
    );
    for s in &series.samples {
        assert!(s.to_server >= 0.0 && s.server >= s.compute && s.to_robots >= 0.0);
        assert!((s.end_to_end - (s.to_server + s.server + s.to_robots)).abs() < 0.01);
    }
}
