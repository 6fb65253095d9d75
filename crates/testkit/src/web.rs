//! A plain HTTP/1.0 request and just enough of a WebSocket client (RFC
//! 6455) for a test: text frames out (masked, as a client must), text and
//! binary frames in, pings answered.

use std::io::{Read as _, Write as _};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

use serde_json::Value;

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

/// A message from the server: text (JSON) or binary.
pub enum Message {
    Text(Value),
    Binary(Vec<u8>),
}

/// A WebSocket client's connection.
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

    pub fn send_binary(&mut self, bytes: &[u8]) {
        self.frame(0x2, bytes);
    }

    /// Closes the WebSocket as a closed tab does (a close frame, then the connection).
    pub fn close(mut self) {
        self.frame(0x8, &[]);
        let _ = self.stream.shutdown(std::net::Shutdown::Both);
    }

    /// The next text message, as JSON (binary messages, the world's bodies, are skipped).
    pub fn recv(&mut self) -> Value {
        loop {
            if let Message::Text(v) = self.recv_any() {
                return v;
            }
        }
    }

    /// The next message if one starts within `within` (else `None`).
    pub fn recv_within(&mut self, within: Duration) -> Option<Message> {
        self.stream
            .set_read_timeout(Some(within.max(Duration::from_millis(1))))
            .unwrap();
        let started = self.stream.peek(&mut [0u8]);
        self.stream
            .set_read_timeout(Some(Duration::from_secs(5)))
            .unwrap();
        match started {
            Ok(0) => panic!("the server closed the connection"),
            Ok(_) => Some(self.recv_any()),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                None
            }
            Err(e) => panic!("{e}"),
        }
    }

    /// The next message: text as JSON, or binary as its bytes.
    pub fn recv_any(&mut self) -> Message {
        let mut message = Vec::new();
        let mut text = true;
        loop {
            let mut first = [0u8];
            self.stream.read_exact(&mut first).unwrap();
            let (fin, opcode, payload) = self.rest_of_frame(first[0]);
            match opcode {
                0x0..=0x2 => {
                    if opcode != 0x0 {
                        text = opcode == 0x1;
                    }
                    message.extend_from_slice(&payload);
                    if fin {
                        return if text {
                            Message::Text(serde_json::from_slice(&message).unwrap())
                        } else {
                            Message::Binary(message)
                        };
                    }
                }
                _ => self.control(opcode, &payload),
            }
        }
    }

    /// Reads whatever comes for `within`, answering pings as it goes (as a browser does for a
    /// page, whatever its script is doing): the text messages, as JSON. Binary messages are
    /// skipped.
    pub fn pump(&mut self, within: Duration) -> Vec<Value> {
        let end = Instant::now() + within;
        let mut out = Vec::new();
        let mut message: Option<(bool, Vec<u8>)> = None;
        loop {
            let left = end.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            // Only the wait for a frame's first byte may time out, so no frame is cut in two.
            self.stream
                .set_read_timeout(Some(left.max(Duration::from_millis(1))))
                .unwrap();
            let mut first = [0u8];
            let got = self.stream.read(&mut first);
            self.stream
                .set_read_timeout(Some(Duration::from_secs(5)))
                .unwrap();
            match got {
                Ok(0) => panic!("the server closed the connection"),
                Ok(_) => {}
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) =>
                {
                    if message.is_none() {
                        break;
                    }
                    continue;
                }
                Err(e) => panic!("{e}"),
            }
            let (fin, opcode, payload) = self.rest_of_frame(first[0]);
            match opcode {
                0x1 | 0x2 => message = Some((opcode == 0x1, payload)),
                0x0 => {
                    if let Some((_, m)) = message.as_mut() {
                        m.extend_from_slice(&payload);
                    }
                }
                _ => {
                    self.control(opcode, &payload);
                    continue;
                }
            }
            if fin {
                if let Some((true, m)) = message.take() {
                    out.push(serde_json::from_slice(&m).unwrap());
                }
                message = None;
            }
        }
        out
    }

    /// A frame's flag, opcode and payload, its first byte read already.
    fn rest_of_frame(&mut self, first: u8) -> (bool, u8, Vec<u8>) {
        let (fin, opcode) = (first & 0x80 != 0, first & 0x0f);
        let mut b = [0u8];
        self.stream.read_exact(&mut b).unwrap();
        let len = match b[0] & 0x7f {
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
        (fin, opcode, payload)
    }

    /// A control frame: pings are answered, a close is the end of the test's connection.
    fn control(&mut self, opcode: u8, payload: &[u8]) {
        match opcode {
            0x9 => self.frame(0xA, payload),
            0x8 => panic!("the server closed the WebSocket"),
            _ => {}
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
