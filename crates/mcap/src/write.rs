//! Writing a traffic log as MCAP.

use std::collections::{BTreeMap, HashMap};
use std::fs::{File, OpenOptions};
use std::io::{self, Write};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

use colony_hub::log::{LogSink, Record};
use colony_wire::Packet;
use mcap::records::MessageHeader;
use mcap::write::NoSeek;
use mcap::{McapError, WriteOptions};

use crate::McapLogError;

/// Uncompressed size at which a chunk is closed and written.
pub const CHUNK_SIZE: u64 = 1 << 20;
/// Age at which [`LogSink::end_round`] closes a chunk, so that a crash loses
/// at most about this much of the traffic.
pub const CHUNK_AGE: Duration = Duration::from_secs(1);
/// Most MCAP channels one log holds. Publishers choose their subjects, and an
/// MCAP channel id is 16 bits: past this many, packets go to [`OTHER_TOPIC`]
/// (each message still holds its packet's text whole).
pub const MAX_CHANNELS: usize = 1024;
/// The channel for packets past [`MAX_CHANNELS`].
pub const OTHER_TOPIC: &str = "colony/other";

/// A file that, once a write to it has failed, refuses every later one, so
/// that nothing (the mcap writer's own drop, which writes the summary,
/// included) appends to a log with a hole in it.
/// An interrupted write (`EINTR`) wrote nothing and is retried, so it does
/// not count as a failure.
struct Fused<W = File> {
    file: W,
    failed: bool,
}

impl<W: Write> Write for Fused<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if self.failed {
            return Err(io::Error::other("an earlier write to this log failed"));
        }
        self.file.write(buf).inspect_err(|e| {
            if e.kind() != io::ErrorKind::Interrupted {
                self.failed = true
            }
        })
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.flush()
    }
}

/// What a log may be written to: a regular file, or a FIFO (a reader at its
/// other end); never a device, a directory or a socket.
fn is_log_target(kind: std::fs::FileType) -> bool {
    #[cfg(unix)]
    let fifo = std::os::unix::fs::FileTypeExt::is_fifo(&kind);
    #[cfg(not(unix))]
    let fifo = false;
    kind.is_file() || fifo
}

type Inner = mcap::Writer<NoSeek<Fused>>;

/// Writes a traffic log as MCAP: chunked, zstd, with message indexes and a
/// summary. Chunks are built in memory and written whole, when they reach
/// [`CHUNK_SIZE`], when they are [`CHUNK_AGE`] old at the end of a hub round,
/// and at [`finish`](Self::finish); so a file a crash cut short holds whole
/// chunks and at most one torn one, and loses at most the chunk in memory.
///
/// ```no_run
/// use colony_mcap::McapLogWriter;
/// let mut w = McapLogWriter::create("run.mcap")?;
/// w.append_raw(1_700_000_000_000_000, "127.0.0.1:5000", b"@ <vision> 0\nrobot id=3 x=1.5\n")?;
/// w.finish()?;
/// # Ok::<(), colony_mcap::McapLogError>(())
/// ```
pub struct McapLogWriter {
    /// `None` once finished or failed.
    writer: Option<Inner>,
    path: PathBuf,
    channels: HashMap<String, u16>,
    sequence: u32,
    /// Messages in the chunk being built.
    in_chunk: u64,
    /// The end of the first round that saw the chunk being built hold a message.
    chunk_since: Option<Instant>,
    messages: u64,
}

impl McapLogWriter {
    /// Creates an MCAP log at `path`. A file that exists and holds anything
    /// is refused ([`McapLogError::Exists`]): MCAP is not appended to.
    pub fn create(path: impl AsRef<Path>) -> Result<McapLogWriter, McapLogError> {
        let path = path.as_ref();
        let io_err = |source| McapLogError::Io {
            path: path.to_owned(),
            source,
        };
        let not_a_file = || {
            io_err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "not a regular file or a FIFO: an MCAP log is written only to a new or empty file (or piped)",
            ))
        };
        // Checked before opening too, so that a device is never opened.
        if std::fs::metadata(path).is_ok_and(|m| !is_log_target(m.file_type())) {
            return Err(not_a_file());
        }
        let file = OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)
            .map_err(io_err)?;
        let meta = file.metadata().map_err(io_err)?;
        if !is_log_target(meta.file_type()) {
            return Err(not_a_file());
        }
        if meta.len() > 0 {
            return Err(McapLogError::Exists {
                path: path.to_owned(),
            });
        }
        let options = WriteOptions::new()
            .profile("")
            .library(concat!("colony-mcap ", env!("CARGO_PKG_VERSION")))
            .chunk_size(Some(CHUNK_SIZE))
            // Chunks built in memory and written whole: what a crash tears
            // is the end of the file, never a chunk header written before
            // its data.
            .disable_seeking(true)
            // Compress on the writing thread: the hub starts no threads for it.
            .compression_threads(0)
            .compression_level(1);
        let writer = options
            .create(NoSeek::new(Fused {
                file,
                failed: false,
            }))
            .map_err(|source| McapLogError::Write {
                path: path.to_owned(),
                source,
            })?;
        Ok(McapLogWriter {
            writer: Some(writer),
            path: path.to_owned(),
            channels: HashMap::new(),
            sequence: 0,
            in_chunk: 0,
            chunk_since: None,
            messages: 0,
        })
    }

    /// The file written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Messages written so far.
    pub fn messages(&self) -> u64 {
        self.messages
    }

    fn failed(&mut self, source: McapError) -> McapLogError {
        // Dropping the writer tries to finish it, which the fused file refuses
        // after an I/O error: nothing more is written after a failure.
        self.writer = None;
        McapLogError::Write {
            path: self.path.clone(),
            source,
        }
    }

    /// Appends one datagram received at `time_us` (microseconds since the
    /// Unix epoch) from `source`, as a message on its packet's channel.
    /// Returns false, writing nothing, for a datagram that is not a packet
    /// (the hub logs only packets; an old `.clog` might hold something else).
    pub fn append_raw(
        &mut self,
        time_us: u64,
        source: &str,
        payload: &[u8],
    ) -> Result<bool, McapLogError> {
        let Ok(packet) = Packet::parse(payload) else {
            return Ok(false);
        };
        let mut topic = colony_schema::topic(&packet);
        let channel = match self.channels.get(&topic) {
            Some(&id) => id,
            None => {
                if self.channels.len() >= MAX_CHANNELS {
                    topic = OTHER_TOPIC.to_string();
                }
                match self.channels.get(&topic) {
                    Some(&id) => id,
                    None => self.add_channel(topic)?,
                }
            }
        };
        let data = colony_schema::to_json(&packet, Some(source));
        let log_time = time_us.saturating_mul(1000);
        let header = MessageHeader {
            channel_id: channel,
            sequence: self.sequence,
            log_time,
            publish_time: log_time,
        };
        let writer = self.writer.as_mut().ok_or_else(|| closed(&self.path))?;
        if let Err(e) = writer.write_to_known_channel(&header, &data) {
            return Err(self.failed(e));
        }
        self.sequence = self.sequence.wrapping_add(1);
        self.messages += 1;
        self.in_chunk += 1;
        Ok(true)
    }

    fn add_channel(&mut self, topic: String) -> Result<u16, McapLogError> {
        let schema = colony_schema::schema_for(&topic);
        let writer = self.writer.as_mut().ok_or_else(|| closed(&self.path))?;
        let added = writer
            .add_schema(&schema.name, colony_schema::SCHEMA_ENCODING, &schema.data)
            .and_then(|schema_id| {
                writer.add_channel(
                    schema_id,
                    &topic,
                    colony_schema::MESSAGE_ENCODING,
                    &BTreeMap::new(),
                )
            });
        match added {
            Ok(id) => {
                self.channels.insert(topic, id);
                Ok(id)
            }
            Err(e) => Err(self.failed(e)),
        }
    }

    /// Appends a record as read from another log (a `.clog`, or an MCAP).
    pub fn append_record(&mut self, record: &Record) -> Result<bool, McapLogError> {
        self.append_raw(record.time_us, &record.source, &record.payload)
    }

    /// Closes the chunk being built and writes it to the file.
    pub fn close_chunk(&mut self) -> Result<(), McapLogError> {
        let writer = self.writer.as_mut().ok_or_else(|| closed(&self.path))?;
        if let Err(e) = writer.flush() {
            return Err(self.failed(e));
        }
        self.in_chunk = 0;
        self.chunk_since = None;
        Ok(())
    }

    /// Writes the last chunk, the indexes and the summary: the file is a
    /// whole MCAP. Nothing can be appended afterwards.
    pub fn finish(&mut self) -> Result<(), McapLogError> {
        let mut writer = self.writer.take().ok_or_else(|| closed(&self.path))?;
        let finished = writer.finish();
        // Dropping a finished writer writes nothing more.
        let mut inner = writer.into_inner().into_inner();
        finished.map_err(|source| McapLogError::Write {
            path: self.path.clone(),
            source,
        })?;
        inner.flush().map_err(|source| McapLogError::Io {
            path: self.path.clone(),
            source,
        })
    }
}

/// The error for a writer used after it finished or failed.
fn closed(path: &Path) -> McapLogError {
    McapLogError::Io {
        path: path.to_owned(),
        source: io::Error::other("the log is finished or failed earlier"),
    }
}

impl LogSink for McapLogWriter {
    fn append(&mut self, time: SystemTime, source: SocketAddr, payload: &[u8]) -> io::Result<()> {
        // Saturating: a time past u64 microseconds must not wrap to an early one.
        let time_us = colony_wire::auth::unix_micros(time);
        self.append_raw(time_us, &source.to_string(), payload)
            .map(|_| ())
            .map_err(io::Error::other)
    }

    fn end_round(&mut self, now: Instant) -> io::Result<()> {
        if self.in_chunk == 0 {
            return Ok(());
        }
        let since = *self.chunk_since.get_or_insert(now);
        if now.saturating_duration_since(since) >= CHUNK_AGE {
            self.close_chunk().map_err(io::Error::other)?;
        }
        Ok(())
    }

    fn finish(&mut self) -> io::Result<()> {
        McapLogWriter::finish(self).map_err(io::Error::other)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fails its first write with `error`, then takes everything.
    struct FailsOnce(Option<io::ErrorKind>, Vec<u8>);

    impl Write for FailsOnce {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            if let Some(kind) = self.0.take() {
                return Err(io::Error::from(kind));
            }
            self.1.extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn an_interrupted_write_is_retried_and_any_other_failure_is_final() {
        let mut f = Fused {
            file: FailsOnce(Some(io::ErrorKind::Interrupted), Vec::new()),
            failed: false,
        };
        f.write_all(b"abc").unwrap();
        assert_eq!(f.file.1, b"abc");
        let mut f = Fused {
            file: FailsOnce(Some(io::ErrorKind::StorageFull), Vec::new()),
            failed: false,
        };
        assert!(f.write_all(b"abc").is_err());
        assert!(f.write_all(b"abc").is_err());
        assert!(f.file.1.is_empty());
    }
}
