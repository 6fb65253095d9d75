//! The one error every decoder in this crate returns.

use colony_wire::{FieldError, ParseError};

/// Why a packet is not the message its decoder reads.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DecodeError {
    /// The bytes are not a packet.
    #[error(transparent)]
    Packet(#[from] ParseError),
    /// A field is missing or of the wrong type (the error names the line, column and field).
    #[error(transparent)]
    Field(#[from] FieldError),
    /// The packet has no line this message needs.
    #[error("no `{0}` line")]
    Missing(&'static str),
    /// A value is out of its range or not a known word.
    #[error("line {line}: {what}")]
    Bad {
        /// 1-based line number.
        line: u32,
        /// What was wrong, with the offending value.
        what: String,
    },
    /// A header with no body line.
    #[error("no message: the packet has no body line")]
    Empty,
    /// A first line whose label names no message this decoder reads.
    #[error("line {line}: unknown message `{label}` (expected {expected})")]
    UnknownMessage {
        /// 1-based line number.
        line: u32,
        /// The label found.
        label: String,
        /// The labels the decoder reads, as a person would list them.
        expected: &'static str,
    },
    /// A field that reads but whose value is out of its range or not a known word.
    #[error("line {line}, field `{field}`: {what}")]
    BadField {
        /// 1-based line number.
        line: u32,
        /// The field at fault.
        field: String,
        /// What is wrong with it, with the offending value.
        what: String,
    },
    /// A header whose subjects do not fit the message.
    #[error("line 1 (header): {0}")]
    Header(String),
}
