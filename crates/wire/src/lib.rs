//! colony's packet format: the text every colony process speaks.
//!
//! ```text
//! @ <vision_out> 0
//! ball x 5.3 y -2.5
//! blue id 0 x 15.2 y -98.3 pose (xh 1.0 yh 0.0)
//! note text "kick \"off\""
//! ```
//!
//! A header names one or more subjects (one subject is a channel; several are
//! a subject set, delivered to clients subscribed to all of them) and an
//! integer priority. Each body line is a label followed by `name value` pairs;
//! a name appears once per line, repeated labels are arrays, and a value is a
//! bare token, a quoted string or a parenthesised group of pairs.
//!
//! This crate parses ([`Packet`], zero-copy), writes ([`PacketBuilder`]) and
//! reads the hub's control requests ([`Request`], [`StatusReport`]); [`auth`]
//! signs and checks packets with a shared key; [`seal`] proves which process
//! wrote a packet (Ed25519, a key per process); [`batch`] joins and splits
//! several packets in one datagram; [`split_blocks`] and [`BlockWriter`] read
//! and write several packets as text; [`terminal_text`] shows network text on
//! a terminal. It does no I/O; its dependencies are
//! HMAC-SHA256 and Ed25519. It is not a schema layer: what a
//! label or field means is up to the programs that use it.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod auth;
pub mod batch;
mod build;
mod control;
mod error;
mod packet;
mod scan;
pub mod seal;
mod split;
mod subject;
mod terminal;

pub use build::{write_quoted, write_token_or_quoted, LineBuilder, PacketBuilder, WireValue};
pub use control::{
    clip_about, hub_packet, ChannelInfo, ClientInfo, ControlError, Cookie, Reply, Request,
    StatusReport, HUB_SUBJECT, MAX_ABOUT, MIN_LEASE_MS,
};
pub use error::{ErrorKind, FieldError, FieldErrorKind, ParseError};
pub use packet::{Field, Fields, Group, Line, Lines, Packet, Picked, Quoted, Subjects, Value};
pub use split::{split_blocks, split_packets, starts_with_packet, Block, BlockError, BlockWriter};
pub use subject::{parse_subject_set, Priority, Subject, SubjectError, SubjectSetError};
pub use terminal::{is_unsafe_for_terminal, terminal_line, terminal_text};

/// The largest packet: the payload of one UDP datagram over IPv4.
pub const MAX_PACKET: usize = 65_507;
/// The most subjects one header may name.
pub const MAX_SUBJECTS: usize = 16;
/// The longest subject name, in bytes.
pub const MAX_SUBJECT_LEN: usize = 64;
/// How deep groups may nest.
pub const MAX_DEPTH: usize = 32;
