//! The hub's control requests and replies, in the same format as any packet.
//!
//! Requests go to the reserved subject `<hub>`, one request a line:
//!
//! ```text
//! @ <hub> 0
//! subscribe ch vision_out
//! unsubscribe ch radio
//! unsubscribe_all
//! status
//! min_priority value 5
//! ```
//!
//! A packet that subscribes also carries `cookie v HHHHHHHHHHHHHHHH` (16 hex
//! digits, zeros until the hub has sent one): the hub leases only to an
//! address that proved it receives there, by returning the cookie the hub sent
//! it. The hub answers on `<hub>` too: `cookie v H` to a subscription from an
//! address it does not know yet, `lease ms N` after a subscription, and a
//! [`StatusReport`] after `status`.

use std::fmt;
use std::fmt::Write as _;

use crate::build::write_quoted;
use crate::error::FieldError;
use crate::{Packet, PacketBuilder, Priority, Subject, MAX_PACKET};

/// The shortest lease a hub grants, and a client believes: below it, hub and
/// clients would do little but refresh.
pub const MIN_LEASE_MS: u64 = 100;

/// The reserved subject that carries control requests and the hub's replies.
pub const HUB_SUBJECT: &str = "hub";

/// One control request.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Request {
    /// Take or refresh a lease on a subject.
    Subscribe(Subject),
    /// Drop the lease on a subject.
    Unsubscribe(Subject),
    /// Drop every lease this client holds.
    UnsubscribeAll,
    /// Ask for a [`StatusReport`]; only answered to a client that already holds a lease.
    Status,
    /// Drop every published packet below this priority, on every channel,
    /// for one lease (a console's request; refused from anyone else).
    MinPriority(Priority),
    /// The cookie the hub last sent this address ([`Cookie::NONE`] for none).
    Cookie(Cookie),
    /// Do not send this client the packets it publishes itself, whatever it
    /// subscribes to (MQTT's "no local"): a bridge that both imports and
    /// exports a channel must not hear its imports back. Lasts as long as the
    /// client holds a lease.
    NoLocal,
    /// A few words on what this client is, shown in the status report (at
    /// most [`MAX_ABOUT`] bytes; longer is cut). Lasts as long as the lease.
    About(String),
    /// Send this client every packet the hub forwards, whatever its subjects:
    /// a monitor's or a spy's view of all traffic, new subjects included.
    /// Lasts as long as the client holds a lease; a hub lets only a few
    /// clients tap at once, and few from one host, unless a console asks.
    Tap,
    /// Send this client several packets joined in one datagram of at most
    /// this many bytes ([`batch`](crate::batch) says how they are framed),
    /// where the hub has several for it at once; a packet too long to join
    /// goes alone, as itself. 0 asks for one packet per datagram again. A hub
    /// never holds a packet back to fill a datagram. Lasts as long as the
    /// client holds a lease; only a client that splits batches should ask,
    /// and a hub older than this request refuses the whole packet with it.
    Batch(usize),
}

/// The longest [`Request::About`] a hub keeps, in bytes.
pub const MAX_ABOUT: usize = 240;

/// `text` cut to at most [`MAX_ABOUT`] bytes, on a character boundary.
pub fn clip_about(text: &str) -> &str {
    let mut end = text.len().min(MAX_ABOUT);
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    &text[..end]
}

/// A hub's proof that an address receives what is sent to it: a keyed hash
/// of the address, handed out by the hub and handed back by the client.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Cookie(pub u64);

impl Cookie {
    /// What a client sends before the hub has given it a cookie.
    pub const NONE: Cookie = Cookie(0);

    fn parse(text: &str) -> Option<Cookie> {
        (text.len() == 16 && text.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f')))
            .then(|| u64::from_str_radix(text, 16).ok().map(Cookie))
            .flatten()
    }
}

impl fmt::Display for Cookie {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:016x}", self.0)
    }
}

/// A packet to `<hub>` that is not a well-formed request or reply.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ControlError {
    /// Control packets name `<hub>` and nothing else.
    NotControl,
    /// A line whose label is no known request.
    Unknown {
        /// The label.
        label: String,
        /// 1-based line of the packet.
        line: u32,
    },
    /// A request whose field is missing or of the wrong type.
    Field(FieldError),
    /// A cookie that is not 16 lowercase hex digits.
    BadCookie {
        /// 1-based line of the packet.
        line: u32,
    },
    /// A subscription to a subject that cannot be one (such as `hub` itself).
    BadSubject {
        /// The subject asked for.
        name: String,
        /// 1-based line of the packet.
        line: u32,
    },
}

impl fmt::Display for ControlError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ControlError::NotControl => write!(f, "a control packet must name `<{HUB_SUBJECT}>` alone"),
            ControlError::Unknown { label, line } => write!(
                f,
                "line {line}: unknown request `{label}` (known: subscribe, unsubscribe, unsubscribe_all, status, min_priority, cookie, no_local, about, tap, batch)"
            ),
            ControlError::Field(e) => e.fmt(f),
            ControlError::BadCookie { line } => {
                write!(f, "line {line}: a cookie is 16 lowercase hex digits")
            }
            ControlError::BadSubject { name, line } => {
                write!(f, "line {line}: `{name}` cannot be subscribed to")
            }
        }
    }
}

impl std::error::Error for ControlError {}

impl From<FieldError> for ControlError {
    fn from(e: FieldError) -> Self {
        ControlError::Field(e)
    }
}

fn is_control(p: &Packet<'_>) -> bool {
    p.subject_count() == 1 && p.has_subject(HUB_SUBJECT)
}

/// The error for an integer field whose value is out of the request's
/// range, at the value's own column.
fn out_of_range(line: &crate::Line<'_>, name: &str, v: i64) -> ControlError {
    ControlError::Field(match line.fields().find(|f| f.name == name) {
        Some(f) => line.value_error(
            &f,
            crate::FieldErrorKind::NotAnInteger(f.value.as_str().unwrap_or_default().into_owned()),
        ),
        None => FieldError {
            label: line.label().into(),
            field: name.into(),
            line: line.number(),
            column: 1,
            kind: crate::FieldErrorKind::NotAnInteger(v.to_string()),
        },
    })
}

impl Request {
    /// Whether a packet is addressed to the hub rather than published.
    pub fn is_control(packet: &Packet<'_>) -> bool {
        is_control(packet)
    }

    /// Reads every request of a control packet, in order.
    pub fn parse_all(packet: &Packet<'_>) -> Result<Vec<Request>, ControlError> {
        if !is_control(packet) {
            return Err(ControlError::NotControl);
        }
        packet
            .lines()
            .map(|line| {
                let subject = |line: &crate::Line<'_>| -> Result<Subject, ControlError> {
                    let name = line.str("ch")?;
                    match Subject::new(&name) {
                        Ok(s) if s.as_str() != HUB_SUBJECT => Ok(s),
                        _ => Err(ControlError::BadSubject {
                            name: name.into_owned(),
                            line: line.number(),
                        }),
                    }
                };
                Ok(match line.label() {
                    "subscribe" => Request::Subscribe(subject(&line)?),
                    "unsubscribe" => Request::Unsubscribe(subject(&line)?),
                    "unsubscribe_all" => Request::UnsubscribeAll,
                    "status" => Request::Status,
                    "no_local" => Request::NoLocal,
                    "tap" => Request::Tap,
                    // A request past the largest datagram asks for the largest.
                    "batch" => {
                        let v = line.i64("bytes")?;
                        let v = u64::try_from(v).map_err(|_| out_of_range(&line, "bytes", v))?;
                        Request::Batch(usize::try_from(v).map_or(MAX_PACKET, |b| b.min(MAX_PACKET)))
                    }
                    "about" => Request::About(clip_about(&line.str("text")?).to_owned()),
                    "min_priority" => {
                        let v = line.i64("value")?;
                        let v = i32::try_from(v).map_err(|_| out_of_range(&line, "value", v))?;
                        Request::MinPriority(Priority(v))
                    }
                    "cookie" => Request::Cookie(Cookie::parse(&line.str("v")?).ok_or(
                        ControlError::BadCookie {
                            line: line.number(),
                        },
                    )?),
                    other => {
                        return Err(ControlError::Unknown {
                            label: other.to_owned(),
                            line: line.number(),
                        })
                    }
                })
            })
            .collect()
    }

    /// Writes requests as one control packet.
    pub fn to_packet(requests: &[Request]) -> Vec<u8> {
        let mut text = format!("@ <{HUB_SUBJECT}> 0\n");
        for r in requests {
            match r {
                Request::Subscribe(s) => writeln!(text, "subscribe ch {s}"),
                Request::Unsubscribe(s) => writeln!(text, "unsubscribe ch {s}"),
                Request::UnsubscribeAll => writeln!(text, "unsubscribe_all"),
                Request::Status => writeln!(text, "status"),
                Request::MinPriority(p) => writeln!(text, "min_priority value {p}"),
                Request::Cookie(c) => writeln!(text, "cookie v {c}"),
                Request::NoLocal => writeln!(text, "no_local"),
                Request::Tap => writeln!(text, "tap"),
                Request::Batch(bytes) => writeln!(text, "batch bytes {bytes}"),
                Request::About(about) => {
                    text.push_str("about text ");
                    write_quoted(&mut text, clip_about(about));
                    writeln!(text)
                }
            }
            .expect("writing to a String cannot fail");
        }
        text.into_bytes()
    }
}

/// What the hub says back on `<hub>`.
#[derive(Debug, Clone, PartialEq)]
pub enum Reply {
    /// A subscription was taken; it lasts this long unless refreshed.
    Lease {
        /// The lease, in milliseconds.
        ms: u64,
    },
    /// The answer to a `status` request.
    Status(StatusReport),
    /// The hub does not know this address yet: subscribe again with this cookie.
    Cookie(Cookie),
}

impl Reply {
    /// The lease acknowledgement: as small as the smallest subscribe request
    /// while the lease is under 100 s. (The hub never answers a new address
    /// with more than it sent, so with a longer lease a client subscribing to
    /// a one-character channel gets its first acknowledgement only on its
    /// next refresh.)
    pub fn lease_packet(ms: u64) -> Vec<u8> {
        format!("@ <{HUB_SUBJECT}> 0\nlease ms {ms}\n").into_bytes()
    }

    /// The cookie reply: 36 bytes, never longer than a subscribe request that
    /// carries a cookie line (the hub answers nothing longer than it was sent).
    pub fn cookie_packet(cookie: Cookie) -> Vec<u8> {
        format!("@ <{HUB_SUBJECT}> 0\ncookie v {cookie}\n").into_bytes()
    }

    /// Reads a reply from the hub, or `None` if the packet is not one.
    pub fn parse(packet: &Packet<'_>) -> Option<Result<Reply, ControlError>> {
        if !is_control(packet) {
            return None;
        }
        let first = packet.lines().next()?;
        match first.label() {
            "lease" => Some(
                first
                    .i64("ms")
                    .map(|ms| Reply::Lease {
                        ms: ms.max(0) as u64,
                    })
                    .map_err(Into::into),
            ),
            "status" => Some(StatusReport::from_packet(packet).map(Reply::Status)),
            "cookie" => Some(first.str("v").map_err(Into::into).and_then(|v| {
                Cookie::parse(&v)
                    .map(Reply::Cookie)
                    .ok_or(ControlError::BadCookie {
                        line: first.number(),
                    })
            })),
            _ => None,
        }
    }
}

/// One client the hub knows, with its subscriptions.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ClientInfo {
    /// The client's address, as the hub sees it.
    pub addr: String,
    /// Time since the hub last heard from it.
    pub idle_ms: u64,
    /// Each subscription and the time left on its lease.
    pub subscriptions: Vec<(String, u64)>,
    /// What the client says it is ([`Request::About`]); empty if it said nothing.
    pub about: String,
    /// It taps: it gets every forwarded packet ([`Request::Tap`]).
    pub tap: bool,
    /// The most bytes of joined packets it takes in one datagram
    /// ([`Request::Batch`]; 0: one packet each).
    pub batch: usize,
}

/// Traffic on one channel (or subject set, written `a b`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelInfo {
    /// The channel, or the subjects of a set joined by blanks.
    pub subjects: String,
    /// Packets published on it.
    pub packets: u64,
    /// Bytes published on it.
    pub bytes: u64,
}

/// The hub's answer to `status`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StatusReport {
    /// Time since the hub started.
    pub uptime_ms: u64,
    /// How long a subscription lasts without a refresh.
    pub lease_ms: u64,
    /// Packets below this priority are dropped (`i32::MIN`: none are).
    pub min_priority: Priority,
    /// How many clients the hub holds, even where `clients` was cut short.
    pub client_count: u64,
    /// The clients, as many as fit in one datagram.
    pub clients: Vec<ClientInfo>,
    /// Traffic by channel.
    pub channels: Vec<ChannelInfo>,
    /// Packets dropped, by reason.
    pub drops: Vec<(String, u64)>,
    /// The report was cut to fit one datagram.
    pub truncated: bool,
}

impl StatusReport {
    /// Writes the report as one packet on `<hub>`, cut short (and marked so) if
    /// it would not fit a datagram.
    pub fn to_packet(&self) -> Vec<u8> {
        let mut head = String::new();
        let mut lines: Vec<String> = Vec::new();
        for (reason, count) in &self.drops {
            let mut l = String::from("drop reason ");
            write_quoted(&mut l, reason);
            let _ = write!(l, " count {count}");
            lines.push(l);
        }
        // Clients before channels: a table of channels filled by anyone who
        // publishes must not push out who subscribes to what (a bridge reads it).
        for c in &self.clients {
            let mut l = String::from("client addr ");
            write_quoted(&mut l, &c.addr);
            let _ = write!(l, " idle_ms {} subs (", c.idle_ms);
            for (i, (s, left)) in c.subscriptions.iter().enumerate() {
                let _ = write!(l, "{}{s} {left}", if i > 0 { " " } else { "" });
            }
            l.push(')');
            if c.tap {
                l.push_str(" tap 1");
            }
            if c.batch > 0 {
                let _ = write!(l, " batch {}", c.batch);
            }
            if !c.about.is_empty() {
                l.push_str(" about ");
                write_quoted(&mut l, &c.about);
            }
            lines.push(l);
        }
        for c in &self.channels {
            let mut l = String::from("channel ch ");
            write_quoted(&mut l, &c.subjects);
            let _ = write!(l, " packets {} bytes {}", c.packets, c.bytes);
            lines.push(l);
        }
        let mut truncated = self.truncated;
        let mut head_line = |truncated: bool| {
            head.clear();
            let _ = writeln!(
                head,
                "@ <{HUB_SUBJECT}> 0\nstatus uptime_ms {} lease_ms {} min_priority {} clients {} truncated {}",
                self.uptime_ms, self.lease_ms, self.min_priority, self.client_count, truncated as u8
            );
            head.clone()
        };
        let mut text = head_line(truncated);
        let budget = MAX_PACKET - 16;
        let mut kept = 0;
        for l in &lines {
            if text.len() + l.len() + 1 > budget {
                truncated = true;
                break;
            }
            text.push_str(l);
            text.push('\n');
            kept += 1;
        }
        if truncated && !self.truncated {
            let mut again = head_line(true);
            for l in &lines[..kept] {
                again.push_str(l);
                again.push('\n');
            }
            text = again;
        }
        text.into_bytes()
    }

    /// Reads a report from the hub's `status` packet.
    pub fn from_packet(packet: &Packet<'_>) -> Result<StatusReport, ControlError> {
        let mut r = StatusReport::default();
        for line in packet.lines() {
            match line.label() {
                "status" => {
                    r.uptime_ms = line.i64("uptime_ms")?.max(0) as u64;
                    r.lease_ms = line.i64("lease_ms")?.max(0) as u64;
                    r.min_priority = Priority(
                        line.i64("min_priority")?
                            .clamp(i32::MIN as i64, i32::MAX as i64) as i32,
                    );
                    r.client_count = line.i64("clients")?.max(0) as u64;
                    r.truncated = line.i64("truncated")? != 0;
                }
                "drop" => r.drops.push((
                    line.str("reason")?.into_owned(),
                    line.i64("count")?.max(0) as u64,
                )),
                "channel" => r.channels.push(ChannelInfo {
                    subjects: line.str("ch")?.into_owned(),
                    packets: line.i64("packets")?.max(0) as u64,
                    bytes: line.i64("bytes")?.max(0) as u64,
                }),
                "client" => {
                    let subs = line.group("subs")?;
                    r.clients.push(ClientInfo {
                        addr: line.str("addr")?.into_owned(),
                        idle_ms: line.i64("idle_ms")?.max(0) as u64,
                        subscriptions: subs
                            .fields()
                            .map(|f| {
                                (
                                    f.name.to_owned(),
                                    f.value.as_i64().unwrap_or(0).max(0) as u64,
                                )
                            })
                            .collect(),
                        about: match line.get("about") {
                            Some(_) => clip_about(&line.str("about")?).to_owned(),
                            None => String::new(),
                        },
                        tap: line.get("tap").is_some(),
                        batch: match line.get("batch") {
                            Some(_) => line.i64("batch")?.clamp(0, MAX_PACKET as i64) as usize,
                            None => 0,
                        },
                    })
                }
                _ => {}
            }
        }
        Ok(r)
    }
}

/// Builds the header-only start of a packet on `<hub>` (used by tests and tools).
pub fn hub_packet() -> PacketBuilder {
    PacketBuilder::new([HUB_SUBJECT], Priority(0))
}
