//! The traffic log: every packet the hub accepted, with when and whence.
//!
//! A log is a header line, `colony-log 1\n`, then records:
//!
//! ```text
//! u32 LE  length of the rest of the record (after the checksum)
//! u32 LE  CRC-32 of the rest of the record
//! u64 LE  receive time, microseconds since the Unix epoch
//! u8      length of the source address text
//! ...     source address, as text (`127.0.0.1:5000`)
//! ...     the datagram, byte for byte
//! ```
//!
//! Records are only ever appended, so a crash can tear only the last one.
//! [`LogReader`] returns every whole record and then reports a torn tail;
//! [`LogWriter::open`] cuts a torn tail off before it appends, so records
//! written after a crash are never hidden behind a broken one.

use std::fs::{File, OpenOptions};
use std::io::{self, BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

const MAGIC: &[u8] = b"colony-log 1\n";
/// Fixed part of a record: length, checksum, time, address length.
const FIXED: usize = 4 + 4 + 8 + 1;
/// Largest length field a reader believes: one datagram plus its address.
const MAX_REST: usize = 8 + 1 + 255 + colony_wire::MAX_PACKET + 1;

/// A problem reading or writing a log.
#[derive(Debug, thiserror::Error)]
pub enum LogError {
    /// The file cannot be opened, read or written; the source says why.
    #[error("{path}")]
    Io {
        /// The log.
        path: PathBuf,
        /// What the system said.
        source: io::Error,
    },
    /// The file is something else.
    #[error("{path}: not a colony traffic log (it does not start with `colony-log 1`)")]
    NotALog {
        /// The file.
        path: PathBuf,
    },
    /// A record in the middle of the log fails its checksum or length check.
    #[error("{path}: record at byte {offset} is corrupt ({why}) and whole records follow it")]
    Corrupt {
        /// The log.
        path: PathBuf,
        /// Where the record starts.
        offset: u64,
        /// Which check it fails.
        why: &'static str,
    },
}

/// One logged packet.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Record {
    /// Receive time in microseconds since the Unix epoch.
    pub time_us: u64,
    /// The sender, as the hub saw it.
    pub source: String,
    /// The datagram, byte for byte.
    pub payload: Vec<u8>,
}

/// The end of a log that a crash cut short.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TornTail {
    /// Where the torn record starts; everything before it was read.
    pub offset: u64,
    /// How many bytes of it are there.
    pub bytes: u64,
}

/// Appends records to a log.
pub struct LogWriter {
    file: BufWriter<File>,
}

impl LogWriter {
    /// Opens `path` for appending, creating it if needed. A torn last record
    /// from an earlier crash is cut off first, and reported.
    pub fn open(path: impl AsRef<Path>) -> Result<(LogWriter, Option<TornTail>), LogError> {
        let path = path.as_ref();
        let io_err = |source| LogError::Io {
            path: path.to_owned(),
            source,
        };
        let mut file = OpenOptions::new()
            .read(true)
            .append(true)
            .create(true)
            .open(path)
            .map_err(io_err)?;
        let len = file.metadata().map_err(io_err)?.len();
        let mut torn = None;
        if len == 0 {
            file.write_all(MAGIC).map_err(io_err)?;
        } else {
            let mut reader = LogReader::from_file(file.try_clone().map_err(io_err)?, path)?;
            for record in reader.by_ref() {
                record?;
            }
            if let Some(t) = reader.torn_tail() {
                file.set_len(t.offset).map_err(io_err)?;
                torn = Some(t.clone());
            }
        }
        Ok((
            LogWriter {
                file: BufWriter::with_capacity(256 * 1024, file),
            },
            torn,
        ))
    }

    /// Appends one record (buffered: call [`flush`](Self::flush) to hand it to the OS).
    pub fn append(
        &mut self,
        time: SystemTime,
        source: SocketAddr,
        payload: &[u8],
    ) -> io::Result<()> {
        let time_us = time
            .duration_since(UNIX_EPOCH)
            .map(|d| d.as_micros() as u64)
            .unwrap_or(0);
        let addr = source.to_string();
        self.append_raw(time_us, &addr, payload)
    }

    fn append_raw(&mut self, time_us: u64, source: &str, payload: &[u8]) -> io::Result<()> {
        let source = &source.as_bytes()[..source.len().min(255)];
        let rest_len = 8 + 1 + source.len() + payload.len();
        let mut hasher = crc32fast::Hasher::new();
        hasher.update(&time_us.to_le_bytes());
        hasher.update(&[source.len() as u8]);
        hasher.update(source);
        hasher.update(payload);
        self.file.write_all(&(rest_len as u32).to_le_bytes())?;
        self.file.write_all(&hasher.finalize().to_le_bytes())?;
        self.file.write_all(&time_us.to_le_bytes())?;
        self.file.write_all(&[source.len() as u8])?;
        self.file.write_all(source)?;
        self.file.write_all(payload)
    }

    /// Appends a record as read from another log.
    pub fn append_record(&mut self, r: &Record) -> io::Result<()> {
        self.append_raw(r.time_us, &r.source, &r.payload)
    }

    /// Writes what is buffered to the file.
    pub fn flush(&mut self) -> io::Result<()> {
        self.file.flush()
    }
}

/// Reads a log record by record. After the last whole record,
/// [`torn_tail`](LogReader::torn_tail) says whether a torn one followed.
pub struct LogReader {
    file: BufReader<File>,
    path: PathBuf,
    offset: u64,
    len: u64,
    torn: Option<TornTail>,
    done: bool,
}

impl LogReader {
    /// Opens a log and checks its header.
    pub fn open(path: impl AsRef<Path>) -> Result<LogReader, LogError> {
        let path = path.as_ref();
        let file = File::open(path).map_err(|source| LogError::Io {
            path: path.to_owned(),
            source,
        })?;
        LogReader::from_file(file, path)
    }

    fn from_file(mut file: File, path: &Path) -> Result<LogReader, LogError> {
        let io_err = |source| LogError::Io {
            path: path.to_owned(),
            source,
        };
        let len = file.metadata().map_err(io_err)?.len();
        file.seek(SeekFrom::Start(0)).map_err(io_err)?;
        let mut magic = [0u8; MAGIC.len()];
        let mut file = BufReader::with_capacity(256 * 1024, file);
        match file.read_exact(&mut magic) {
            Ok(()) if magic == MAGIC => {}
            Err(e) if e.kind() != io::ErrorKind::UnexpectedEof => return Err(io_err(e)),
            _ => {
                return Err(LogError::NotALog {
                    path: path.to_owned(),
                })
            }
        }
        Ok(LogReader {
            file,
            path: path.to_owned(),
            offset: MAGIC.len() as u64,
            len,
            torn: None,
            done: false,
        })
    }

    /// The torn record at the end, once iteration has reached it.
    pub fn torn_tail(&self) -> Option<&TornTail> {
        self.torn.as_ref()
    }

    fn tear(&mut self) -> Option<Result<Record, LogError>> {
        self.torn = Some(TornTail {
            offset: self.offset,
            bytes: self.len - self.offset,
        });
        self.done = true;
        None
    }

    fn read_record(&mut self) -> Option<Result<Record, LogError>> {
        if self.done || self.offset >= self.len {
            return None;
        }
        let remaining = self.len - self.offset;
        if remaining < 8 {
            return self.tear();
        }
        let mut head = [0u8; 8];
        if let Err(e) = self.file.read_exact(&mut head) {
            self.done = true;
            return Some(Err(LogError::Io {
                path: self.path.clone(),
                source: e,
            }));
        }
        let rest_len = u32::from_le_bytes(head[..4].try_into().expect("4 bytes")) as u64;
        let crc = u32::from_le_bytes(head[4..].try_into().expect("4 bytes"));
        if rest_len < (FIXED - 8) as u64 || rest_len > MAX_REST as u64 {
            return self.corrupt_or_torn("impossible length");
        }
        if remaining - 8 < rest_len {
            return self.tear();
        }
        let mut rest = vec![0u8; rest_len as usize];
        if let Err(e) = self.file.read_exact(&mut rest) {
            self.done = true;
            return Some(Err(LogError::Io {
                path: self.path.clone(),
                source: e,
            }));
        }
        if crc32fast::hash(&rest) != crc {
            return self.corrupt_or_torn("checksum mismatch");
        }
        let time_us = u64::from_le_bytes(rest[..8].try_into().expect("8 bytes"));
        let addr_len = rest[8] as usize;
        if 9 + addr_len > rest.len() {
            return self.corrupt_or_torn("address longer than its record");
        }
        let source = String::from_utf8_lossy(&rest[9..9 + addr_len]).into_owned();
        let payload = rest[9 + addr_len..].to_vec();
        self.offset += 8 + rest_len;
        Some(Ok(Record {
            time_us,
            source,
            payload,
        }))
    }

    /// A bad record at the very end is a torn tail; one followed by more data is corruption.
    fn corrupt_or_torn(&mut self, why: &'static str) -> Option<Result<Record, LogError>> {
        let offset = self.offset;
        if self.is_last_record(offset) {
            return self.tear();
        }
        self.done = true;
        Some(Err(LogError::Corrupt {
            path: self.path.clone(),
            offset,
            why,
        }))
    }

    /// Whether a record starting at `offset` is the last thing in the file, as
    /// a torn append would be: its length field reaches the end or beyond, or
    /// the bytes after its claimed end hold no whole record.
    fn is_last_record(&mut self, offset: u64) -> bool {
        let Ok(mut file) = self.file.get_ref().try_clone() else {
            return true;
        };
        let mut head = [0u8; 4];
        if file.seek(SeekFrom::Start(offset)).is_err() || file.read_exact(&mut head).is_err() {
            return true;
        }
        let claimed = u32::from_le_bytes(head) as u64;
        let next = offset + 8 + claimed;
        claimed > MAX_REST as u64 || next >= self.len
    }
}

impl Iterator for LogReader {
    type Item = Result<Record, LogError>;
    fn next(&mut self) -> Option<Self::Item> {
        self.read_record()
    }
}
