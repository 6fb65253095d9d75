//! The traffic log: append, read back, survive a torn tail.

use std::fs::OpenOptions;
use std::io::Write;
use std::net::SocketAddr;
use std::time::{Duration, UNIX_EPOCH};

use colony_hub::log::{LogError, LogReader, LogWriter, Record};

fn write_records(path: &std::path::Path, n: u64) -> Vec<Record> {
    let (mut log, torn) = LogWriter::open(path).unwrap();
    assert!(torn.is_none());
    let src: SocketAddr = "127.0.0.1:5000".parse().unwrap();
    let mut written = Vec::new();
    for i in 0..n {
        let payload = format!("@ <vision> 0\nball seq {i}\n").into_bytes();
        let time = UNIX_EPOCH + Duration::from_micros(1_000_000 + i * 33_000);
        log.append(time, src, &payload).unwrap();
        written.push(Record {
            time_us: 1_000_000 + i * 33_000,
            source: src.to_string(),
            payload,
        });
    }
    log.flush().unwrap();
    written
}

fn read_all(path: &std::path::Path) -> (Vec<Record>, Option<u64>) {
    let mut reader = LogReader::open(path).unwrap();
    let records: Vec<Record> = reader.by_ref().map(|r| r.unwrap()).collect();
    (records, reader.torn_tail().map(|t| t.offset))
}

#[test]
fn records_read_back_exactly_as_written() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    let written = write_records(&path, 50);
    let (read, torn) = read_all(&path);
    assert_eq!(read, written);
    assert_eq!(torn, None);
}

#[test]
fn a_torn_last_record_is_reported_and_every_whole_record_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    let written = write_records(&path, 20);
    let full = std::fs::metadata(&path).unwrap().len();
    // Tear the last record at every possible length.
    let last_len = 8 + 8 + 1 + "127.0.0.1:5000".len() as u64 + written[19].payload.len() as u64;
    for cut in 1..last_len {
        let torn_path = dir.path().join(format!("torn{cut}.clog"));
        std::fs::copy(&path, &torn_path).unwrap();
        OpenOptions::new()
            .write(true)
            .open(&torn_path)
            .unwrap()
            .set_len(full - cut)
            .unwrap();
        let (read, torn) = read_all(&torn_path);
        assert_eq!(read, written[..19], "cut {cut}");
        assert_eq!(torn, Some(full - last_len), "cut {cut}");
    }
}

#[test]
fn reopening_a_torn_log_cuts_the_tail_and_appends_after_the_last_whole_record() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    let written = write_records(&path, 5);
    let full = std::fs::metadata(&path).unwrap().len();
    OpenOptions::new()
        .write(true)
        .open(&path)
        .unwrap()
        .set_len(full - 3)
        .unwrap();
    let (mut log, torn) = LogWriter::open(&path).unwrap();
    assert!(torn.is_some());
    log.append_record(&written[4]).unwrap();
    log.flush().unwrap();
    drop(log);
    let (read, torn) = read_all(&path);
    assert_eq!(read, written);
    assert_eq!(torn, None);
}

#[test]
fn garbage_appended_by_a_crash_is_a_torn_tail_not_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    let written = write_records(&path, 3);
    OpenOptions::new()
        .append(true)
        .open(&path)
        .unwrap()
        .write_all(&[0xff; 40])
        .unwrap();
    let (read, torn) = read_all(&path);
    assert_eq!(read, written);
    assert!(torn.is_some());
}

#[test]
fn a_corrupt_record_in_the_middle_is_an_error_naming_its_offset() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    write_records(&path, 10);
    let mut bytes = std::fs::read(&path).unwrap();
    let at = 13 + 8 + 20; // inside the first record's payload
    bytes[at] ^= 0x55;
    std::fs::write(&path, &bytes).unwrap();
    let mut reader = LogReader::open(&path).unwrap();
    match reader.next() {
        Some(Err(LogError::Corrupt { offset, .. })) => assert_eq!(offset, 13),
        other => panic!("expected corruption, got {other:?}"),
    }
}

#[test]
fn a_file_that_is_not_a_log_is_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("notes.txt");
    std::fs::write(&path, "hello").unwrap();
    let e = LogReader::open(&path).err().expect("not a log").to_string();
    assert!(e.contains("not a colony traffic log"), "{e}");
    let e = LogWriter::open(&path).err().expect("not a log").to_string();
    assert!(e.contains("not a colony traffic log"), "{e}");
    let missing = LogReader::open(dir.path().join("missing.clog"))
        .err()
        .expect("missing")
        .to_string();
    assert!(missing.contains("missing.clog"), "{missing}");
}

#[test]
fn a_reopened_log_knows_its_latest_record() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    let (fresh, _) = LogWriter::open(&path).unwrap();
    assert_eq!(fresh.latest(), None, "a new log");
    drop(fresh);
    let written = write_records(&path, 20);
    // A record from a clock that ran ahead, then one behind it again: the
    // latest is the greatest time, not the last record's.
    let src: SocketAddr = "127.0.0.1:5000".parse().unwrap();
    let last = written.last().unwrap().time_us;
    let ahead = UNIX_EPOCH + Duration::from_micros(last + 3_600_000_000);
    let (mut log, _) = LogWriter::open(&path).unwrap();
    log.append(ahead, src, b"@ <a> 0\n").unwrap();
    log.append(
        UNIX_EPOCH + Duration::from_micros(last + 1),
        src,
        b"@ <a> 0\n",
    )
    .unwrap();
    log.flush().unwrap();
    drop(log);
    let (reopened, _) = LogWriter::open(&path).unwrap();
    assert_eq!(reopened.latest(), Some(ahead));
}

#[test]
fn a_time_past_what_the_log_can_hold_is_kept_as_its_latest_not_wrapped() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    let (mut log, _) = LogWriter::open(&path).unwrap();
    // 2e19 µs is past u64::MAX (1.8e19): it was cut to its low 64 bits, about 1970 + 46,000 years.
    let far = UNIX_EPOCH
        .checked_add(Duration::from_secs(20_000_000_000_000))
        .unwrap();
    let src: SocketAddr = "127.0.0.1:5000".parse().unwrap();
    log.append(far, src, b"@ <a> 0\n").unwrap();
    log.flush().unwrap();
    let (read, _) = read_all(&path);
    assert_eq!(read[0].time_us, u64::MAX);
}
