//! Reading an MCAP traffic log back, whole chunk by whole chunk.

use std::collections::{HashMap, VecDeque};
use std::fs::File;
use std::io::{self, BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use colony_hub::log::Record;

use crate::{McapLogError, MAGIC};

/// Longest record (and largest uncompressed chunk) a reader believes: the
/// mcap crate reads whole records into memory, so a forged length must not
/// make it allocate without bound. colony's chunks are about 1 MiB.
pub const MAX_RECORD: u64 = 64 << 20;

const OP_HEADER: u8 = 0x01;
const OP_FOOTER: u8 = 0x02;
const OP_SCHEMA: u8 = 0x03;
const OP_CHANNEL: u8 = 0x04;
const OP_MESSAGE: u8 = 0x05;
const OP_CHUNK: u8 = 0x06;
const OP_DATA_END: u8 = 0x0F;

/// How an MCAP log ends.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum McapEnd {
    /// Its writer finished it: the data section's end record is there (and
    /// the summary after it, which this reader does not need).
    Finished,
    /// It ends before its writer finished, as a crash leaves it: every whole
    /// record before `offset` was read; the `bytes` from there on (a chunk cut
    /// short, none at all when the writer died between chunks) were not.
    Torn {
        /// Where the first record that is not whole starts.
        offset: u64,
        /// How many bytes from there to the end of the file.
        bytes: u64,
    },
}

/// Reads the colony messages of an MCAP log as [`Record`]s, in the order
/// they were written, holding one chunk in memory at a time.
///
/// A file a crash cut short is read as far as its last whole record and
/// [`end`](Self::end) says where it was torn; anything else wrong (a chunk
/// failing its checksum, a record with an impossible length or opcode) is a
/// [`McapLogError::Corrupt`] with the record's offset. Messages that colony
/// did not write (not JSON, or JSON without a packet's text) are skipped and
/// counted ([`foreign`](Self::foreign)).
pub struct McapReader {
    file: BufReader<File>,
    path: PathBuf,
    offset: u64,
    len: u64,
    /// Whether the file ends in the MCAP magic, as only a finished file does:
    /// then nothing in it is a torn end, and a record cut short is corruption.
    ends_whole: bool,
    /// For each channel id seen, whether its messages are JSON.
    channels: HashMap<u16, bool>,
    pending: VecDeque<Record>,
    end: Option<McapEnd>,
    done: bool,
    chunks: u64,
    messages: u64,
    foreign: u64,
    skip_corrupt: bool,
    skipped: Vec<(u64, String)>,
}

impl McapReader {
    /// Opens an MCAP log and checks its magic.
    pub fn open(path: impl AsRef<Path>) -> Result<McapReader, McapLogError> {
        let path = path.as_ref();
        let io_err = |source| McapLogError::Io {
            path: path.to_owned(),
            source,
        };
        let file = File::open(path).map_err(io_err)?;
        let len = file.metadata().map_err(io_err)?.len();
        let mut file = BufReader::with_capacity(256 * 1024, file);
        let mut magic = [0u8; 8];
        match file.read_exact(&mut magic) {
            Ok(()) if &magic == MAGIC => {}
            Err(e) if e.kind() != io::ErrorKind::UnexpectedEof => return Err(io_err(e)),
            _ => {
                return Err(McapLogError::NotAnMcap {
                    path: path.to_owned(),
                })
            }
        }
        let mut tail = [0u8; 8];
        let ends_whole = len >= 16 && {
            file.seek(SeekFrom::Start(len - 8)).map_err(io_err)?;
            file.read_exact(&mut tail).map_err(io_err)?;
            file.seek(SeekFrom::Start(8)).map_err(io_err)?;
            &tail == MAGIC
        };
        Ok(McapReader {
            file,
            path: path.to_owned(),
            offset: 8,
            len,
            ends_whole,
            channels: HashMap::new(),
            pending: VecDeque::new(),
            end: None,
            done: false,
            chunks: 0,
            messages: 0,
            foreign: 0,
            skip_corrupt: false,
            skipped: Vec::new(),
        })
    }

    /// Skips a corrupt record whose length is whole (a chunk failing its
    /// checksum) and reads on, instead of ending in an error: for recovery.
    /// Each one skipped is listed by [`skipped`](Self::skipped).
    pub fn skipping_corrupt(mut self) -> McapReader {
        self.skip_corrupt = true;
        self
    }

    /// How the file ends, once reading has reached its end.
    pub fn end(&self) -> Option<&McapEnd> {
        self.end.as_ref()
    }

    /// Whole chunks read so far.
    pub fn chunks(&self) -> u64 {
        self.chunks
    }

    /// colony messages read so far.
    pub fn messages(&self) -> u64 {
        self.messages
    }

    /// Messages skipped because colony did not write them.
    pub fn foreign(&self) -> u64 {
        self.foreign
    }

    /// Corrupt records skipped (offset, what was wrong), when skipping.
    pub fn skipped(&self) -> &[(u64, String)] {
        &self.skipped
    }

    fn corrupt(&self, offset: u64, why: impl Into<String>) -> McapLogError {
        McapLogError::Corrupt {
            path: self.path.clone(),
            offset,
            why: why.into(),
        }
    }

    fn io(&self, source: io::Error) -> McapLogError {
        McapLogError::Io {
            path: self.path.clone(),
            source,
        }
    }

    /// Ends the reading at a record that is not whole: the torn end a crash
    /// leaves, unless the file ends as only a finished one does.
    fn torn(&mut self) -> Result<(), McapLogError> {
        if self.ends_whole {
            self.done = true;
            return Err(self.corrupt(
                self.offset,
                "a record cut short in a file that ends as a finished one does (its length is damaged)",
            ));
        }
        self.end = Some(McapEnd::Torn {
            offset: self.offset,
            bytes: self.len - self.offset,
        });
        self.done = true;
        Ok(())
    }

    /// Reads one top-level record, queueing the messages it holds.
    fn step(&mut self) -> Result<(), McapLogError> {
        let remaining = self.len - self.offset;
        if remaining < 9 {
            // Nothing, or less than a record's opcode and length.
            return self.torn();
        }
        let mut head = [0u8; 9];
        self.file.read_exact(&mut head).map_err(|e| self.io(e))?;
        let opcode = head[0];
        let len = u64::from_le_bytes(head[1..].try_into().expect("8 bytes"));
        if opcode == 0 && len == 0 && self.rest_is_zeros().map_err(|e| self.io(e))? {
            // What a power cut leaves at the end of a file.
            return self.torn();
        }
        if !(OP_HEADER..=OP_DATA_END).contains(&opcode) && opcode < 0x80 {
            return Err(self.corrupt(self.offset, format!("no record has opcode {opcode:#04x}")));
        }
        if len > remaining - 9 {
            // A record cut short: what a crash leaves at the end.
            return self.torn();
        }
        let start = self.offset;
        let next = self.offset + 9 + len;
        match opcode {
            OP_DATA_END | OP_FOOTER => {
                self.end = Some(McapEnd::Finished);
                self.done = true;
                return Ok(());
            }
            OP_CHUNK | OP_CHANNEL | OP_MESSAGE | OP_SCHEMA => {
                if len > MAX_RECORD {
                    return Err(self.corrupt(
                        start,
                        format!("length {len} beyond the {MAX_RECORD} bytes a reader believes"),
                    ));
                }
                let mut record = vec![0u8; 9 + len as usize];
                record[..9].copy_from_slice(&head);
                self.file
                    .read_exact(&mut record[9..])
                    .map_err(|e| self.io(e))?;
                self.offset = next;
                match self.decode(&record) {
                    Ok(found) => {
                        if opcode == OP_CHUNK {
                            self.chunks += 1;
                        }
                        self.messages += found.len() as u64;
                        self.pending.extend(found);
                    }
                    Err(why) if self.skip_corrupt => self.skipped.push((start, why)),
                    Err(why) => return Err(self.corrupt(start, why)),
                }
            }
            _ => {
                // Indexes, attachments, metadata: not needed to read the messages.
                self.file
                    .seek(SeekFrom::Start(next))
                    .map_err(|e| self.io(e))?;
                self.offset = next;
            }
        }
        Ok(())
    }

    /// Whether everything from the offset on is zeros (reading in pieces).
    fn rest_is_zeros(&mut self) -> io::Result<bool> {
        let mut buf = vec![0u8; 64 * 1024];
        let mut at = self.offset;
        self.file.seek(SeekFrom::Start(at))?;
        while at < self.len {
            let n = ((self.len - at) as usize).min(buf.len());
            self.file.read_exact(&mut buf[..n])?;
            if buf[..n].iter().any(|&b| b != 0) {
                self.file.seek(SeekFrom::Start(self.offset + 9))?;
                return Ok(false);
            }
            at += n as u64;
        }
        Ok(true)
    }

    /// The colony messages in one whole record (a chunk, a channel or a
    /// message), decompressing and checking a chunk; channels are noted.
    ///
    /// A chunk is decompressed here, not by the mcap crate's reader (whose
    /// arithmetic trusts a chunk's sizes): only no compression or zstd, into
    /// at most `uncompressed_size` bytes (itself at most [`MAX_RECORD`]), and
    /// the result must be exactly that long. Its CRC is checked unless it is
    /// 0, which MCAP lets a writer write for "not computed" (colony's writer
    /// always computes it); the sizes bound a chunk either way. The records
    /// inside are walked with every length checked against what is left.
    fn decode(&mut self, record: &[u8]) -> Result<Vec<Record>, String> {
        let mut found = Vec::new();
        if record[0] != OP_CHUNK {
            self.walk(record, &mut found)?;
            return Ok(found);
        }
        let (header, data) = match mcap::parse_record(OP_CHUNK, &record[9..]) {
            Ok(mcap::records::Record::Chunk { header, data }) => (header, data),
            Ok(_) => return Err("not a chunk".into()),
            Err(e) => return Err(e.to_string()),
        };
        if header.uncompressed_size > MAX_RECORD {
            return Err(format!(
                "uncompressed size {} beyond the {MAX_RECORD} bytes a reader believes",
                header.uncompressed_size
            ));
        }
        let size = header.uncompressed_size as usize;
        let inner: std::borrow::Cow<[u8]> = match header.compression.as_str() {
            "" => data,
            "zstd" => zstd::bulk::decompress(&data, size)
                .map_err(|e| {
                    format!(
                        "zstd data that does not decompress into its uncompressed size {size}: {e}"
                    )
                })?
                .into(),
            other => {
                return Err(format!(
                    "compression {other:?}: colony reads only zstd or none"
                ))
            }
        };
        if inner.len() != size {
            return Err(format!(
                "{} bytes of records where the chunk says {size}",
                inner.len()
            ));
        }
        if header.uncompressed_crc != 0 {
            let crc = crc32fast::hash(&inner);
            if crc != header.uncompressed_crc {
                return Err(format!(
                    "records' CRC {crc:#010x} where the chunk says {:#010x}",
                    header.uncompressed_crc
                ));
            }
        }
        self.walk(&inner, &mut found)?;
        Ok(found)
    }

    /// Walks whole records (a chunk's contents, or one top-level record),
    /// noting channels and collecting colony messages.
    fn walk(&mut self, mut rest: &[u8], found: &mut Vec<Record>) -> Result<(), String> {
        while !rest.is_empty() {
            if rest.len() < 9 {
                return Err("a record cut short inside a chunk".into());
            }
            let opcode = rest[0];
            let len = u64::from_le_bytes(rest[1..9].try_into().expect("8 bytes"));
            let after = &rest[9..];
            if len > after.len() as u64 {
                return Err(format!(
                    "a record of {len} bytes where {} are left",
                    after.len()
                ));
            }
            let (body, next) = after.split_at(len as usize);
            rest = next;
            match opcode {
                OP_CHANNEL | OP_MESSAGE => {
                    match mcap::parse_record(opcode, body).map_err(|e| e.to_string())? {
                        mcap::records::Record::Channel(c) => {
                            let json = c.message_encoding == colony_schema::MESSAGE_ENCODING;
                            self.channels.insert(c.id, json);
                        }
                        mcap::records::Record::Message { header, data } => {
                            match self.to_record(header.channel_id, header.log_time, &data) {
                                Some(r) => found.push(r),
                                None => self.foreign += 1,
                            }
                        }
                        _ => {}
                    }
                }
                OP_SCHEMA => {}
                op if op < 0x80 => {
                    return Err(format!("a record with opcode {op:#04x} inside a chunk"))
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// A message as a [`Record`], if colony wrote it. A message on a channel
    /// never seen (its channel record was in a chunk that was damaged and
    /// skipped) is still colony's if its data is: colony's JSON carries the
    /// packet's text, from which the channel follows.
    fn to_record(&self, channel: u16, log_time: u64, data: &[u8]) -> Option<Record> {
        if self.channels.get(&channel) == Some(&false) {
            return None;
        }
        let (text, source) = colony_schema::packet_text(data)?;
        Some(Record {
            time_us: log_time / 1000,
            source: source.unwrap_or_default(),
            payload: text.into_bytes(),
        })
    }
}

impl Iterator for McapReader {
    type Item = Result<Record, McapLogError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if let Some(r) = self.pending.pop_front() {
                return Some(Ok(r));
            }
            if self.done {
                return None;
            }
            if let Err(e) = self.step() {
                self.done = true;
                return Some(Err(e));
            }
        }
    }
}
