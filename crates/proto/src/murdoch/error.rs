//! Why a MURDOCH message could not be written. (Why one could not be read is a
//! [`DecodeError`](crate::DecodeError), the crate's one decode error.)

use colony_wire::ParseError;

use super::SpecError;

/// A message that could not be written: a value no reader would accept.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EncodeError {
    /// The builder's own check failed (a bug in this crate, or a packet too large).
    #[error("cannot write the packet")]
    Packet(#[from] ParseError),
    /// The task itself is invalid.
    #[error(transparent)]
    Spec(#[from] SpecError),
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

/// An [`EncodeError::Field`].
pub(crate) fn unwritable(field: &'static str, what: impl Into<String>) -> EncodeError {
    EncodeError::Field {
        field,
        what: what.into(),
    }
}
