//! The monitor with a big swarm over real sockets: a world of 2,000 robots and 20,000 pucks is
//! published on `vision` split into datagrams, each under the UDP limit, through a real hub; the
//! page gets whole frames only (every robot and puck in its binary bodies message), and a frame
//! that lost a part is never shown, only counted. What it costs in time is a benchmark
//! (scripts/bench-monitor-swarm), not asserted here.

use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_monitor::state::bodies;
use colony_proto::swarm::{vision, PuckKind, VisionFrame, VisionPuck, VisionRobot};
use colony_proto::{Pose, Vec2};
use colony_testkit::monitor::{monitor, with_token};
use colony_testkit::web::{Message, Ws};
use colony_testkit::HubOnThread;
use serde_json::Value;

const ROBOTS: u32 = 2000;
const PUCKS: u32 = 20_000;

/// The world at `step`: every robot and puck somewhere that depends on the step.
fn frame(step: u64) -> VisionFrame {
    let wobble = (step % 10) as f64;
    VisionFrame {
        step,
        robots: (0..ROBOTS)
            .map(|id| VisionRobot {
                id,
                pose: Pose {
                    x: (id % 50) as f64 * 20.0 + wobble,
                    y: (id / 50) as f64 * 20.0,
                    theta: 0.5,
                },
                carrying: (id % 7 == 0).then_some(id),
            })
            .collect(),
        pucks: (0..PUCKS)
            .map(|id| VisionPuck {
                id,
                kind: PuckKind((id % 3) as u8),
                pos: Vec2::new(
                    -((id % 100) as f64) * 10.0,
                    (id / 100) as f64 * 10.0 - wobble,
                ),
            })
            .collect(),
        ..VisionFrame::default()
    }
}

/// Publishes `step`'s frame, leaving out part `skip`; returns how many parts it had.
fn publish(c: &mut UdpClient, step: u64, skip: Option<usize>) -> usize {
    let parts = vision::encode(&frame(step)).unwrap();
    for (i, p) in parts.iter().enumerate() {
        assert!(p.len() <= colony_wire::MAX_PACKET, "{} bytes", p.len());
        if Some(i) != skip {
            c.publish(p).unwrap();
        }
    }
    parts.len()
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

fn f32_at(b: &[u8], at: usize) -> f32 {
    f32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

#[test]
fn a_swarm_of_2000_robots_reaches_the_page_in_whole_frames_and_a_lost_part_is_counted() {
    let hub = HubOnThread::start();
    let m = monitor(&hub);
    let mut ws = Ws::connect(m.local_addr(), &with_token(&m, "/ws"));
    let mut world = UdpClient::connect(hub.addr).unwrap();
    // Until the monitor has joined the hub, frames go nowhere: publish until one is whole.
    let mut step = 0;
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut whole: Vec<(u64, Vec<u8>)> = Vec::new();
    let mut last_json = Value::Null;
    while whole.len() < 3 {
        assert!(
            Instant::now() < deadline,
            "{} whole frames; the last snapshot: {last_json}",
            whole.len()
        );
        step += 1;
        let parts = publish(&mut world, step, None);
        assert!(
            parts > 10,
            "a 2,000-robot frame takes many datagrams: {parts}"
        );
        // Read what the page gets until its snapshot after this frame.
        let until = Instant::now() + Duration::from_millis(300);
        let mut pending: Option<Vec<u8>> = None;
        while Instant::now() < until {
            match ws.recv_any() {
                Message::Binary(b) => pending = Some(b),
                Message::Text(v) if v["t"] == "world" => {
                    if let Some(b) = pending.take() {
                        // Bodies come just before the snapshot of the same frame.
                        assert_eq!(v["nrobots"], ROBOTS, "{v}");
                        assert_eq!(v["npucks"], PUCKS);
                        assert_eq!(v["robots"], serde_json::json!([]), "too many for JSON");
                        whole.push((v["step"].as_u64().unwrap(), b));
                    }
                    last_json = v;
                }
                Message::Text(_) => {}
            }
        }
    }
    for (step, b) in &whole {
        let (n, k) = (ROBOTS as usize, PUCKS as usize);
        assert_eq!(b.len(), bodies::HEADER + 20 * n + 13 * k, "every body in");
        assert_eq!((u32_at(b, 4), u32_at(b, 8)), (ROBOTS, PUCKS));
        assert_eq!(
            f64::from_le_bytes(b[16..24].try_into().unwrap()),
            *step as f64
        );
        let sent = frame(*step);
        let poses = bodies::HEADER;
        for id in [0, 1, 777, ROBOTS as usize - 1] {
            let r = &sent.robots[id];
            assert_eq!(
                f32_at(b, poses + 12 * id),
                r.pose.x as f32,
                "robot {id} of step {step}"
            );
            assert_eq!(f32_at(b, poses + 12 * id + 4), r.pose.y as f32);
            assert_eq!(u32_at(b, poses + 12 * n + 4 * id), id as u32);
        }
        let carrying = poses + 16 * n;
        assert_eq!(
            (u32_at(b, carrying), u32_at(b, carrying + 4)),
            (0, bodies::NONE)
        );
        let puck_pos = carrying + 4 * n;
        let p = &sent.pucks[PUCKS as usize - 1];
        assert_eq!(f32_at(b, puck_pos + 8 * (k - 1) + 4), p.pos.y as f32);
        assert_eq!(b[b.len() - 1], p.kind.0, "the last puck's kind ends it");
    }

    // A frame that loses a part is dropped whole, and counted on the page.
    let before = last_json["frames_missing"].as_u64().unwrap();
    let lost = step + 1;
    publish(&mut world, lost, Some(3));
    let next = lost + 1;
    publish(&mut world, next, None);
    let shown = ws.until(
        Duration::from_secs(20),
        "the frame after the lost one",
        |v| v["t"] == "world" && v["step"].as_u64().is_some_and(|s| s >= next),
    );
    assert_eq!(shown["nrobots"], ROBOTS);
    assert!(
        shown["frames_missing"].as_u64().unwrap() > before,
        "the frame with a lost part is counted: {shown}"
    );
    m.shutdown().unwrap();
}
