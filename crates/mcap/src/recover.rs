//! Rewriting a torn MCAP log as a valid one.

use std::path::Path;

use crate::{McapEnd, McapLogError, McapLogWriter, McapReader};

/// What [`recover`] found and wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Recovered {
    /// colony messages written to the new file.
    pub messages: u64,
    /// Whole chunks they came from.
    pub chunks: u64,
    /// How the damaged file ended.
    pub end: McapEnd,
    /// Corrupt records skipped: where each starts and what was wrong.
    pub skipped: Vec<(u64, String)>,
    /// Messages left out because colony did not write them.
    pub foreign: u64,
    /// Messages read but left out because their text is not a packet (the
    /// writer would not take them).
    pub unwritable: u64,
}

/// Reads the MCAP log `from` as far as its whole records go (skipping any
/// chunk that fails its checks) and writes every colony message in it to a
/// new, finished MCAP at `to` (which must not exist or be empty), with its
/// channels, schemas, indexes and summary.
pub fn recover(from: impl AsRef<Path>, to: impl AsRef<Path>) -> Result<Recovered, McapLogError> {
    let mut reader = McapReader::open(from)?.skipping_corrupt();
    let mut writer = McapLogWriter::create(to)?;
    let mut unwritable = 0;
    for record in reader.by_ref() {
        if !writer.append_record(&record?)? {
            unwritable += 1;
        }
    }
    writer.finish()?;
    Ok(Recovered {
        messages: writer.messages(),
        chunks: reader.chunks(),
        end: reader.end().cloned().unwrap_or(McapEnd::Finished),
        skipped: reader.skipped().to_vec(),
        foreign: reader.foreign(),
        unwritable,
    })
}
