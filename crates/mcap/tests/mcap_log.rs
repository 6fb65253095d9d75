//! The MCAP log written, read back whole, torn by a crash, damaged, and recovered.

use std::path::Path;
use std::time::{Duration, Instant};

use colony_hub::log::{LogSink, Record};
use colony_mcap::{recover, McapEnd, McapLogError, McapLogWriter, McapReader, TrafficReader};

fn record(i: u64) -> Record {
    let payload = if i % 3 == 0 {
        format!("@ <vision> 20\nstep n {i} part 0 parts 1\nrobot id 3 x {i}.5 y -2 theta 0.1\n")
    } else if i % 3 == 1 {
        format!("@ <radio> 5\nsay n {i} text \"hello {i}\"\n")
    } else {
        format!("@ <team.1> <team.2> 0\nping n {i}\n")
    };
    Record {
        time_us: 1_700_000_000_000_000 + i * 1000,
        source: format!("127.0.0.1:{}", 5000 + i % 7),
        payload: payload.into_bytes(),
    }
}

/// Writes `n` records, closing a chunk every `per_chunk`, and leaves the file unfinished when `finish` is false.
fn write(path: &Path, n: u64, per_chunk: u64, finish: bool) {
    let mut w = McapLogWriter::create(path).unwrap();
    for i in 0..n {
        assert!(w.append_record(&record(i)).unwrap());
        if (i + 1) % per_chunk == 0 {
            w.close_chunk().unwrap();
        }
    }
    if finish {
        w.finish().unwrap();
    } else {
        // As a kill -9 leaves it: the chunk in memory never reaches the file.
        std::mem::forget(w);
    }
}

fn read_all(path: &Path) -> (Vec<Record>, Option<McapEnd>) {
    let mut r = McapReader::open(path).unwrap();
    let got: Vec<Record> = r.by_ref().map(Result::unwrap).collect();
    (got, r.end().cloned())
}

#[test]
fn every_record_comes_back_in_order_with_its_time_and_source() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.mcap");
    write(&path, 500, 100, true);
    let (got, end) = read_all(&path);
    assert_eq!(end, Some(McapEnd::Finished));
    assert_eq!(got, (0..500).map(record).collect::<Vec<_>>());
}

#[test]
fn a_file_cut_anywhere_reads_its_whole_chunks_and_says_where_it_was_torn() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.mcap");
    write(&path, 450, 100, false);
    let whole = std::fs::read(&path).unwrap();
    // Unfinished: the four closed chunks are there, the last 50 are lost.
    let (got, end) = read_all(&path);
    assert_eq!(got.len(), 400);
    assert!(
        matches!(end, Some(McapEnd::Torn { bytes: 0, .. })),
        "{end:?}"
    );
    let cut_path = dir.path().join("cut.mcap");
    let mut last = usize::MAX;
    for cut in (8..whole.len()).step_by(97) {
        std::fs::write(&cut_path, &whole[..cut]).unwrap();
        let (got, end) = read_all(&cut_path);
        assert_eq!(got.len() % 100, 0, "cut at {cut}");
        assert_eq!(got, (0..got.len() as u64).map(record).collect::<Vec<_>>());
        let Some(McapEnd::Torn { offset, bytes }) = end else {
            panic!("cut at {cut}: {end:?}")
        };
        assert_eq!(offset + bytes, cut as u64);
        assert!(last == usize::MAX || got.len() >= last);
        last = got.len();
    }
}

#[test]
fn recovery_rewrites_a_torn_file_as_a_finished_one() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.mcap");
    write(&path, 450, 100, false);
    let whole = std::fs::read(&path).unwrap();
    std::fs::write(&path, &whole[..whole.len() - 10]).unwrap();
    let out = dir.path().join("b.mcap");
    let r = recover(&path, &out).unwrap();
    // The cut falls in the message indexes after the fourth chunk: all four are whole.
    assert_eq!(r.messages, 400);
    assert!(matches!(r.end, McapEnd::Torn { .. }));
    let (got, end) = read_all(&out);
    assert_eq!(end, Some(McapEnd::Finished));
    assert_eq!(got, (0..400).map(record).collect::<Vec<_>>());
    // The mcap crate's own reader, which insists on a summary, reads it.
    let bytes = std::fs::read(&out).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
    assert_eq!(summary.stats.unwrap().message_count, 400);
    assert_eq!(mcap::MessageStream::new(&bytes).unwrap().count(), 400);
}

#[test]
fn a_chunk_damaged_in_the_middle_is_an_error_with_its_offset() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.mcap");
    write(&path, 500, 100, true);
    let mut bytes = std::fs::read(&path).unwrap();
    let mid = bytes.len() / 3;
    for b in &mut bytes[mid..mid + 16] {
        *b ^= 0x5a;
    }
    std::fs::write(&path, &bytes).unwrap();
    let mut r = McapReader::open(&path).unwrap();
    let err = r.find_map(Result::err).expect("an error");
    match &err {
        McapLogError::Corrupt { offset, .. } => assert!(*offset <= mid as u64),
        e => panic!("{e}"),
    }
    assert!(err.to_string().contains("at byte"), "{err}");
    // Recovery skips the damaged chunk and keeps the rest.
    let out = dir.path().join("b.mcap");
    let rec = recover(&path, &out).unwrap();
    assert_eq!(rec.skipped.len(), 1, "{rec:?}");
    assert!(rec.messages >= 400);
}

#[test]
fn no_damage_makes_the_reader_panic() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.mcap");
    write(&path, 300, 100, true);
    let whole = std::fs::read(&path).unwrap();
    let bad = dir.path().join("bad.mcap");
    let mut seed = 0x9e3779b97f4a7c15u64;
    for _ in 0..300 {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        let mut bytes = whole.clone();
        let at = 8 + (seed as usize) % (bytes.len() - 8);
        bytes[at] = (seed >> 32) as u8;
        if seed % 5 == 0 {
            // A forged length.
            let at = 8 + (seed as usize >> 3) % (bytes.len() - 16);
            bytes[at..at + 8].copy_from_slice(&u64::MAX.to_le_bytes());
        }
        std::fs::write(&bad, &bytes).unwrap();
        let mut r = McapReader::open(&bad).unwrap();
        for x in r.by_ref() {
            if x.is_err() {
                break;
            }
        }
    }
}

#[test]
fn an_existing_file_is_not_written_over() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.mcap");
    std::fs::write(&path, b"keep me").unwrap();
    let err = McapLogWriter::create(&path).err().expect("refused");
    assert!(matches!(err, McapLogError::Exists { .. }), "{err}");
    assert_eq!(std::fs::read(&path).unwrap(), b"keep me");
}

#[test]
fn the_hub_sink_closes_a_chunk_a_second_after_a_round_first_holds_one() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.mcap");
    let mut w = McapLogWriter::create(&path).unwrap();
    let t0 = Instant::now();
    let src = "127.0.0.1:9".parse().unwrap();
    LogSink::append(
        &mut w,
        std::time::SystemTime::now(),
        src,
        &record(0).payload,
    )
    .unwrap();
    w.end_round(t0).unwrap();
    w.end_round(t0 + Duration::from_millis(900)).unwrap();
    assert_eq!(read_all(&path).0.len(), 0);
    w.end_round(t0 + Duration::from_millis(1000)).unwrap();
    assert_eq!(read_all(&path).0.len(), 1);
    LogSink::finish(&mut w).unwrap();
    assert_eq!(read_all(&path).1, Some(McapEnd::Finished));
}

#[test]
fn either_format_is_told_by_its_first_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let mcap = dir.path().join("run.clog");
    write(&mcap, 10, 100, true);
    let clog = dir.path().join("run.mcap");
    let (mut w, _) = colony_hub::log::LogWriter::open(&clog).unwrap();
    w.append_record(&record(1)).unwrap();
    w.flush().unwrap();
    assert!(matches!(
        TrafficReader::open(&mcap).unwrap(),
        TrafficReader::Mcap(..)
    ));
    let got: Vec<_> = TrafficReader::open(&clog)
        .unwrap()
        .map(Result::unwrap)
        .collect();
    assert_eq!(got, vec![record(1)]);
}

#[test]
fn a_write_error_is_returned_not_panicked_and_nothing_follows_it() {
    // /dev/full fails every write with ENOSPC, as a full disk does.
    if !Path::new("/dev/full").exists() {
        return;
    }
    match McapLogWriter::create("/dev/full") {
        Err(e) => assert!(e.to_string().contains("/dev/full"), "{e}"),
        Ok(_) => panic!("writing the header to /dev/full succeeded"),
    }
}

#[test]
fn a_damaged_length_in_a_finished_file_is_corruption_not_a_torn_end() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.mcap");
    write(&path, 500, 100, true);
    let mut bytes = std::fs::read(&path).unwrap();
    // The first chunk follows the magic and the header record.
    let header_len = u64::from_le_bytes(bytes[9..17].try_into().unwrap()) as usize;
    let chunk = 8 + 9 + header_len;
    assert_eq!(bytes[chunk], 0x06, "a chunk");
    bytes[chunk + 1..chunk + 9].copy_from_slice(&(1u64 << 40).to_le_bytes());
    std::fs::write(&path, &bytes).unwrap();
    let mut r = McapReader::open(&path).unwrap();
    match r.find_map(Result::err) {
        Some(McapLogError::Corrupt { offset, .. }) => assert_eq!(offset, chunk as u64),
        other => panic!("{other:?}"),
    }
}
