//! Why a packet is not a MURDOCH message, with the line and field at fault.

use colony_wire::{FieldError, Line, ParseError};

/// A packet that is not a message this crate can act on. Every variant names
/// where the problem is, so a person forging packets by hand can fix them.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DecodeError {
    /// Not a packet at all.
    #[error(transparent)]
    Packet(#[from] ParseError),
    /// A field is missing or not of its type.
    #[error(transparent)]
    Field(#[from] FieldError),
    /// A header with no body.
    #[error("no message: the packet has no body line")]
    Empty,
    /// A first line whose label names no message.
    #[error(
        "line {line}: unknown message `{label}` (expected task, bid, award, ack, decline, \
         renew, done, abandon, cancel or unachievable)"
    )]
    UnknownMessage {
        /// 1-based line in the packet.
        line: u32,
        /// The label found.
        label: String,
    },
    /// A field that reads but whose value is out of range or not a known word.
    #[error("line {line}, field `{field}`: {what}")]
    Bad {
        /// 1-based line in the packet.
        line: u32,
        /// The field at fault.
        field: String,
        /// What is wrong with it.
        what: String,
    },
    /// A header whose subjects do not fit the message.
    #[error("line 1 (header): {0}")]
    Header(String),
}

pub(crate) fn bad(line: &Line<'_>, field: &str, what: impl Into<String>) -> DecodeError {
    DecodeError::Bad {
        line: line.number(),
        field: field.to_owned(),
        what: what.into(),
    }
}

/// A message that could not be written: a value no reader would accept.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EncodeError {
    /// The builder's own check failed (a bug in this crate, or a packet too large).
    #[error("cannot write the packet: {0}")]
    Packet(#[from] ParseError),
    /// The task itself is invalid.
    #[error(transparent)]
    Spec(#[from] crate::protocol::SpecError),
    /// A value the reader would refuse (a score out of range, a task number
    /// beyond what a packet carries, a deadline too long, a subject that is
    /// not a negotiation subject), so it is not sent.
    #[error("cannot write field `{field}`: {what}")]
    Field {
        /// The field (or `subject`, for the header).
        field: &'static str,
        /// What is wrong with it.
        what: String,
    },
}

pub(crate) fn unwritable(field: &'static str, what: impl Into<String>) -> EncodeError {
    EncodeError::Field {
        field,
        what: what.into(),
    }
}
