//! The game page's server side on loopback, next to a real hub: game
//! packets published on the hub reach a WebSocket client as JSON, a squad
//! command sent over the WebSocket is published on `game.player.<team>`
//! exactly as the game reads it, and a bad one is answered with an error and
//! publishes nothing.

use std::io::{Read as _, Write as _};
use std::net::{SocketAddr, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_hub::{HubConfig, Server};
use colony_monitor::{Monitor, MonitorConfig};
use serde_json::Value;

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

/// Just enough of a WebSocket client (RFC 6455) for a test: text frames
/// out (masked, as a client must), text frames in, pings answered.
struct Ws {
    stream: TcpStream,
}

impl Ws {
    fn connect(addr: SocketAddr, path: &str) -> Ws {
        let mut stream = TcpStream::connect(addr).unwrap();
        stream
            .set_read_timeout(Some(Duration::from_secs(5)))
            .unwrap();
        write!(
            stream,
            "GET {path} HTTP/1.1\r\nHost: {addr}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n\
             Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"
        )
        .unwrap();
        let mut head = Vec::new();
        let mut byte = [0u8];
        while !head.ends_with(b"\r\n\r\n") {
            stream.read_exact(&mut byte).unwrap();
            head.push(byte[0]);
        }
        let head = String::from_utf8_lossy(&head);
        assert!(head.starts_with("HTTP/1.1 101"), "{head}");
        Ws { stream }
    }

    fn frame(&mut self, opcode: u8, payload: &[u8]) {
        let mut f = vec![0x80 | opcode];
        match payload.len() {
            n if n < 126 => f.push(0x80 | n as u8),
            n if n < 65536 => {
                f.push(0x80 | 126);
                f.extend_from_slice(&(n as u16).to_be_bytes());
            }
            n => {
                f.push(0x80 | 127);
                f.extend_from_slice(&(n as u64).to_be_bytes());
            }
        }
        let mask = [0x37, 0xfa, 0x21, 0x3d];
        f.extend_from_slice(&mask);
        f.extend(payload.iter().enumerate().map(|(i, b)| b ^ mask[i % 4]));
        self.stream.write_all(&f).unwrap();
    }

    fn send(&mut self, text: &str) {
        self.frame(0x1, text.as_bytes());
    }

    /// The next text message, as JSON.
    fn recv(&mut self) -> Value {
        let mut message = Vec::new();
        loop {
            let mut h = [0u8; 2];
            self.stream.read_exact(&mut h).unwrap();
            let (fin, opcode) = (h[0] & 0x80 != 0, h[0] & 0x0f);
            let len = match h[1] & 0x7f {
                126 => {
                    let mut b = [0u8; 2];
                    self.stream.read_exact(&mut b).unwrap();
                    u16::from_be_bytes(b) as usize
                }
                127 => {
                    let mut b = [0u8; 8];
                    self.stream.read_exact(&mut b).unwrap();
                    u64::from_be_bytes(b) as usize
                }
                n => n as usize,
            };
            let mut payload = vec![0u8; len];
            self.stream.read_exact(&mut payload).unwrap();
            match opcode {
                0x9 => self.frame(0xA, &payload),
                0x8 => panic!("the server closed the WebSocket"),
                0x0..=0x2 => {
                    message.extend_from_slice(&payload);
                    if fin {
                        return serde_json::from_slice(&message).unwrap();
                    }
                }
                _ => {}
            }
        }
    }

    /// Reads messages until one satisfies `want`, for at most `within`.
    fn until(&mut self, within: Duration, what: &str, want: impl Fn(&Value) -> bool) -> Value {
        let deadline = Instant::now() + within;
        let mut last = Value::Null;
        while Instant::now() < deadline {
            let m = self.recv();
            if want(&m) {
                return m;
            }
            last = m;
        }
        panic!("no {what} within {within:?}; the last message: {last}");
    }
}

fn get(addr: SocketAddr, path: &str) -> String {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    write!(s, "GET {path} HTTP/1.0\r\nHost: {addr}\r\n\r\n").unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    out
}

fn monitor(hub: &Hub) -> Monitor {
    Monitor::start(&MonitorConfig {
        hub: hub.addr.to_string(),
        bind: "127.0.0.1:0".into(),
    })
    .unwrap()
}

/// A client subscribed to `channel`, returned once the hub has granted the lease.
fn subscriber(hub: &Hub, channel: &str) -> UdpClient {
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
    let hub = Hub::start();
    let m = monitor(&hub);
    let page = get(m.local_addr(), "/game");
    assert!(
        page.starts_with("HTTP/1.0 200") && page.contains("<title>colony game</title>"),
        "{page:.300}"
    );
    let js = get(m.local_addr(), "/game.js");
    assert!(js.contains("text/javascript") && js.contains("window.colonyGame"));
    assert!(get(m.local_addr(), "/game.css").contains("text/css"));

    let mut ws = Ws::connect(m.local_addr(), "/ws?view=game");
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
    let hub = Hub::start();
    let m = monitor(&hub);
    let mut ws = Ws::connect(m.local_addr(), "/ws");
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
        kinds.iter().all(|k| k == "world" || k == "hub"),
        "{kinds:?}"
    );
    m.shutdown().unwrap();
}
