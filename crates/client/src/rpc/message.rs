//! How services, calls and answers are written: the one definition both
//! clients (Rust here, Python in `python/colony_client.py`) follow.
//!
//! A service `S` has a channel, `svc.S`, and each of its providers an inbox,
//! `svc.S.P` (`P` the provider's id); a caller `C` has an inbox `reply.C`.
//!
//! ```text
//! @ <svc.echo> 0                      a provider exists, for this long unless renewed
//! provider id 8f1c0a2b3c4d5e6f lease_ms 3000
//!
//! @ <svc.echo> 0                      a caller asks who provides (answered at once)
//! who
//!
//! @ <svc.echo.8f1c0a2b3c4d5e6f> 0     a call: its id and where to answer, then its lines
//! call id 00000000a1b2c3d4 reply_to reply.77e0c1d2e3f40516
//! text value "hello"
//!
//! @ <reply.77e0c1d2e3f40516> 0        the answer, with the call's id and its provider
//! reply id 00000000a1b2c3d4 from 8f1c0a2b3c4d5e6f
//! text value "hello"
//! ```
//!
//! A provider that stops cleanly says `leaving id P` on the service channel;
//! one that cannot serve a call answers `refused id N from P text "why"`.

use std::fmt;
use std::time::Duration;

use colony_wire::{
    Line, Packet, PacketBuilder, ParseError, Priority, Subject, Value, MAX_SUBJECT_LEN,
};

use super::RpcError;

/// What a service's channel name starts with.
pub const SERVICE_PREFIX: &str = "svc.";
/// What a caller's inbox name starts with; a call may name no other place
/// for its answer, so a forged call cannot make a provider publish on `radio`.
pub const REPLY_PREFIX: &str = "reply.";
/// Hex digits of an [`Id`].
const ID_DIGITS: usize = 16;
/// The longest service name: room in one subject for the prefix, a dot and a provider id.
pub const MAX_SERVICE_LEN: usize = MAX_SUBJECT_LEN - SERVICE_PREFIX.len() - 1 - ID_DIGITS;

/// A provider's, a caller's or a call's identity: 16 hex digits on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Id(pub u64);

impl Id {
    /// Reads 16 lowercase hex digits.
    pub fn parse(text: &str) -> Option<Id> {
        (text.len() == ID_DIGITS && text.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f')))
            .then(|| u64::from_str_radix(text, 16).ok().map(Id))
            .flatten()
    }

    /// An id no other process is likely to draw: std's per-process random
    /// hash keys, mixed with the clock, so no random-number crate is needed.
    pub fn fresh() -> Id {
        use std::hash::{BuildHasher, Hasher};
        let mut h = std::collections::hash_map::RandomState::new().build_hasher();
        h.write_u128(
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos()),
        );
        h.write_u32(std::process::id());
        Id(h.finish())
    }
}

impl fmt::Display for Id {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:016x}", self.0)
    }
}

/// A service's name and the subjects it gives rise to.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Service {
    name: Box<str>,
    channel: Subject,
}

impl Service {
    /// A service called `name`: subject characters only, 1 to [`MAX_SERVICE_LEN`]
    /// bytes, and not ending in `.` and 16 hex digits (a provider inbox's shape).
    pub fn new(name: &str) -> Result<Service, RpcError> {
        let bad = || RpcError::BadService(name.to_owned());
        // A name ending in `.` and an id would make this service's channel
        // another service's provider inbox.
        let looks_like_inbox = name
            .rsplit_once('.')
            .is_some_and(|(_, last)| Id::parse(last).is_some());
        if name.is_empty() || name.len() > MAX_SERVICE_LEN || looks_like_inbox {
            return Err(bad());
        }
        let channel = Subject::new(&format!("{SERVICE_PREFIX}{name}")).map_err(|_| bad())?;
        Ok(Service {
            name: name.into(),
            channel,
        })
    }

    /// The name it was made with.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Where providers announce themselves and callers ask who provides.
    pub fn channel(&self) -> &Subject {
        &self.channel
    }

    /// Where the provider `id` takes its calls.
    pub fn inbox(&self, id: Id) -> Subject {
        Subject::new(&format!("{}.{id}", self.channel.as_str()))
            .expect("a valid service name leaves room for a provider id")
    }
}

/// A caller's inbox, where its answers come.
pub fn reply_inbox(caller: Id) -> Subject {
    Subject::new(&format!("{REPLY_PREFIX}{caller}")).expect("prefix and id are subject characters")
}

/// What is said on a service's channel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Notice {
    /// A provider exists, and will say so again within its lease.
    Provider {
        /// Its id, and so its inbox.
        id: Id,
        /// How long to believe it without hearing from it again.
        lease: Duration,
    },
    /// A provider stopped; calls still waiting on it will not be answered.
    Leaving {
        /// Its id.
        id: Id,
    },
    /// A caller asks every provider to announce itself now.
    Who,
}

impl Notice {
    /// The notice as a packet on `service`'s channel.
    pub fn to_packet(&self, service: &Service) -> Vec<u8> {
        let mut b = PacketBuilder::new([service.channel()], Priority(0));
        match self {
            Notice::Provider { id, lease } => {
                let ms = u64::try_from(lease.as_millis()).unwrap_or(u64::MAX);
                b.line("provider")
                    .bare("id", &id.to_string())
                    .field("lease_ms", ms);
            }
            Notice::Leaving { id } => {
                b.line("leaving").bare("id", &id.to_string());
            }
            Notice::Who => {
                b.line("who");
            }
        }
        b.finish().expect("notices are built from valid parts")
    }

    /// The notice a packet on a service channel holds, if it is one (its first line decides).
    pub fn read(packet: &Packet<'_>) -> Option<Notice> {
        let line = packet.lines().next()?;
        match line.label() {
            "provider" => {
                let ms = u64::try_from(line.i64("lease_ms").ok()?).ok()?;
                Some(Notice::Provider {
                    id: id_field(&line, "id")?,
                    lease: Duration::from_millis(ms),
                })
            }
            "leaving" => Some(Notice::Leaving {
                id: id_field(&line, "id")?,
            }),
            "who" => Some(Notice::Who),
            _ => None,
        }
    }
}

/// A bare token, as written: ids and inboxes are never quoted, so both
/// clients read exactly the same packets as valid.
fn bare<'a>(line: &Line<'a>, name: &str) -> Option<&'a str> {
    match line.get(name)? {
        Value::Bare(token) => Some(token),
        _ => None,
    }
}

fn id_field(line: &Line<'_>, name: &str) -> Option<Id> {
    Id::parse(bare(line, name)?)
}

/// The first line of a call: which call, and where its answer goes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CallHeader {
    /// The call's id, unique per caller.
    pub id: Id,
    /// The caller's inbox (always a [`REPLY_PREFIX`] subject).
    pub reply_to: Subject,
}

impl CallHeader {
    /// A call to the provider inbox `to`: this header, then the caller's `lines`.
    pub fn to_packet(
        &self,
        to: &Subject,
        priority: Priority,
        lines: &[String],
    ) -> Result<Vec<u8>, ParseError> {
        let mut b = PacketBuilder::new([to], priority);
        b.line("call")
            .bare("id", &self.id.to_string())
            .bare("reply_to", self.reply_to.as_str());
        for l in lines {
            b.raw_line(l);
        }
        b.finish()
    }

    /// The header of a call packet, if its first line is one with a reply inbox.
    pub fn read(packet: &Packet<'_>) -> Option<CallHeader> {
        let line = packet.lines().next()?;
        if line.label() != "call" {
            return None;
        }
        let inbox = bare(&line, "reply_to").filter(|t| t.starts_with(REPLY_PREFIX))?;
        Some(CallHeader {
            id: id_field(&line, "id")?,
            reply_to: Subject::new(inbox).ok()?,
        })
    }
}

/// The first line of an answer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AnswerHeader {
    /// The call answered.
    pub id: Id,
    /// The provider that answered.
    pub from: Id,
    /// Why the provider could not serve the call, if it could not.
    pub refused: Option<String>,
}

impl AnswerHeader {
    /// The answer as a packet to the caller's inbox, with the provider's `lines`
    /// (a refusal carries none).
    pub fn to_packet(
        &self,
        to: &Subject,
        priority: Priority,
        lines: &[String],
    ) -> Result<Vec<u8>, ParseError> {
        let mut b = PacketBuilder::new([to], priority);
        match &self.refused {
            None => {
                b.line("reply")
                    .bare("id", &self.id.to_string())
                    .bare("from", &self.from.to_string());
                for l in lines {
                    b.raw_line(l);
                }
            }
            Some(why) => {
                b.line("refused")
                    .bare("id", &self.id.to_string())
                    .bare("from", &self.from.to_string())
                    .field("text", why.as_str());
            }
        }
        b.finish()
    }

    /// The header of an answer packet, if its first line is one.
    pub fn read(packet: &Packet<'_>) -> Option<AnswerHeader> {
        let line = packet.lines().next()?;
        let refused = match line.label() {
            "reply" => None,
            // A bare reason as written, a quoted one unescaped; a group is no reason.
            "refused" => Some(match line.get("text")? {
                Value::Bare(token) => token.to_owned(),
                Value::Quoted(q) => q.unescape().into_owned(),
                Value::Group(_) => return None,
            }),
            _ => return None,
        };
        Some(AnswerHeader {
            id: id_field(&line, "id")?,
            from: id_field(&line, "from")?,
            refused,
        })
    }
}

/// The lines of a call or answer after its first, as written.
pub fn body_lines(packet: &Packet<'_>) -> Vec<String> {
    packet
        .lines()
        .skip(1)
        .map(|l| l.as_str().to_owned())
        .collect()
}
