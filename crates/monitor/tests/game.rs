//! The game page's server side on loopback, next to a real hub: game
//! packets published on the hub reach a WebSocket client as JSON, a squad
//! command sent over the WebSocket is published on `game.player.<team>`
//! exactly as the game reads it, and a bad one is answered with an error and
//! publishes nothing.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_client::UdpClient;

use colony_testkit::monitor::{monitor, with_token};
use colony_testkit::web::{get, Ws};
use colony_testkit::HubOnThread;

/// A client subscribed to `channel`, returned once the hub has granted the lease.
fn subscriber(hub: &HubOnThread, channel: &str) -> UdpClient {
    let mut c = UdpClient::connect(hub.addr).unwrap();
    c.subscribe(channel).unwrap();
    let deadline = Instant::now() + Duration::from_secs(5);
    while Instant::now() < deadline {
        let _ = c.wait(Some(Instant::now() + Duration::from_millis(20)));
        c.poll(Instant::now()).unwrap();
        while let Ok(Some(r)) = c.recv_reply() {
            if matches!(r, colony_wire::Reply::Lease { .. }) {
                return c;
            }
        }
    }
    panic!("no lease for {channel}");
}

/// Every packet `c` receives within `within`, as text.
fn drain(c: &mut UdpClient, within: Duration) -> Vec<String> {
    let deadline = Instant::now() + within;
    let mut out = Vec::new();
    while Instant::now() < deadline {
        let _ = c.wait(Some(
            deadline.min(Instant::now() + Duration::from_millis(20)),
        ));
        c.poll(Instant::now()).unwrap();
        while let Ok(Some(p)) = c.recv() {
            out.push(p.as_str().to_owned());
        }
    }
    out
}

const MAP: &str = "@ <game.map> 0\nmap width 4 height 3 cell 20 part 0 parts 1\nsite team red base_x 10 base_y 10 flag_x 10 flag_y 30\nsite team blue base_x 70 base_y 50 flag_x 70 flag_y 30\nrow y 0 cells \"@..W\"\nrow y 1 cells \".TS.\"\nrow y 2 cells \"G..@\"\n";
const STATE: &str = "@ <game.state> 0\ngame mode ctf status running time 3.2 winner - reason \"\"\nteam name red score 0 kills 0\nteam name blue score 0 kills 0\nflag team red x 10 y 30 home 1\nflag team blue x 70 y 30 home 1\nrobot id 0 team red squad alpha kind tank x 12 y 14 theta 0.5 health 120 alive 1 behaviour hold reason \"no order\"\nrobot id 7 team blue squad alpha kind scout x 68 y 45 theta 3.1 health 40 alive 1 behaviour goto reason \"path\"\nsquad team red name alpha formation line order \"\" behaviour idle path \"12,14 40,30\"\n";
const EVENT: &str =
    "@ <game.event> 0\nevent kind refused time 3.1 text \"squad zulu: no such squad\"\n";

#[test]
fn game_packets_reach_the_game_page_and_its_squad_commands_reach_the_game() {
    let hub = HubOnThread::start();
    let m = monitor(&hub);
    let page = get(m.local_addr(), &with_token(&m, "/game"));
    assert!(
        page.starts_with("HTTP/1.0 200") && page.contains("<title>colony game</title>"),
        "{page:.300}"
    );
    let js = get(m.local_addr(), "/game.js");
    assert!(js.contains("text/javascript") && js.contains("window.colonyGame"));
    assert!(get(m.local_addr(), "/game.css").contains("text/css"));

    let mut ws = Ws::connect(m.local_addr(), &with_token(&m, "/ws?view=game"));
    // The monitor subscribes as it starts: publish until the page has it all.
    let mut publisher = UdpClient::connect(hub.addr).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let feeding = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            while !stop.load(Ordering::Relaxed) {
                for p in [MAP, STATE, EVENT] {
                    publisher.publish(p.as_bytes()).unwrap();
                }
                std::thread::sleep(Duration::from_millis(100));
            }
        })
    };
    let map = ws.until(Duration::from_secs(10), "map", |v| {
        v["t"] == "map" && !v["map"].is_null()
    });
    assert_eq!(
        map["map"]["rows"],
        serde_json::json!(["@..W", ".TS.", "G..@"])
    );
    assert_eq!(map["map"]["cell"], 20.0);
    assert_eq!(
        map["map"]["sites"][1]["flag"],
        serde_json::json!([70.0, 30.0])
    );
    let game = ws.until(Duration::from_secs(10), "game state with events", |v| {
        v["t"] == "game" && !v["state"].is_null() && !v["events"].as_array().unwrap().is_empty()
    });
    let s = &game["state"];
    assert_eq!(s["mode"], "ctf");
    assert_eq!(s["robots"][1]["id"], 7);
    assert_eq!(s["robots"][1]["team"], "blue");
    assert_eq!(
        s["squads"][0]["path"],
        serde_json::json!([[12.0, 14.0], [40.0, 30.0]])
    );
    assert_eq!(game["refusal"]["text"], "squad zulu: no such squad");
    assert_eq!(game["map_version"], 1);
    assert_eq!(game["stale"], false);

    // The same map, published again and again, is sent once; state keeps coming.
    let mut maps = 0;
    for _ in 0..10 {
        if ws.recv()["t"] == "map" {
            maps += 1;
        }
    }
    assert_eq!(maps, 0, "an unchanged map is sent once");
    stop.store(true, Ordering::Relaxed);
    feeding.join().unwrap();

    let mut red = subscriber(&hub, "game.player.red");
    ws.send(
        r#"{"t":"squad","team":"red","squad":"alpha","do":"attack","robot":7,"formation":"wedge"}"#,
    );
    let reply = ws.until(Duration::from_secs(5), "reply", |v| v["t"] == "reply");
    assert_eq!(reply["ok"], true, "{reply}");
    assert_eq!(reply["to"], "squad");
    assert_eq!(reply["msg"], "sent red alpha: attack robot 7 in wedge");
    let got = drain(&mut red, Duration::from_millis(700));
    assert_eq!(
        got,
        ["@ <game.player.red> 0\nsquad name alpha do attack robot 7 formation wedge\n"]
    );

    for (bad, says) in [
        (
            r#"{"t":"squad","team":"red","squad":"alpha","do":"attack","robot":7,"formation":"square"}"#,
            "unknown formation \"square\"",
        ),
        (
            r#"{"t":"squad","team":"red","squad":"alpha","do":"goto","x":5e6,"y":0}"#,
            "within ±",
        ),
        (
            r#"{"t":"squad","team":"red blue","squad":"alpha","do":"stop"}"#,
            "is not a name",
        ),
        (r#"{"t":"squad","team":"red""#, "cannot read the request"),
    ] {
        ws.send(bad);
        let reply = ws.until(Duration::from_secs(5), "reply", |v| v["t"] == "reply");
        assert_eq!(reply["ok"], false, "{bad}: {reply}");
        let msg = reply["msg"].as_str().unwrap();
        assert!(msg.contains(says), "{bad}: {msg}");
    }
    assert!(
        drain(&mut red, Duration::from_millis(700)).is_empty(),
        "a refused command publishes nothing"
    );
    m.shutdown().unwrap();
}

#[test]
fn the_system_monitor_page_gets_no_game_messages() {
    let hub = HubOnThread::start();
    let m = monitor(&hub);
    let mut ws = Ws::connect(m.local_addr(), &with_token(&m, "/ws"));
    let mut publisher = UdpClient::connect(hub.addr).unwrap();
    // Watch for 2 s, and on until the page has had a world at all (a busy machine may be slow
    // to send the first), so that "no game message" is checked over a real stream.
    let window = Instant::now() + Duration::from_secs(2);
    let give_up = Instant::now() + Duration::from_secs(30);
    let mut kinds = std::collections::BTreeSet::new();
    while Instant::now() < window || (!kinds.contains("world") && Instant::now() < give_up) {
        publisher.publish(STATE.as_bytes()).unwrap();
        kinds.insert(ws.recv()["t"].as_str().unwrap_or("?").to_owned());
    }
    assert!(kinds.contains("world"), "{kinds:?}");
    assert!(
        kinds
            .iter()
            .all(|k| k == "world" || k == "hub" || k == "monitor"),
        "{kinds:?}"
    );
    m.shutdown().unwrap();
}
