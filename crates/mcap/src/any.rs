//! Either kind of traffic log, told apart by its first bytes.

use std::fs::File;
use std::io::{self, Read};
use std::path::{Path, PathBuf};

use colony_hub::log::{LogError, LogReader, Record};

use crate::{McapEnd, McapLogError, McapReader, MAGIC};

/// A traffic log of either format, read record by record: a `.clog`
/// ([`LogReader`]) or an MCAP ([`McapReader`]), whatever its name says.
///
/// ```no_run
/// let mut log = colony_mcap::TrafficReader::open("run.mcap")?;
/// for record in log.by_ref() {
///     let record = record?;
///     println!("{} bytes from {}", record.payload.len(), record.source);
/// }
/// if let Some(note) = log.damage() {
///     eprintln!("{note}");
/// }
/// # Ok::<(), colony_mcap::TrafficError>(())
/// ```
pub enum TrafficReader {
    /// A `.clog`.
    Clog(LogReader, PathBuf),
    /// An MCAP.
    Mcap(McapReader, PathBuf),
}

/// A problem reading a traffic log of either format.
#[derive(Debug, thiserror::Error)]
pub enum TrafficError {
    /// Reading a `.clog`.
    #[error(transparent)]
    Clog(#[from] LogError),
    /// Reading an MCAP.
    #[error(transparent)]
    Mcap(#[from] McapLogError),
}

impl TrafficReader {
    /// Opens the log at `path`: an MCAP if it starts with the MCAP magic,
    /// otherwise a `.clog` (which checks its own header).
    pub fn open(path: impl AsRef<Path>) -> Result<TrafficReader, TrafficError> {
        let path = path.as_ref();
        if is_mcap(path).map_err(|source| McapLogError::Io {
            path: path.to_owned(),
            source,
        })? {
            Ok(TrafficReader::Mcap(
                McapReader::open(path)?,
                path.to_owned(),
            ))
        } else {
            Ok(TrafficReader::Clog(LogReader::open(path)?, path.to_owned()))
        }
    }

    /// After reading to the end: what a crash cut short, said for a person
    /// (`None` when the log ends whole).
    pub fn damage(&self) -> Option<String> {
        match self {
            TrafficReader::Clog(r, path) => r.torn_tail().map(|t| {
                format!(
                    "{} ends in a torn record at byte {} ({} bytes, a write cut short); every record before it was read",
                    path.display(),
                    t.offset,
                    t.bytes
                )
            }),
            TrafficReader::Mcap(r, path) => {
                let mut notes = Vec::new();
                if let Some(McapEnd::Torn { offset, bytes }) = r.end() {
                    notes.push(format!(
                        "{} ends before its writer finished it (no summary: the writer was stopped, or is still writing): \
                         read {} messages from {} whole chunks; the {bytes} bytes from byte {offset} on (a chunk cut short, \
                         if any) were not read. If its writer is gone, `colony log recover {} OUT.mcap` rewrites it as a valid MCAP",
                        path.display(),
                        r.messages(),
                        r.chunks(),
                        path.display()
                    ));
                }
                if r.foreign() > 0 {
                    notes.push(format!(
                        "{}: skipped {} messages that colony did not write",
                        path.display(),
                        r.foreign()
                    ));
                }
                (!notes.is_empty()).then(|| notes.join("\n"))
            }
        }
    }
}

/// Whether the file at `path` starts with the MCAP magic.
pub fn is_mcap(path: &Path) -> io::Result<bool> {
    let mut magic = [0u8; 8];
    let mut file = File::open(path)?;
    let mut got = 0;
    while got < magic.len() {
        match file.read(&mut magic[got..])? {
            0 => return Ok(false),
            n => got += n,
        }
    }
    Ok(&magic == MAGIC)
}

impl Iterator for TrafficReader {
    type Item = Result<Record, TrafficError>;

    fn next(&mut self) -> Option<Self::Item> {
        match self {
            TrafficReader::Clog(r, _) => r.next().map(|r| r.map_err(TrafficError::from)),
            TrafficReader::Mcap(r, _) => r.next().map(|r| r.map_err(TrafficError::from)),
        }
    }
}
