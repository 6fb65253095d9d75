//! Just enough MQTT 3.1.1 for the benchmark (CONNECT, SUBSCRIBE, PUBLISH at
//! QoS 0), over a std `TcpStream` with `TCP_NODELAY`, and a Mosquitto broker
//! run as a child process with a temporary configuration.

use std::fs::File;
use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{bail, Context};

const CONNECT: u8 = 0x10;
const CONNACK: u8 = 0x20;
const PUBLISH: u8 = 0x30;
const SUBSCRIBE: u8 = 0x82;
const SUBACK: u8 = 0x90;

fn put_remaining_length(out: &mut Vec<u8>, mut len: usize) {
    loop {
        let mut byte = (len % 128) as u8;
        len /= 128;
        if len > 0 {
            byte |= 0x80;
        }
        out.push(byte);
        if len == 0 {
            break;
        }
    }
}

fn put_str(out: &mut Vec<u8>, s: &str) {
    out.extend_from_slice(&(s.len() as u16).to_be_bytes());
    out.extend_from_slice(s.as_bytes());
}

/// Appends one QoS 0 PUBLISH frame.
pub fn put_publish(out: &mut Vec<u8>, topic: &str, payload: &[u8]) {
    out.push(PUBLISH);
    put_remaining_length(out, 2 + topic.len() + payload.len());
    put_str(out, topic);
    out.extend_from_slice(payload);
}

/// A complete frame at the start of `buf`: its first byte, where its body
/// starts and where the frame ends; `None` if more bytes are needed.
pub fn frame(buf: &[u8]) -> Option<(u8, usize, usize)> {
    let first = *buf.first()?;
    let mut len = 0usize;
    let mut shift = 0;
    for (i, &b) in buf.iter().enumerate().skip(1).take(4) {
        len |= usize::from(b & 0x7f) << shift;
        shift += 7;
        if b & 0x80 == 0 {
            let end = i + 1 + len;
            return (buf.len() >= end).then_some((first, i + 1, end));
        }
    }
    None
}

/// The application payload of a QoS 0 PUBLISH body.
pub fn publish_payload(body: &[u8]) -> &[u8] {
    if body.len() < 2 {
        return &[];
    }
    let topic = usize::from(u16::from_be_bytes([body[0], body[1]]));
    body.get(2 + topic..).unwrap_or(&[])
}

/// One MQTT connection with a receive buffer that keeps partial frames.
pub struct Conn {
    pub stream: TcpStream,
    buf: Vec<u8>,
    start: usize,
    end: usize,
}

impl Conn {
    /// Connects with a clean session and no keep-alive, and waits for CONNACK.
    pub fn connect(addr: SocketAddr, client_id: &str) -> anyhow::Result<Conn> {
        let stream = TcpStream::connect(addr).with_context(|| format!("connecting to {addr}"))?;
        stream.set_nodelay(true)?;
        stream.set_read_timeout(Some(Duration::from_secs(5)))?;
        let mut conn = Conn {
            stream,
            buf: vec![0; 256 * 1024],
            start: 0,
            end: 0,
        };
        let mut body = Vec::new();
        put_str(&mut body, "MQTT");
        body.push(4); // protocol level 3.1.1
        body.push(0x02); // clean session
        body.extend_from_slice(&0u16.to_be_bytes()); // keep-alive off
        put_str(&mut body, client_id);
        let mut msg = vec![CONNECT];
        put_remaining_length(&mut msg, body.len());
        msg.extend_from_slice(&body);
        conn.stream.write_all(&msg)?;
        let (kind, body) = conn.next_frame()?;
        if kind != CONNACK || body.len() != 2 || body[1] != 0 {
            bail!("broker refused the connection (frame {kind:#x}, body {body:?})");
        }
        Ok(conn)
    }

    /// Subscribes at QoS 0 and waits for SUBACK.
    pub fn subscribe(&mut self, topic: &str) -> anyhow::Result<()> {
        let mut body = Vec::new();
        body.extend_from_slice(&1u16.to_be_bytes()); // packet id
        put_str(&mut body, topic);
        body.push(0); // QoS 0
        let mut msg = vec![SUBSCRIBE];
        put_remaining_length(&mut msg, body.len());
        msg.extend_from_slice(&body);
        self.stream.write_all(&msg)?;
        let (kind, body) = self.next_frame()?;
        if kind != SUBACK || body.len() != 3 || body[2] == 0x80 {
            bail!("broker refused the subscription (frame {kind:#x}, body {body:?})");
        }
        Ok(())
    }

    /// Blocks (up to the read timeout) for the next whole frame.
    pub fn next_frame(&mut self) -> io::Result<(u8, Vec<u8>)> {
        loop {
            if let Some((kind, body, end)) = frame(&self.buf[self.start..self.end]) {
                let out = (kind, self.buf[self.start + body..self.start + end].to_vec());
                self.start += end;
                return Ok(out);
            }
            if self.fill()? == 0 {
                return Err(io::Error::new(
                    io::ErrorKind::UnexpectedEof,
                    "broker closed the connection",
                ));
            }
        }
    }

    /// Calls `f` with the payload of every QoS 0 PUBLISH now buffered, then
    /// keeps any partial frame for later.
    pub fn each_publish(&mut self, mut f: impl FnMut(&[u8])) {
        while let Some((kind, body, end)) = frame(&self.buf[self.start..self.end]) {
            if kind & 0xf0 == PUBLISH {
                f(publish_payload(
                    &self.buf[self.start + body..self.start + end],
                ));
            }
            self.start += end;
        }
    }

    /// Reads once (blocking or not, as the stream is set) into the buffer.
    pub fn fill(&mut self) -> io::Result<usize> {
        if self.start == self.end {
            self.start = 0;
            self.end = 0;
        } else if self.buf.len() - self.end < 64 * 1024 {
            self.buf.copy_within(self.start..self.end, 0);
            self.end -= self.start;
            self.start = 0;
        }
        let n = self.stream.read(&mut self.buf[self.end..])?;
        self.end += n;
        Ok(n)
    }
}

/// A Mosquitto broker on a loopback port, stopped when dropped.
pub struct Mosquitto {
    child: Child,
    dir: PathBuf,
    pub addr: SocketAddr,
    pub version: String,
}

impl Mosquitto {
    pub fn start(program: &Path, nodelay: bool) -> anyhow::Result<Mosquitto> {
        let version = Command::new(program)
            .arg("-h")
            .output()
            .ok()
            .and_then(|o| {
                String::from_utf8_lossy(&o.stdout)
                    .lines()
                    .next()
                    .map(|l| l.trim().to_owned())
            })
            .filter(|l| l.contains("mosquitto"))
            .with_context(|| {
                format!(
                    "`{}` does not run as mosquitto (apt-get install mosquitto)",
                    program.display()
                )
            })?;
        let port = TcpListener::bind("127.0.0.1:0")?.local_addr()?.port();
        let dir = std::env::temp_dir().join(format!(
            "colony-bench-mosquitto-{}-{port}",
            std::process::id()
        ));
        std::fs::create_dir_all(&dir)?;
        let conf = dir.join("mosquitto.conf");
        // Nothing persisted, only errors logged; `nodelay` turns Nagle off on
        // the broker's side (better latency, more segments). Run as root, it
        // would drop to the `mosquitto` user, and that would clear the
        // parent-death signal set below; it listens on loopback only, briefly.
        let user = if colony_sys::process::is_root() {
            "user root\n"
        } else {
            ""
        };
        std::fs::write(
            &conf,
            format!(
                "listener {port} 127.0.0.1\nallow_anonymous true\nset_tcp_nodelay {nodelay}\n\
                 persistence false\nlog_dest stderr\nlog_type error\nlog_type warning\n{user}"
            ),
        )?;
        let log_path = dir.join("stderr.log");
        let log = File::create(&log_path)?;
        let mut command = Command::new(program);
        // The broker dies with the benchmark, however the benchmark ends.
        colony_sys::process::die_with_parent(&mut command, libc::SIGTERM);
        let child = command
            .arg("-c")
            .arg(&conf)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::from(log))
            .spawn()
            .with_context(|| format!("starting {}", program.display()))?;
        let addr: SocketAddr = ([127, 0, 0, 1], port).into();
        let mut broker = Mosquitto {
            child,
            dir,
            addr,
            version,
        };
        let deadline = Instant::now() + Duration::from_secs(5);
        loop {
            if TcpStream::connect(addr).is_ok() {
                return Ok(broker);
            }
            if let Some(status) = broker.child.try_wait()? {
                let log = std::fs::read_to_string(&log_path).unwrap_or_default();
                bail!("mosquitto exited at start ({status}): {log}");
            }
            if Instant::now() > deadline {
                let log = std::fs::read_to_string(&log_path).unwrap_or_default();
                bail!("mosquitto did not listen on {addr} within 5 s: {log}");
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }
}

impl Drop for Mosquitto {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn remaining_length_round_trips() {
        for len in [0usize, 1, 127, 128, 16_383, 16_384, 2_097_151] {
            let mut out = vec![PUBLISH];
            put_remaining_length(&mut out, len);
            out.resize(out.len() + len, 0);
            let (kind, body, end) = frame(&out).unwrap();
            assert_eq!((kind, end - body), (PUBLISH, len));
            assert!(frame(&out[..out.len() - 1]).is_none());
        }
    }

    #[test]
    fn publish_frame_carries_the_payload() {
        let mut out = Vec::new();
        put_publish(&mut out, "bench", b"hello");
        let (kind, body, end) = frame(&out).unwrap();
        assert_eq!(kind, PUBLISH);
        assert_eq!(publish_payload(&out[body..end]), b"hello");
    }
}
