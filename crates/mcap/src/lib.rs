//! colony's traffic log as [MCAP](https://mcap.dev): what `colony hub --log
//! FILE.mcap` writes, `colony log export --mcap` converts a `.clog` to, and
//! `colony log` and `colony replay` read back.
//!
//! - [`McapLogWriter`] writes a chunked, zstd-compressed MCAP with message
//!   indexes and a summary. Each colony channel (the subjects of a packet's
//!   header, as [`colony_schema::topic`] names them) is an MCAP channel; each
//!   message is the packet as JSON ([`colony_schema::to_json`]), which keeps
//!   the packet's text exactly and gives its lines as typed fields, with a
//!   JSON Schema per channel, so Foxglove or Lichtblick can plot them without
//!   colony. It implements [`colony_hub::log::LogSink`], so the hub logs
//!   through it without depending on this crate.
//! - [`McapReader`] reads such a file back as [`Record`]s, with bounded
//!   memory, whole chunk by whole chunk. A file a crash cut short (a writer
//!   killed before its summary) is read as far as its last whole chunk and
//!   says where the damage starts ([`McapEnd`]); a file damaged elsewhere is an
//!   error with the offset of the damaged record.
//! - [`recover`] rewrites a torn MCAP as a valid one.
//! - [`TrafficReader`] opens either format, told apart by its first bytes.
//!
//! What this crate is not: a general MCAP toolkit. It reads the messages
//! colony wrote (JSON with the packet's text) and skips, counting them, any
//! others.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod any;
mod read;
mod recover;
mod write;

use std::io;
use std::path::PathBuf;

pub use any::{is_mcap, TrafficError, TrafficReader};
pub use colony_hub::log::Record;
pub use read::{McapEnd, McapReader, MAX_RECORD};
pub use recover::{recover, Recovered};
pub use write::{McapLogWriter, CHUNK_AGE, CHUNK_SIZE, MAX_CHANNELS, OTHER_TOPIC};

/// The first eight bytes of every MCAP file.
pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

/// A problem writing or reading an MCAP traffic log.
#[derive(Debug, thiserror::Error)]
pub enum McapLogError {
    /// The file cannot be created, opened, read or written; the source says why.
    #[error("{path}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: io::Error,
    },
    /// The writer will not write over (or append to) a file that has data:
    /// a finished MCAP cannot be appended to.
    #[error("{path} exists and is not empty: an MCAP log is never appended to; move it aside or choose another name")]
    Exists {
        /// The file.
        path: PathBuf,
    },
    /// The file does not start with the MCAP magic.
    #[error("{path}: not an MCAP file (it does not start with the MCAP magic bytes)")]
    NotAnMcap {
        /// The file.
        path: PathBuf,
    },
    /// A record is damaged somewhere other than a torn end.
    #[error("{path}: record at byte {offset} is corrupt ({why})")]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// Where the damaged record starts.
        offset: u64,
        /// What is wrong with it.
        why: String,
    },
    /// The MCAP writer failed; the source says why.
    #[error("{path}: cannot write the MCAP")]
    Write {
        /// The file.
        path: PathBuf,
        /// What the writer said.
        source: mcap::McapError,
    },
}
