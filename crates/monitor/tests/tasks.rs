//! The task board's server side on loopback, next to a real hub: MURDOCH
//! messages published on subjects nobody subscribes to (a task's negotiation
//! subject, robots' reports) reach the board through the monitor's tap, and
//! the page gets the task from announced to done with its bids and winner.
//! Each message is sealed by the process it speaks for, as the board takes
//! nothing else; a forged `done` from another key changes nothing.

use std::time::Duration;

use colony_client::UdpClient;
use colony_wire::seal::Identity;
use serde_json::Value;

use colony_testkit::monitor::{monitor, with_token};
use colony_testkit::web::{get, Ws};
use colony_testkit::HubOnThread;

const ANNOUNCE: &str = "@ <camera> <idle> 0\ntask name inspect id 4 negotiation murdoch.user.4.1 deadline_ms 200 length_s 2 announcer user\nmetric name distance weight 1\n";
const BID: &str = "@ <murdoch.user.4.1> 0\nbid task 4 bidder r2 score 12.5\n";
const AWARD: &str = "@ <murdoch.user.4.1> 0\naward task 4 winner r2 score 12.5 bids 1\n";
const DONE: &str = "@ <murdoch.user.4.1> 0\ndone task 4 bidder r2\n";
const REPORT: &str = "@ <murdoch.robots> 0\nrobot name r2 mode working battery 0.7 resources \"camera\" task 4 task_name inspect\n";

/// Publishes `packet` until the board the page gets passes `seen`; that board.
fn until(
    ws: &mut Ws,
    publisher: &mut UdpClient,
    packet: &str,
    what: &str,
    seen: impl Fn(&Value) -> bool,
) -> Value {
    let deadline = std::time::Instant::now() + Duration::from_secs(20);
    while std::time::Instant::now() < deadline {
        publisher.publish(packet.as_bytes()).unwrap();
        let v = ws.recv();
        if v["t"] == "tasks" && seen(&v) {
            return v;
        }
    }
    panic!("the board never showed {what}");
}

#[test]
fn the_board_follows_a_task_from_announced_to_done_on_subjects_nobody_subscribes_to() {
    let hub = HubOnThread::start();
    let m = monitor(&hub);
    let page = get(m.local_addr(), &with_token(&m, "/tasks"));
    assert!(
        page.starts_with("HTTP/1.0 200") && page.contains("<title>colony task board</title>"),
        "{page:.300}"
    );
    assert!(get(m.local_addr(), "/tasks.js").contains("text/javascript"));

    let mut ws = Ws::connect(m.local_addr(), &with_token(&m, "/ws?view=tasks"));
    let mut publisher = UdpClient::connect(hub.addr).unwrap();
    let (mut user, mut r2) = (Identity::generate(), Identity::generate());
    let sealed = |id: &mut Identity, packet: &str| {
        String::from_utf8(id.sealed(packet.as_bytes().to_vec())).unwrap()
    };
    let (announce, award) = (sealed(&mut user, ANNOUNCE), sealed(&mut user, AWARD));
    let (bid, report, done) = (
        sealed(&mut r2, BID),
        sealed(&mut r2, REPORT),
        sealed(&mut r2, DONE),
    );
    let forged_done = sealed(&mut Identity::generate(), DONE);
    let task = |v: &Value| v["tasks"][0].clone();
    let b = until(
        &mut ws,
        &mut publisher,
        &announce,
        "the announcement",
        |v| task(v)["name"] == "inspect",
    );
    assert_eq!(task(&b)["state"], "announced");
    assert_eq!(task(&b)["resources"], serde_json::json!(["camera"]));
    let b = until(&mut ws, &mut publisher, &bid, "the bid", |v| {
        task(v)["bids"].as_array().is_some_and(|a| !a.is_empty())
    });
    assert_eq!(task(&b)["state"], "bidding");
    assert_eq!(task(&b)["bids"][0]["bidder"], "r2");
    assert_eq!(task(&b)["bids"][0]["score"], 12.5);
    until(&mut ws, &mut publisher, &award, "the award", |v| {
        task(v)["winner"]["bidder"] == "r2"
    });
    let b = until(&mut ws, &mut publisher, &report, "the robot", |v| {
        v["robots"][0]["name"] == "r2"
    });
    assert_eq!(b["robots"][0]["mode"], "working");
    assert_eq!(b["robots"][0]["battery"], 0.7);
    // A `done` in r2's name from another key, and an unsealed one, are counted, not taken.
    let b = until(
        &mut ws,
        &mut publisher,
        &forged_done,
        "the forged done counted",
        |v| v["forged"].as_u64().is_some_and(|n| n > 0),
    );
    assert_eq!(task(&b)["state"], "awarded");
    until(
        &mut ws,
        &mut publisher,
        DONE,
        "the unsealed done counted",
        |v| v["forged"].as_u64().is_some_and(|n| n > 1),
    );
    let b = until(&mut ws, &mut publisher, &done, "the end", |v| {
        task(v)["state"] == "done"
    });
    let done = task(&b);
    let timeline: Vec<&str> = done["timeline"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|m| m["text"].as_str())
        .collect();
    assert!(
        timeline.contains(&"awarded to r2: 12.5 is the only bid"),
        "{timeline:?}"
    );
    assert!(timeline.contains(&"r2 finished it"), "{timeline:?}");
    m.shutdown().unwrap();
}
