//! Damage to a traffic log: a torn tail (what a crash leaves) is read past and
//! cut, anything else is corruption, reported with its offset and never cut.

use std::net::SocketAddr;
use std::path::Path;
use std::time::{Duration, UNIX_EPOCH};

use colony_hub::log::{LogError, LogReader, LogWriter, Record};

const HEADER: u64 = 13; // `colony-log 1\n`

/// Writes `n` records and returns them with the offset each starts at.
fn write_records(path: &Path, n: u64) -> (Vec<Record>, Vec<u64>) {
    let (mut log, torn) = LogWriter::open(path).unwrap();
    assert!(torn.is_none());
    let src: SocketAddr = "127.0.0.1:5000".parse().unwrap();
    let mut written = Vec::new();
    let mut offsets = Vec::new();
    let mut at = HEADER;
    for i in 0..n {
        let payload = format!("@ <vision> 0\nball seq {i}\n").into_bytes();
        log.append(
            UNIX_EPOCH + Duration::from_micros(1_000_000 + i),
            src,
            &payload,
        )
        .unwrap();
        offsets.push(at);
        at += 8 + 8 + 1 + src.to_string().len() as u64 + payload.len() as u64;
        written.push(Record {
            time_us: 1_000_000 + i,
            source: src.to_string(),
            payload,
        });
    }
    log.flush().unwrap();
    assert_eq!(std::fs::metadata(path).unwrap().len(), at);
    (written, offsets)
}

/// Sets the length field of the record at `offset`.
fn set_length(path: &Path, offset: u64, length: u32) {
    let mut bytes = std::fs::read(path).unwrap();
    let at = offset as usize;
    bytes[at..at + 4].copy_from_slice(&length.to_le_bytes());
    std::fs::write(path, &bytes).unwrap();
}

/// Every record the reader returns before it stops, and how it stopped.
fn read(path: &Path) -> (Vec<Record>, Result<Option<u64>, LogError>) {
    let mut reader = LogReader::open(path).unwrap();
    let mut records = Vec::new();
    for r in reader.by_ref() {
        match r {
            Ok(r) => records.push(r),
            Err(e) => return (records, Err(e)),
        }
    }
    let torn = reader.torn_tail().map(|t| t.offset);
    (records, Ok(torn))
}

fn expect_corrupt_at(path: &Path, offset: u64, before: &[Record]) {
    let (records, end) = read(path);
    assert_eq!(records, before);
    match end {
        Err(LogError::Corrupt { offset: o, .. }) => assert_eq!(o, offset),
        other => panic!("expected corruption at byte {offset}, got {other:?}"),
    }
}

/// The hub opening the log must refuse it, name the offset, and leave every byte as it was.
fn expect_writer_refuses(path: &Path, offset: u64) {
    let before = std::fs::read(path).unwrap();
    let e = LogWriter::open(path)
        .err()
        .expect("a corrupt log is refused")
        .to_string();
    assert!(e.contains(&format!("byte {offset}")), "{e}");
    assert_eq!(std::fs::read(path).unwrap(), before, "the log was changed");
}

#[test]
fn a_length_corrupted_past_the_end_in_the_middle_is_corruption_not_a_torn_tail() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    let (written, offsets) = write_records(&path, 10);
    // A plausible length that runs past the end of the file, and one no record can have.
    for length in [5_000, u32::MAX] {
        set_length(&path, offsets[4], length);
        expect_corrupt_at(&path, offsets[4], &written[..4]);
        expect_writer_refuses(&path, offsets[4]);
    }
}

#[test]
fn corruption_names_where_the_next_whole_record_starts() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    let (_, offsets) = write_records(&path, 10);
    set_length(&path, offsets[2], u32::MAX);
    let (_, end) = read(&path);
    let e = end.expect_err("corrupt");
    assert!(
        e.to_string().contains(&format!("byte {}", offsets[3])),
        "{e}"
    );
}

#[test]
fn a_length_corrupted_to_zero_in_the_middle_is_corruption() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    let (written, offsets) = write_records(&path, 6);
    set_length(&path, offsets[1], 0);
    expect_corrupt_at(&path, offsets[1], &written[..1]);
    expect_writer_refuses(&path, offsets[1]);
}

#[test]
fn a_whole_last_record_with_a_bad_checksum_is_corruption_not_cut() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    let (written, offsets) = write_records(&path, 5);
    let mut bytes = std::fs::read(&path).unwrap();
    let last = bytes.len() - 3; // inside the last record's payload
    bytes[last] ^= 0x20;
    std::fs::write(&path, &bytes).unwrap();
    expect_corrupt_at(&path, offsets[4], &written[..4]);
    expect_writer_refuses(&path, offsets[4]);
}

#[test]
fn zeros_left_by_a_power_cut_are_a_torn_tail_and_are_cut() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    let (written, _) = write_records(&path, 4);
    let full = std::fs::metadata(&path).unwrap().len();
    let mut bytes = std::fs::read(&path).unwrap();
    bytes.extend([0u8; 4096]);
    std::fs::write(&path, &bytes).unwrap();
    let (records, end) = read(&path);
    assert_eq!(records, written);
    assert_eq!(end.unwrap(), Some(full));
    let (mut log, torn) = LogWriter::open(&path).unwrap();
    assert_eq!(torn.map(|t| (t.offset, t.bytes)), Some((full, 4096)));
    log.append_record(&written[0]).unwrap();
    log.flush().unwrap();
    drop(log);
    let (records, end) = read(&path);
    assert_eq!(records.len(), 5);
    assert_eq!(end.unwrap(), None);
}

#[test]
fn a_buffer_of_records_cut_short_is_a_torn_tail() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    let (written, offsets) = write_records(&path, 8);
    // A crash in the middle of writing the last three records: the file ends
    // inside the sixth, which claims more bytes than there are.
    let cut = offsets[5] + 20;
    std::fs::OpenOptions::new()
        .write(true)
        .open(&path)
        .unwrap()
        .set_len(cut)
        .unwrap();
    let (records, end) = read(&path);
    assert_eq!(records, written[..5]);
    assert_eq!(end.unwrap(), Some(offsets[5]));
    let (_, torn) = LogWriter::open(&path).unwrap();
    assert_eq!(torn.map(|t| t.offset), Some(offsets[5]));
    assert_eq!(std::fs::metadata(&path).unwrap().len(), offsets[5]);
}

#[test]
fn whole_records_megabytes_after_the_damage_are_still_found() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    let (written, offsets) = write_records(&path, 3);
    let other = dir.path().join("other.clog");
    write_records(&other, 2);
    set_length(&path, offsets[2], u32::MAX);
    let mut bytes = std::fs::read(&path).unwrap();
    // Three windows' worth of bytes no record starts in, then whole records.
    bytes.extend(std::iter::repeat_n(0x5a, 3 << 20));
    let next = bytes.len() as u64;
    bytes.extend(&std::fs::read(&other).unwrap()[HEADER as usize..]);
    std::fs::write(&path, &bytes).unwrap();
    let (records, end) = read(&path);
    assert_eq!(records, written[..2]);
    match end {
        Err(LogError::Corrupt {
            offset, next: n, ..
        }) => {
            assert_eq!((offset, n), (offsets[2], Some(next)));
        }
        other => panic!("expected corruption, got {other:?}"),
    }
    expect_writer_refuses(&path, offsets[2]);
}
