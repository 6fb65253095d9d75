//! How services, calls and answers are written: the one definition both
//! clients (Rust here, Python in `python/colony_client.py`) follow.
//!
//! A service `S` has a channel, `svc.S`, and each of its providers an inbox,
//! `svc.S.P` (`P` the provider's id); a caller `C` has an inbox `reply.C`.
//!
//! ```text
//! @ <svc.echo> 0                      a caller asks who provides, with a fresh nonce
//! who nonce 5b0e9d2c41f7a386
//!
//! @ <svc.echo> 0                      a provider exists (echoing the nonce it answers)
//! provider id 8f1c0a2b3c4d5e6f lease_ms 3000 nonce 5b0e9d2c41f7a386
//! seal n 7 key 3d40…(64 hex digits) sig 9f51…(128 hex digits)
//!
//! @ <svc.echo.8f1c0a2b3c4d5e6f> 0     a call: its id and where to answer, then its lines
//! call id 00000000a1b2c3d4 reply_to reply.77e0c1d2e3f40516
//! text value "hello"
//!
//! @ <reply.77e0c1d2e3f40516> 0        the provider took the call
//! accepted id 00000000a1b2c3d4 from 8f1c0a2b3c4d5e6f
//! seal n 8 key 3d40… sig 51c2…
//!
//! @ <reply.77e0c1d2e3f40516> 0        the answer, with the call's id and its provider
//! reply id 00000000a1b2c3d4 from 8f1c0a2b3c4d5e6f
//! text value "hello"
//! seal n 9 key 3d40… sig 0a7e…
//! ```
//!
//! A provider that stops cleanly says `leaving id P` on the service channel;
//! one that cannot serve a call answers `refused id N from P text "why"`.
//!
//! Everything a provider says is sealed ([`colony_wire::seal`]) by a key it
//! made for itself, and its id `P` is that key's fingerprint: a caller takes
//! a provider's word only through [`proven`], so nobody else can announce,
//! leave, accept or answer as `P`. Calls and `who` are not sealed: callers
//! are anonymous, and their answers go to their own inbox.

use std::fmt;
use std::time::Duration;

use colony_wire::seal::{self, PublicKey};
use colony_wire::{
    ErrorKind, Line, Packet, PacketBuilder, ParseError, Priority, Subject, Value, MAX_PACKET,
    MAX_SUBJECT_LEN,
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

/// Room a provider's packet leaves for what is added after it is built: the
/// longest seal line and the longest `auth` line a hub key adds, so a sealed
/// answer still fits one datagram.
const SEALED_ROOM: usize = colony_wire::seal::MAX_LINE + colony_wire::auth::MAX_LINE;

/// A provider's, a caller's or a call's identity, or a `who` nonce: 16 hex
/// digits on the wire. A provider's id is its key's fingerprint.
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

impl From<PublicKey> for Id {
    fn from(key: PublicKey) -> Id {
        Id(key.fingerprint())
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
        /// The `who` it answers, if it answers one: proof it is alive now.
        nonce: Option<Id>,
    },
    /// A provider stopped; calls still waiting on it will not be answered.
    Leaving {
        /// Its id.
        id: Id,
    },
    /// A caller asks every provider to announce itself now.
    Who {
        /// Fresh per question, so an echo cannot have been recorded earlier.
        nonce: Option<Id>,
    },
}

impl Notice {
    /// The notice as a packet on `service`'s channel (unsealed).
    pub fn to_packet(&self, service: &Service) -> Vec<u8> {
        let mut b = PacketBuilder::new([service.channel()], Priority(0));
        match self {
            Notice::Provider { id, lease, nonce } => {
                let ms = u64::try_from(lease.as_millis()).unwrap_or(u64::MAX);
                let mut line = b.line("provider");
                line.bare("id", &id.to_string()).field("lease_ms", ms);
                if let Some(nonce) = nonce {
                    line.bare("nonce", &nonce.to_string());
                }
            }
            Notice::Leaving { id } => {
                b.line("leaving").bare("id", &id.to_string());
            }
            Notice::Who { nonce } => {
                let mut line = b.line("who");
                if let Some(nonce) = nonce {
                    line.bare("nonce", &nonce.to_string());
                }
            }
        }
        b.finish().expect("notices are built from valid parts")
    }

    /// The provider a notice speaks for: only that provider's seal makes it
    /// true. `who` speaks for nobody.
    pub fn speaker(&self) -> Option<Id> {
        match self {
            Notice::Provider { id, .. } | Notice::Leaving { id } => Some(*id),
            Notice::Who { .. } => None,
        }
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
                    nonce: optional_id(&line, "nonce")?,
                })
            }
            "leaving" => Some(Notice::Leaving {
                id: id_field(&line, "id")?,
            }),
            "who" => Some(Notice::Who {
                nonce: optional_id(&line, "nonce")?,
            }),
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

/// An absent field is `Some(None)`; a present one that is no id spoils the line.
fn optional_id(line: &Line<'_>, name: &str) -> Option<Option<Id>> {
    match line.get(name) {
        None => Some(None),
        Some(_) => id_field(line, name).map(Some),
    }
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

/// What a provider says to a caller about one call.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Said {
    /// It took the call and will answer it: the call goes nowhere else.
    Accepted,
    /// Its answer; the lines follow the header.
    Reply,
    /// Why it could not serve the call.
    Refused(String),
}

/// The first line of what a provider sends a caller.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AnswerHeader {
    /// The call answered.
    pub id: Id,
    /// The provider that answered.
    pub from: Id,
    /// Taken, answered or refused.
    pub said: Said,
}

impl AnswerHeader {
    /// The answer as a packet to the caller's inbox, with the provider's
    /// `lines` (only a reply carries any), unsealed but leaving room for the
    /// seal and a hub key's `auth` line.
    pub fn to_packet(
        &self,
        to: &Subject,
        priority: Priority,
        lines: &[String],
    ) -> Result<Vec<u8>, ParseError> {
        let mut b = PacketBuilder::new([to], priority);
        let (id, from) = (self.id.to_string(), self.from.to_string());
        match &self.said {
            Said::Accepted => {
                b.line("accepted").bare("id", &id).bare("from", &from);
            }
            Said::Reply => {
                b.line("reply").bare("id", &id).bare("from", &from);
                for l in lines {
                    b.raw_line(l);
                }
            }
            Said::Refused(why) => {
                b.line("refused")
                    .bare("id", &id)
                    .bare("from", &from)
                    .field("text", why.as_str());
            }
        }
        let packet = b.finish()?;
        if packet.len() + SEALED_ROOM > MAX_PACKET {
            return Err(ParseError {
                kind: ErrorKind::TooLarge {
                    len: packet.len() + SEALED_ROOM,
                },
                line: 1,
                column: 1,
            });
        }
        Ok(packet)
    }

    /// The header of an answer packet, if its first line is one.
    pub fn read(packet: &Packet<'_>) -> Option<AnswerHeader> {
        let line = packet.lines().next()?;
        let said = match line.label() {
            "accepted" => Said::Accepted,
            "reply" => Said::Reply,
            // A bare reason as written, a quoted one unescaped; a group is no reason.
            "refused" => Said::Refused(match line.get("text")? {
                Value::Bare(token) => token.to_owned(),
                Value::Quoted(q) => q.unescape().into_owned(),
                Value::Group(_) => return None,
            }),
            _ => return None,
        };
        Some(AnswerHeader {
            id: id_field(&line, "id")?,
            from: id_field(&line, "from")?,
            said,
        })
    }
}

/// A provider's packet whose seal proves it came from the provider it names.
#[derive(Debug, Clone, Copy)]
pub struct Proven<'a> {
    /// The packet as the provider built it, its seal line left out.
    pub packet: Packet<'a>,
    /// Its count among the packets the provider's key sealed.
    pub n: u64,
}

/// The one check on a provider's word: `packet` counts as said by provider
/// `named` only if it is sealed by a key whose fingerprint is `named`.
pub fn proven<'a>(packet: &Packet<'a>, named: Id) -> Option<Proven<'a>> {
    let sealed = seal::open(packet.as_str().as_bytes()).ok()?;
    if Id::from(sealed.key) != named {
        return None;
    }
    Some(Proven {
        packet: Packet::parse(sealed.body).ok()?,
        n: sealed.n,
    })
}

/// The lines of a call or answer after its first, as written.
pub fn body_lines(packet: &Packet<'_>) -> Vec<String> {
    packet
        .lines()
        .skip(1)
        .map(|l| l.as_str().to_owned())
        .collect()
}
