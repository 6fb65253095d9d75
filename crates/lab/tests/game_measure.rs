//! The paper's Tables 3 and 4 measured through a real hub: each hop of a player's command
//! timed on a live match.

use std::time::Duration;

use colony_game::rules::{Mode, Rules, TeamSetup};
use colony_lab::game::live_match::MatchPlan;
use colony_lab::game::measure::{run_series, SeriesSpec};
use colony_testkit::HubOnThread;

#[test]
fn each_hop_of_a_players_command_is_timed_through_the_real_hub() {
    let hub = HubOnThread::start();
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
    drop(hub);
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
