//! The parts of the game over a real hub, on colony-node's runtime.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_game::bot::Bot;
use colony_game::live::{self, LiveError};
use colony_game::logic::roster;
use colony_game::map::Battlefield;
use colony_game::protocol::{FlagState, GameState, RobotState, Status, STATE, WORLD};
use colony_game::rules::RobotKind;
use colony_game::rules::{Mode, Rules, TeamSetup};
use colony_game::world::GameWorld;
use colony_sim::{Pose, Vec2};
use colony_testkit::HubOnThread;

fn world() -> GameWorld {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/ctf.map");
    let field = Battlefield::from_file(&path).unwrap();
    let teams = [
        TeamSetup::parse("red", "alpha:tank").unwrap(),
        TeamSetup::parse("blue", "alpha:scout").unwrap(),
    ];
    let entries = roster(&field, &Rules::new(Mode::CaptureTheFlag), &teams).unwrap();
    GameWorld::new(&field, &entries).unwrap()
}

#[test]
fn a_live_world_takes_its_steps_at_its_pace_and_hands_its_client_back() {
    let hub = HubOnThread::start();
    let mut ear = hub.ear(WORLD);
    let mut w = world();
    let mut client = UdpClient::connect(hub.addr).unwrap();
    let local = client.local_addr().unwrap();
    let stop = AtomicBool::new(false);
    let t0 = Instant::now();
    // 0.1 s steps at 5x: one every 20 ms, the first at once.
    live::run_world(&mut w, &mut client, 0.1, 5.0, Some(5), &stop).unwrap();
    assert!(
        t0.elapsed() >= Duration::from_millis(80),
        "{:?}",
        t0.elapsed()
    );
    assert_eq!(w.field().step_count(), 5);
    assert_eq!(
        client.local_addr().unwrap(),
        local,
        "the caller's client back"
    );
    // Wait (generously) for the five frames, then a little longer for any sixth.
    let mut frames = Vec::new();
    let give_up = Instant::now() + Duration::from_secs(30);
    while frames.len() < 5 && Instant::now() < give_up {
        frames.extend(HubOnThread::hear(&mut ear, Duration::from_millis(100)));
    }
    frames.extend(HubOnThread::hear(&mut ear, Duration::from_millis(300)));
    assert_eq!(frames.len(), 5, "{frames:?}");
}

#[test]
fn a_live_world_refuses_a_bad_speed_and_a_stopped_one_does_not_step() {
    let hub = HubOnThread::start();
    let mut w = world();
    let mut client = UdpClient::connect(hub.addr).unwrap();
    let stop = AtomicBool::new(false);
    for speed in [0.0, -1.0, f64::NAN] {
        let e = live::run_world(&mut w, &mut client, 0.1, speed, None, &stop).unwrap_err();
        assert!(matches!(e, LiveError::Options(_)));
        assert!(
            e.to_string().contains("speed must be a positive number"),
            "{e}"
        );
    }
    stop.store(true, Ordering::Relaxed);
    live::run_world(&mut w, &mut client, 0.1, 1.0, None, &stop).unwrap();
    assert_eq!(w.field().step_count(), 0);
}

#[test]
fn a_live_bot_answers_the_game_state_until_stopped() {
    let hub = HubOnThread::start();
    let mut ear = hub.ear("game.player.red");
    let stop = Arc::new(AtomicBool::new(false));
    let addr = hub.addr;
    let s = stop.clone();
    let bot = std::thread::spawn(move || {
        let mut client = UdpClient::connect(addr).unwrap();
        live::run_node(&mut Bot::new("red"), &mut client, &s)
    });
    // Tell it the state until it has subscribed and answered.
    let mut publisher = UdpClient::connect(hub.addr).unwrap();
    let mut heard = Vec::new();
    for _ in 0..100 {
        publisher.publish(&red_state()).unwrap();
        heard = HubOnThread::hear(&mut ear, Duration::from_millis(50));
        if !heard.is_empty() {
            break;
        }
    }
    assert!(heard.iter().all(|l| l == "squad"), "{heard:?}");
    assert!(!heard.is_empty(), "the bot never answered on {STATE}");
    stop.store(true, Ordering::Relaxed);
    bot.join().unwrap().unwrap();
}

/// A running capture-the-flag game with one red squad.
fn red_state() -> Vec<u8> {
    GameState {
        mode: "ctf".into(),
        status: Status::Running,
        time: 10.0,
        winner: None,
        reason: String::new(),
        teams: Vec::new(),
        flags: ["red", "blue"]
            .map(|t| FlagState {
                team: t.into(),
                at: Vec2::ZERO,
                carrier: None,
                home: true,
            })
            .to_vec(),
        robots: vec![RobotState {
            id: 0,
            team: "red".into(),
            squad: "alpha".into(),
            kind: RobotKind::Tank,
            pose: Pose {
                x: 0.0,
                y: 0.0,
                theta: 0.0,
            },
            health: 1.0,
            max_health: 1.0,
            power: 0.0,
            alive: true,
            behaviour: String::new(),
            reason: String::new(),
        }],
        squads: Vec::new(),
    }
    .encode()
    .unwrap()
}
