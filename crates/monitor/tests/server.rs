//! The monitor's web server on loopback, next to a real hub: it serves its
//! page, script and style from the binary, reports a taken port clearly,
//! joins the hub as an ordinary client, and stops promptly.

use std::io::{Read as _, Write as _};
use std::net::{SocketAddr, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_hub::{HubConfig, Server};
use colony_monitor::{Monitor, MonitorConfig, MonitorError};

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

#[test]
fn the_page_its_script_and_its_style_are_served_from_the_binary() {
    let hub = Hub::start();
    let m = monitor(&hub);
    assert!(m.url().starts_with("http://127.0.0.1:"));
    let page = get(m.local_addr(), "/");
    assert!(page.starts_with("HTTP/1.0 200"), "{page}");
    assert!(page.contains("<title>colony monitor</title>") && page.contains("/app.js"));
    let js = get(m.local_addr(), "/app.js");
    assert!(
        js.contains("text/javascript") && js.contains("window.colony"),
        "{js:.300}"
    );
    let css = get(m.local_addr(), "/style.css");
    assert!(
        css.contains("text/css") && css.contains(".stale-banner"),
        "{css:.300}"
    );
    assert!(get(m.local_addr(), "/nothing-here").starts_with("HTTP/1.0 404"));
    // A plain GET on the WebSocket route is refused, not a crash.
    assert!(!get(m.local_addr(), "/ws").starts_with("HTTP/1.0 200"));
    assert!(m.is_running());
    m.shutdown().unwrap();
}

#[test]
fn a_taken_port_is_a_clear_error() {
    let hub = Hub::start();
    let first = monitor(&hub);
    let taken = first.local_addr().to_string();
    let e = Monitor::start(&MonitorConfig {
        hub: hub.addr.to_string(),
        bind: taken.clone(),
    })
    .err()
    .expect("a second monitor on the same port fails");
    assert!(matches!(e, MonitorError::Bind { .. }), "{e}");
    let text = e.to_string();
    assert!(
        text.contains(&taken) && text.contains("--bind"),
        "the message names the address and the way out: {text}"
    );
    let bad_hub = Monitor::start(&MonitorConfig {
        hub: "not an address".into(),
        bind: "127.0.0.1:0".into(),
    })
    .err()
    .expect("a hub address that does not resolve fails");
    assert!(bad_hub.to_string().contains("not an address"), "{bad_hub}");
}

#[test]
fn the_monitor_joins_the_hub_as_a_client_and_stops_promptly() {
    let hub = Hub::start();
    let m = monitor(&hub);
    // The hub lists the monitor's subscriptions once they arrive.
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut status = String::new();
    while Instant::now() < deadline {
        let mut c = colony_client::UdpClient::connect(hub.addr).unwrap();
        c.subscribe("probe").unwrap();
        let until = Instant::now() + Duration::from_millis(500);
        let mut leased = false;
        while Instant::now() < until {
            let _ = c.wait(Some(Instant::now() + Duration::from_millis(20)));
            while let Ok(Some(r)) = c.recv_reply() {
                match r {
                    colony_wire::Reply::Lease { .. } if !leased => {
                        leased = true;
                        c.request(&[colony_wire::Request::Status]).unwrap();
                    }
                    colony_wire::Reply::Status(s) => {
                        status = format!("{:?}", s.clients);
                    }
                    _ => {}
                }
            }
        }
        if status.contains("vision") && status.contains(colony_monitor::LEASE_CHANNEL) {
            break;
        }
    }
    assert!(
        status.contains("vision") && status.contains("radio") && status.contains("debug"),
        "{status}"
    );
    let t0 = Instant::now();
    m.shutdown().unwrap();
    // Shutdown ends the bridge and the server (it returning at all is the behaviour; the
    // bound only keeps a hang from stalling the suite).
    assert!(t0.elapsed() < Duration::from_secs(60), "{:?}", t0.elapsed());
}
