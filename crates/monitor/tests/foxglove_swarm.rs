//! The Foxglove endpoint with a big swarm over real sockets: 2,000 robots and 20,000 pucks on
//! `vision`, a viewer subscribed to the arena's scene that stops reading for a while. It is
//! sent whole scenes only (every robot and puck in each), and what it missed is counted; the
//! scenes the bridge passed over to keep its time budget are counted too. (How long a scene
//! takes is a benchmark: `cargo bench -p colony-monitor --bench foxglove_scene`.)

use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_foxglove::ARENA_TOPIC;
use colony_monitor::Liveness;
use colony_proto::swarm::{vision, PuckKind, VisionFrame, VisionPuck, VisionRobot};
use colony_proto::{Pose, Vec2};
use colony_testkit::monitor::{monitor_with, with_token};
use colony_testkit::web::{Message, Ws};
use colony_testkit::HubOnThread;

const ROBOTS: u32 = 2000;
const PUCKS: u32 = 20_000;

fn publish(c: &mut UdpClient, step: u64) {
    let frame = VisionFrame {
        step,
        robots: (0..ROBOTS)
            .map(|id| VisionRobot {
                id,
                pose: Pose {
                    x: f64::from(id % 50) * 20.0 + (step % 5) as f64,
                    y: f64::from(id / 50) * 20.0,
                    theta: 0.0,
                },
                carrying: None,
            })
            .collect(),
        pucks: (0..PUCKS)
            .map(|id| VisionPuck {
                id,
                kind: PuckKind((id % 2) as u8),
                pos: Vec2::new(-f64::from(id % 100) * 10.0, f64::from(id / 100) * 10.0),
            })
            .collect(),
        ..VisionFrame::default()
    };
    for p in vision::encode(&frame).unwrap() {
        c.publish(&p).unwrap();
    }
}

/// Robots and pucks in a `foxglove.SceneUpdate` message (`messageData`: op 1, the subscription,
/// the time, then the JSON).
fn counts(message: &[u8]) -> (usize, usize) {
    assert_eq!(message[0], 1, "messageData");
    let v: serde_json::Value = serde_json::from_slice(&message[13..]).unwrap();
    let entity = |id: &str, list: &str| {
        v["entities"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["id"] == id)
            .map_or(0, |e| e[list].as_array().map_or(0, Vec::len))
    };
    (entity("robots", "cubes"), entity("pucks", "cylinders"))
}

#[test]
fn a_slow_viewer_of_a_2000_robot_arena_gets_whole_scenes_and_the_rest_is_counted() {
    let hub = HubOnThread::start();
    // Pings all but off, and a long deadline: the viewer pauses, it is not gone.
    let m = monitor_with(
        &hub,
        Liveness {
            ping_every: Duration::from_secs(3600),
            deadline: Duration::from_secs(60),
        },
    );
    let addr = m.local_addr();
    let mut viewer = Ws::handshake(addr, &with_token(&m, "/foxglove"), &addr.to_string(), None)
        .unwrap_or_else(|head| panic!("{head}"));
    let advertised = viewer.until(Duration::from_secs(10), "the arena's channel", |v| {
        v["op"] == "advertise"
            && v["channels"]
                .as_array()
                .is_some_and(|cs| cs.iter().any(|c| c["topic"] == ARENA_TOPIC))
    });
    let arena = advertised["channels"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["topic"] == ARENA_TOPIC)
        .unwrap()["id"]
        .clone();
    viewer.send(&format!(
        r#"{{"op":"subscribe","subscriptions":[{{"id":7,"channelId":{arena}}}]}}"#
    ));
    let mut world = UdpClient::connect(hub.addr).unwrap();
    // A first whole scene.
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut step = 0;
    'first: loop {
        assert!(Instant::now() < deadline, "no scene of the swarm");
        step += 1;
        publish(&mut world, step);
        let until = Instant::now() + Duration::from_millis(300);
        while Instant::now() < until {
            if let Some(Message::Binary(b)) = viewer.recv_within(Duration::from_millis(100)) {
                if counts(&b) == (ROBOTS as usize, PUCKS as usize) {
                    break 'first;
                }
            }
        }
    }
    // The viewer reads nothing for 3 s while the world goes on at 10 frames a second.
    let paused = Instant::now();
    while paused.elapsed() < Duration::from_secs(3) {
        step += 1;
        publish(&mut world, step);
        std::thread::sleep(Duration::from_millis(100));
    }
    // Then it reads again: every scene it is sent is whole.
    let mut scenes = 0;
    let until = Instant::now() + Duration::from_secs(3);
    while Instant::now() < until {
        if let Some(Message::Binary(b)) = viewer.recv_within(Duration::from_millis(100)) {
            assert_eq!(counts(&b), (ROBOTS as usize, PUCKS as usize));
            scenes += 1;
        }
    }
    assert!(scenes >= 1, "a scene after the pause");
    let (_, dropped) = m.foxglove_viewers();
    let skipped = {
        let mut page = Ws::connect(addr, &with_token(&m, "/ws"));
        page.until(Duration::from_secs(10), "the monitor's counts", |v| {
            v["t"] == "monitor"
        })["foxglove"]["scenes_skipped"]
            .as_u64()
            .unwrap()
    };
    eprintln!("after the pause: {scenes} scenes read, {dropped} messages dropped, {skipped} scenes skipped");
    // 30 frames in 3 s: more than the viewer read or the bridge built, and each one not sent is
    // counted, as dropped for the viewer or as skipped by the bridge's budget.
    assert!(
        dropped + skipped > 0,
        "{scenes} scenes read, {dropped} dropped, {skipped} skipped"
    );
    m.shutdown().unwrap();
}
