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
    /// A message that must be sealed is not, or its seal does not check out.
    #[error("seal: {0}")]
    Seal(#[from] colony_wire::seal::SealError),
}

/// What a viewer's decoder (`skim`) read: the message as far as it could be read, and how many
/// of its lines could not be and were skipped.
///
/// A node acts on what it reads, so its decoder (`decode`) refuses a packet with one bad line; a
/// viewer such as the monitor shows what it can and counts the rest. Both read every line with
/// the same rules: `skim` only differs in what it does with a line those rules refuse.
#[derive(Debug, Clone, PartialEq)]
pub struct Skimmed<T> {
    /// What could be read.
    pub message: T,
    /// Lines that could not be read and were left out.
    pub bad_lines: u64,
}

/// What a decoder does with a line it cannot read: refuse the packet (a node's decoder) or skip
/// the line and count it (a viewer's). Each message is read by one function taking this policy,
/// so the strict and the tolerant decoder cannot drift apart.
#[derive(Debug)]
pub(crate) struct LinePolicy {
    strict: bool,
    skipped: u64,
}

impl LinePolicy {
    /// Refuse the packet on its first bad line.
    pub(crate) fn strict() -> LinePolicy {
        LinePolicy {
            strict: true,
            skipped: 0,
        }
    }

    /// Skip bad lines, counting them.
    pub(crate) fn skim() -> LinePolicy {
        LinePolicy {
            strict: false,
            skipped: 0,
        }
    }

    /// A line's reading: its value, `None` when skimming past a bad line, or the error when strict.
    pub(crate) fn take<T>(
        &mut self,
        read: Result<T, DecodeError>,
    ) -> Result<Option<T>, DecodeError> {
        match read {
            Ok(v) => Ok(Some(v)),
            Err(e) if self.strict => Err(e),
            Err(_) => {
                self.skipped += 1;
                Ok(None)
            }
        }
    }

    /// `message` with the count of lines skipped.
    pub(crate) fn skimmed<T>(self, message: T) -> Skimmed<T> {
        Skimmed {
            message,
            bad_lines: self.skipped,
        }
    }
}
