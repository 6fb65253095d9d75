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
}
