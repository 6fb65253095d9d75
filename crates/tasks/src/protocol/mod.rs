//! Every MURDOCH message as a hub packet, written and read.
//!
//! [`Message::decode`] takes any packet and either returns the message or
//! says which line and field are wrong; it never panics, whatever the bytes
//! (a property test and a fuzz target hold it to that).

mod announce;
mod error;
mod fields;
mod negotiate;

pub use announce::{
    Announcement, MetricTerm, Param, ParamValue, SpecError, TaskSpec, MAX_METRICS, MAX_PARAMS,
};
pub use error::{DecodeError, EncodeError};
pub use fields::{valid_name, MAX_DEADLINE, MAX_LENGTH_S, MAX_MAGNITUDE, MAX_TEXT};
pub use negotiate::{Bid, Negotiation};

use colony_wire::{Packet, Subject};

use crate::resource::NEGOTIATION_PREFIX;

/// The labels of the messages on a negotiation subject.
const NEGOTIATION_LABELS: [&str; 9] = [
    "bid",
    "award",
    "ack",
    "decline",
    "renew",
    "done",
    "abandon",
    "cancel",
    "unachievable",
];

/// Any MURDOCH message.
#[derive(Debug, Clone, PartialEq)]
pub enum Message {
    /// A task on offer, addressed to its resources and `idle`.
    Announce(Announcement),
    /// A message on a negotiation subject.
    Negotiation {
        /// The subject it came on.
        subject: Subject,
        /// What it says.
        message: Negotiation,
    },
}

impl Message {
    /// Reads a message from a packet: an announcement if its first line is
    /// `task`, otherwise a negotiation message, whose header must be a single
    /// `murdoch.` subject. Lines after a negotiation message's first are ignored,
    /// so later versions can add some.
    pub fn decode(packet: &Packet<'_>) -> Result<Message, DecodeError> {
        let first = packet.lines().next().ok_or(DecodeError::Empty)?;
        if first.label() == "task" {
            return Announcement::decode(packet).map(Message::Announce);
        }
        if !NEGOTIATION_LABELS.contains(&first.label()) {
            return Err(DecodeError::UnknownMessage {
                line: first.number(),
                label: first.label().to_owned(),
            });
        }
        let mut subjects = packet.subjects();
        let subject = match (subjects.next(), subjects.next()) {
            (Some(s), None) if s.starts_with(NEGOTIATION_PREFIX) => {
                Subject::new(s).map_err(|e| DecodeError::Header(e.to_string()))?
            }
            _ => {
                return Err(DecodeError::Header(format!(
                    "a `{}` message goes to one `{NEGOTIATION_PREFIX}` subject, not to {}",
                    first.label(),
                    packet.subjects_text()
                )))
            }
        };
        let message = Negotiation::decode_line(&first)?;
        Ok(Message::Negotiation { subject, message })
    }

    /// The packet.
    pub fn encode(&self) -> Result<Vec<u8>, EncodeError> {
        match self {
            Message::Announce(a) => a.encode(),
            Message::Negotiation { subject, message } => message.encode(subject),
        }
    }

    /// Parses and reads a datagram.
    pub fn decode_bytes(bytes: &[u8]) -> Result<Message, DecodeError> {
        Message::decode(&Packet::parse(bytes)?)
    }
}
