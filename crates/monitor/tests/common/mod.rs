//! What the monitor's server tests share: a real hub on loopback, a monitor joined to it, a
//! plain HTTP/1.0 GET and just enough of a WebSocket client.

// Each test binary uses part of this.
#![allow(dead_code)]

use std::io::{Read as _, Write as _};
use std::net::{SocketAddr, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_hub::{HubConfig, Server};
use colony_monitor::{Monitor, MonitorConfig};
use serde_json::Value;

pub struct Hub {
    pub addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<std::io::Result<()>>>,
}

impl Hub {
    pub fn start() -> Hub {
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

/// A monitor joined to `hub`, on a free loopback port, needing its token.
pub fn monitor(hub: &Hub) -> Monitor {
    Monitor::start(&MonitorConfig {
        hub: hub.addr.to_string(),
        bind: "127.0.0.1:0".into(),
        ..MonitorConfig::default()
    })
    .unwrap()
}

/// `path` on `m` with its token (`path` may have a query already).
pub fn with_token(m: &Monitor, path: &str) -> String {
    let sep = if path.contains('?') { '&' } else { '?' };
    format!("{path}{sep}token={}", m.token().expect("a token"))
}

/// The whole answer to a request of `head` (everything up to the blank line) sent to `addr`.
pub fn request(addr: SocketAddr, head: &str) -> String {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    s.write_all(head.as_bytes()).unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    out
}

/// `GET path` as a browser at the monitor's own address sends it.
pub fn get(addr: SocketAddr, path: &str) -> String {
    request(
        addr,
        &format!("GET {path} HTTP/1.0\r\nHost: {addr}\r\n\r\n"),
    )
}

/// Just enough of a WebSocket client (RFC 6455) for a test: text frames
/// out (masked, as a client must), text frames in, pings answered.
pub struct Ws {
    stream: TcpStream,
}

impl Ws {
    /// Opens `path` as a page of the monitor's own origin would, or panics.
    pub fn connect(addr: SocketAddr, path: &str) -> Ws {
        let host = addr.to_string();
        let origin = format!("http://{addr}");
        Ws::handshake(addr, path, &host, Some(&origin)).unwrap_or_else(|head| panic!("{head}"))
    }

    /// Asks to open `path` with these `Host` and `Origin` headers: the socket, or the
    /// server's whole answer when it refuses.
    pub fn handshake(
        addr: SocketAddr,
        path: &str,
        host: &str,
        origin: Option<&str>,
    ) -> Result<Ws, String> {
        let mut stream = TcpStream::connect(addr).unwrap();
        stream
            .set_read_timeout(Some(Duration::from_secs(5)))
            .unwrap();
        let origin = origin.map_or(String::new(), |o| format!("Origin: {o}\r\n"));
        write!(
            stream,
            "GET {path} HTTP/1.1\r\nHost: {host}\r\n{origin}Upgrade: websocket\r\nConnection: Upgrade\r\n\
             Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"
        )
        .unwrap();
        let mut head = Vec::new();
        let mut byte = [0u8];
        while !head.ends_with(b"\r\n\r\n") {
            stream.read_exact(&mut byte).unwrap();
            head.push(byte[0]);
        }
        let head = String::from_utf8_lossy(&head).into_owned();
        if head.starts_with("HTTP/1.1 101") {
            Ok(Ws { stream })
        } else {
            // The refusal's body too (the server closes after it, or says how long it is).
            let mut rest = vec![0u8; 4096];
            let n = stream.read(&mut rest).unwrap_or(0);
            Err(head + &String::from_utf8_lossy(&rest[..n]))
        }
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

    pub fn send(&mut self, text: &str) {
        self.frame(0x1, text.as_bytes());
    }

    /// Closes the WebSocket as a closed tab does (a close frame, then the connection).
    pub fn close(mut self) {
        self.frame(0x8, &[]);
        let _ = self.stream.shutdown(std::net::Shutdown::Both);
    }

    /// The next text message, as JSON.
    pub fn recv(&mut self) -> Value {
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
    pub fn until(&mut self, within: Duration, what: &str, want: impl Fn(&Value) -> bool) -> Value {
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
