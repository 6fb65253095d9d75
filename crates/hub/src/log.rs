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
//! Records are only ever appended, so a crash can tear only the end of the
//! file: the last record, or the last buffer of records, cut short (or, after
//! a power cut, left as zeros). What a crash leaves therefore never contains a
//! whole record, and that is how damage is told apart:
//!
//! - a **torn tail** is a record that cannot be whole (fewer bytes left than
//!   its header, an impossible length, or a length running past the end of
//!   the file) with no whole record anywhere after it. [`LogReader`] returns
//!   every record before it and then reports it; [`LogWriter::open`] cuts it
//!   off before it appends, so records written after a crash are never hidden
//!   behind a broken one;
//! - anything else (a record that fails its checks while a whole record
//!   follows, or a whole-length record whose checksum fails) is **corruption**:
//!   the reader reports it as an error with its offset, and the writer refuses
//!   to append to the file at all, because cutting it would lose whole records.
//!
//! A writer can also rotate its log by size ([`Rotation`]): `FILE` becomes
//! `FILE.1`, `FILE.1` becomes `FILE.2` and so on, the oldest beyond the number
//! kept is deleted, and a fresh `FILE` begins.

use std::ffi::OsString;
use std::fs::{File, OpenOptions};
use std::io::{self, BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

const MAGIC: &[u8] = b"colony-log 1\n";
/// Fixed part of a record: length, checksum, time, address length.
const FIXED: usize = 4 + 4 + 8 + 1;
/// Largest length field a reader believes: one datagram plus its address.
const MAX_REST: usize = 8 + 1 + 255 + colony_wire::MAX_PACKET + 1;
/// Bytes of the file looked at per read while searching for a whole record
/// after damage (plus one record's worth of overlap).
const SCAN_WINDOW: usize = 1 << 20;

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
    /// A record fails its checks and is not a torn tail: a whole record
    /// follows it, or it is whole in length but its checksum fails.
    #[error("{path}: record at byte {offset} is corrupt ({why}){}", follows(*next))]
    Corrupt {
        /// The log.
        path: PathBuf,
        /// Where the record starts.
        offset: u64,
        /// Which check it fails.
        why: &'static str,
        /// Where the first whole record after it starts, if one does.
        next: Option<u64>,
    },
    /// [`LogWriter::open`] found corruption (not a torn tail) and refuses to
    /// append to the file or to cut it, since cutting would lose whole records.
    #[error(
        "{path}: record at byte {offset} is corrupt ({why}){}; this is not a torn tail, so nothing \
         was cut or appended. Move the file aside and log to a new one (or, to keep only the \
         records before the damage, cut it at byte {offset} yourself: `truncate -s {offset} {path}`)",
        follows(*next)
    )]
    WontCut {
        /// The log.
        path: PathBuf,
        /// Where the corrupt record starts.
        offset: u64,
        /// Which check it fails.
        why: &'static str,
        /// Where the first whole record after it starts, if one does.
        next: Option<u64>,
    },
}

/// The end of a corruption message: what a cut there would lose.
fn follows(next: Option<u64>) -> String {
    match next {
        Some(n) => format!(" and whole records follow it, the first at byte {n}"),
        None => String::new(),
    }
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

/// When a [`LogWriter`] starts a new file: once the next record would take
/// the file past `max_bytes`, `FILE` is renamed `FILE.1` (after `FILE.1` has
/// become `FILE.2`, and so on up to `FILE.{keep}`, the oldest, which the shift
/// replaces) and a fresh `FILE` begins. The log then never holds more than
/// about `(keep + 1) × max_bytes` on disk, and the newest records are always in
/// `FILE`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rotation {
    /// Largest size of one file, header included (a single record larger
    /// than this still gets a file of its own).
    pub max_bytes: u64,
    /// How many earlier files to keep (`FILE.1` to `FILE.{keep}`); 0 keeps none.
    pub keep: u32,
}

impl Rotation {
    /// The name of the `n`th earlier file: `FILE.n`.
    pub fn earlier(path: &Path, n: u32) -> PathBuf {
        let mut name = OsString::from(path.as_os_str());
        name.push(format!(".{n}"));
        PathBuf::from(name)
    }
}

/// Where a hub records the packets it accepts: the `.clog` [`LogWriter`]
/// here, or another format's writer (colony-mcap's MCAP log), so that the hub
/// needs no dependency of any other format.
///
/// The hub calls [`append`](Self::append) for each accepted packet,
/// [`end_round`](Self::end_round) once per round of its loop (at least every
/// 100 ms), and [`finish`](Self::finish) once when it stops. An error from any
/// of them makes the hub log it, drop the sink and serve on without it.
pub trait LogSink: Send {
    /// Records one accepted packet, received at `time` from `source` (it may be buffered).
    fn append(&mut self, time: SystemTime, source: SocketAddr, payload: &[u8]) -> io::Result<()>;
    /// The end of a round of the hub's loop at `now`: hands to the system
    /// what a crash should not lose (the `.clog` writer flushes every round; an
    /// MCAP writer closes its chunk when it is old or large enough).
    fn end_round(&mut self, now: Instant) -> io::Result<()>;
    /// The hub is stopping: completes the log (an MCAP writes its summary).
    /// Nothing is appended after it.
    fn finish(&mut self) -> io::Result<()>;
}

impl LogSink for LogWriter {
    fn append(&mut self, time: SystemTime, source: SocketAddr, payload: &[u8]) -> io::Result<()> {
        LogWriter::append(self, time, source, payload)
    }

    fn end_round(&mut self, _now: Instant) -> io::Result<()> {
        self.flush()
    }

    fn finish(&mut self) -> io::Result<()> {
        self.flush()
    }
}

/// Appends records to a log.
pub struct LogWriter {
    file: BufWriter<File>,
    path: PathBuf,
    /// Bytes in the current file, buffered ones included.
    size: u64,
    rotation: Option<Rotation>,
    /// The latest time of the records the file held when it was opened, µs.
    latest_us: Option<u64>,
}

impl LogWriter {
    /// Opens `path` for appending as [`open`](Self::open) does, and says on the
    /// log (`tracing`) what it cut: what a hub or a recording program does.
    pub fn open_warning(path: impl AsRef<Path>) -> Result<LogWriter, LogError> {
        let path = path.as_ref();
        let (log, torn) = LogWriter::open(path)?;
        if let Some(t) = torn {
            tracing::warn!(path = %path.display(), offset = t.offset, bytes = t.bytes, "cut a torn record from the end of the log");
        }
        Ok(log)
    }

    /// Opens `path` for appending, creating it if needed. A torn tail from an
    /// earlier crash is cut off first, and reported; a log corrupt anywhere
    /// else is refused ([`LogError::WontCut`]) and left as it is.
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
        let mut size = file.metadata().map_err(io_err)?.len();
        let mut torn = None;
        let mut latest_us = None;
        if size == 0 {
            file.write_all(MAGIC).map_err(io_err)?;
            size = MAGIC.len() as u64;
        } else {
            let mut reader = LogReader::from_file(file.try_clone().map_err(io_err)?, path)?;
            for record in reader.by_ref() {
                match record {
                    Ok(r) => latest_us = latest_us.max(Some(r.time_us)),
                    Err(LogError::Corrupt {
                        path,
                        offset,
                        why,
                        next,
                    }) => {
                        return Err(LogError::WontCut {
                            path,
                            offset,
                            why,
                            next,
                        })
                    }
                    Err(e) => return Err(e),
                }
            }
            if let Some(t) = reader.torn_tail() {
                file.set_len(t.offset).map_err(io_err)?;
                size = t.offset;
                torn = Some(t.clone());
            }
        }
        Ok((
            LogWriter {
                file: BufWriter::with_capacity(256 * 1024, file),
                path: path.to_owned(),
                size,
                rotation: None,
                latest_us,
            },
            torn,
        ))
    }

    /// The latest time among the records the file already held when it was
    /// opened (`None` for a new or empty log, or a time this system's clock
    /// cannot hold): a program that stamps records with a clock of its own
    /// starts after it, so the log stays in time order.
    pub fn latest(&self) -> Option<SystemTime> {
        self.latest_us
            .and_then(|us| UNIX_EPOCH.checked_add(std::time::Duration::from_micros(us)))
    }

    /// Rotates the log by size from now on, as `rotation` says.
    pub fn with_rotation(mut self, rotation: Rotation) -> LogWriter {
        self.rotation = Some(rotation);
        self
    }

    /// Appends one record (buffered: call [`flush`](Self::flush) to hand it to the OS).
    pub fn append(
        &mut self,
        time: SystemTime,
        source: SocketAddr,
        payload: &[u8],
    ) -> io::Result<()> {
        // Saturating: a time past u64 microseconds must not wrap to an early one.
        let time_us = colony_wire::auth::unix_micros(time);
        let addr = source.to_string();
        self.append_raw(time_us, &addr, payload)
    }

    fn append_raw(&mut self, time_us: u64, source: &str, payload: &[u8]) -> io::Result<()> {
        let source = &source.as_bytes()[..source.len().min(255)];
        let rest_len = 8 + 1 + source.len() + payload.len();
        if let Some(r) = self.rotation {
            // A file that holds no record yet takes this one whatever its size,
            // so an oversized record cannot make every append rotate.
            let record = 8 + rest_len as u64;
            if self.size > MAGIC.len() as u64 && self.size + record > r.max_bytes {
                self.rotate(r.keep)?;
            }
        }
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
        self.file.write_all(payload)?;
        self.size += 8 + rest_len as u64;
        Ok(())
    }

    /// Closes the current file as `FILE.1` (shifting the earlier ones up, the
    /// oldest beyond `keep` replaced) and begins a fresh `FILE`.
    fn rotate(&mut self, keep: u32) -> io::Result<()> {
        self.file.flush()?;
        if keep == 0 {
            std::fs::remove_file(&self.path)?;
        } else {
            // `rename` replaces its target, so shifting `FILE.{keep-1}` onto
            // `FILE.{keep}` is what deletes the oldest.
            for n in (1..keep).rev() {
                let from = Rotation::earlier(&self.path, n);
                match std::fs::rename(&from, Rotation::earlier(&self.path, n + 1)) {
                    Err(e) if e.kind() == io::ErrorKind::NotFound => {}
                    other => other?,
                }
            }
            std::fs::rename(&self.path, Rotation::earlier(&self.path, 1))?;
        }
        // `create_new`: should someone else have made a `FILE` meanwhile, fail
        // rather than append to (or cut) a file that is not ours.
        let mut file = OpenOptions::new()
            .append(true)
            .create_new(true)
            .open(&self.path)?;
        file.write_all(MAGIC)?;
        self.file = BufWriter::with_capacity(self.file.capacity(), file);
        self.size = MAGIC.len() as u64;
        Ok(())
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

/// What is wrong with the record at the reader's offset.
struct Damage {
    why: &'static str,
    /// Whether the record cannot be whole (as a write cut short leaves it),
    /// as opposed to whole in length but failing a check.
    partial: bool,
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

    fn io_error(&mut self, source: io::Error) -> Option<Result<Record, LogError>> {
        self.done = true;
        Some(Err(LogError::Io {
            path: self.path.clone(),
            source,
        }))
    }

    fn read_record(&mut self) -> Option<Result<Record, LogError>> {
        if self.done || self.offset >= self.len {
            return None;
        }
        let remaining = self.len - self.offset;
        if remaining < 8 {
            return self.damaged(Damage {
                why: "shorter than a record's header",
                partial: true,
            });
        }
        let mut head = [0u8; 8];
        if let Err(e) = self.file.read_exact(&mut head) {
            return self.io_error(e);
        }
        let (rest_len, crc) = header(&head);
        if rest_len < (FIXED - 8) as u64 || rest_len > MAX_REST as u64 {
            return self.damaged(Damage {
                why: "impossible length",
                partial: true,
            });
        }
        if remaining - 8 < rest_len {
            return self.damaged(Damage {
                why: "length runs past the end of the file",
                partial: true,
            });
        }
        let mut rest = vec![0u8; rest_len as usize];
        if let Err(e) = self.file.read_exact(&mut rest) {
            return self.io_error(e);
        }
        if let Err(why) = check_rest(&rest, crc) {
            return self.damaged(Damage {
                why,
                partial: false,
            });
        }
        let time_us = u64::from_le_bytes(rest[..8].try_into().expect("8 bytes"));
        let addr_len = rest[8] as usize;
        let source = String::from_utf8_lossy(&rest[9..9 + addr_len]).into_owned();
        let payload = rest[9 + addr_len..].to_vec();
        self.offset += 8 + rest_len;
        Some(Ok(Record {
            time_us,
            source,
            payload,
        }))
    }

    /// Ends the reading at a damaged record: a torn tail when it cannot be
    /// whole and no whole record follows it, corruption otherwise.
    fn damaged(&mut self, damage: Damage) -> Option<Result<Record, LogError>> {
        self.done = true;
        let offset = self.offset;
        let next = match self.next_whole_record(offset) {
            Ok(next) => next,
            Err(e) => return self.io_error(e),
        };
        if damage.partial && next.is_none() {
            self.torn = Some(TornTail {
                offset,
                bytes: self.len - offset,
            });
            return None;
        }
        Some(Err(LogError::Corrupt {
            path: self.path.clone(),
            offset,
            why: damage.why,
            next,
        }))
    }

    /// Where the first whole record (plausible length, inside the file,
    /// checksum right) starting after `damaged` is, if any. A write cut short
    /// leaves none, so finding one proves the damage is no torn tail. None can
    /// be found inside a logged packet either: a length field holds NUL bytes,
    /// which the hub never accepts in a packet. Reads in windows, so a long log
    /// costs memory for one window only.
    fn next_whole_record(&mut self, damaged: u64) -> io::Result<Option<u64>> {
        let mut buf = Vec::new();
        let mut base = damaged + 1;
        while base + FIXED as u64 <= self.len {
            let want = (self.len - base).min((SCAN_WINDOW + 8 + MAX_REST) as u64) as usize;
            buf.resize(want, 0);
            self.file.seek(SeekFrom::Start(base))?;
            self.file.read_exact(&mut buf)?;
            for i in 0..want.min(SCAN_WINDOW) {
                if is_whole_record(&buf[i..]) {
                    return Ok(Some(base + i as u64));
                }
            }
            base += SCAN_WINDOW as u64;
        }
        Ok(None)
    }
}

/// A record header's length of the rest and checksum.
fn header(head: &[u8; 8]) -> (u64, u32) {
    let rest_len = u32::from_le_bytes([head[0], head[1], head[2], head[3]]) as u64;
    let crc = u32::from_le_bytes([head[4], head[5], head[6], head[7]]);
    (rest_len, crc)
}

/// Checks the rest of a record (everything after its checksum) against its checksum.
fn check_rest(rest: &[u8], crc: u32) -> Result<(), &'static str> {
    if crc32fast::hash(rest) != crc {
        return Err("checksum mismatch");
    }
    if rest.len() < FIXED - 8 || 9 + rest[8] as usize > rest.len() {
        return Err("address longer than its record");
    }
    Ok(())
}

/// Whether `bytes` begin with a whole, valid record.
fn is_whole_record(bytes: &[u8]) -> bool {
    let Some(head) = bytes.first_chunk::<8>() else {
        return false;
    };
    let (rest_len, crc) = header(head);
    if rest_len < (FIXED - 8) as u64 || rest_len > MAX_REST as u64 {
        return false;
    }
    bytes
        .get(8..8 + rest_len as usize)
        .is_some_and(|rest| check_rest(rest, crc).is_ok())
}

impl Iterator for LogReader {
    type Item = Result<Record, LogError>;
    fn next(&mut self) -> Option<Self::Item> {
        self.read_record()
    }
}
