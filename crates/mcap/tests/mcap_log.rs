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

/// A chunk record: `records` as its (already compressed) data, then `padding`
/// inside the record after it.
fn chunk(compression: &str, size: u64, crc: u32, records: &[u8], padding: &[u8]) -> Vec<u8> {
    let mut body = Vec::new();
    body.extend_from_slice(&0u64.to_le_bytes());
    body.extend_from_slice(&0u64.to_le_bytes());
    body.extend_from_slice(&size.to_le_bytes());
    body.extend_from_slice(&crc.to_le_bytes());
    body.extend_from_slice(&(compression.len() as u32).to_le_bytes());
    body.extend_from_slice(compression.as_bytes());
    body.extend_from_slice(&(records.len() as u64).to_le_bytes());
    body.extend_from_slice(records);
    body.extend_from_slice(padding);
    let mut r = vec![0x06];
    r.extend_from_slice(&(body.len() as u64).to_le_bytes());
    r.extend_from_slice(&body);
    r
}

/// Every chunk in a file: (where its record starts, its whole length).
fn chunks(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut at = 8;
    let mut found = Vec::new();
    while at + 9 <= bytes.len() {
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        if bytes[at] == 0x06 {
            found.push((at, 9 + len));
        }
        if bytes[at] == 0x0f {
            break;
        }
        at += 9 + len;
    }
    found
}

fn read_to_error(path: &Path) -> Option<McapLogError> {
    let mut r = McapReader::open(path).unwrap();
    r.find_map(Result::err)
}

#[test]
fn a_record_running_past_an_uncompressed_chunk_is_corruption_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.mcap");
    // A message record whose length runs 5 bytes past the chunk's records,
    // into padding inside the chunk record; with a CRC of 0 and with a valid one.
    let mut inner = vec![0x05];
    inner.extend_from_slice(&(22u64 + 5).to_le_bytes());
    inner.extend_from_slice(&[0u8; 22]);
    for crc in [0, crc32fast::hash(&inner)] {
        let mut bytes = colony_mcap::MAGIC.to_vec();
        bytes.extend(chunk("", inner.len() as u64, crc, &inner, &[0u8; 64]));
        std::fs::write(&path, &bytes).unwrap();
        match read_to_error(&path) {
            Some(McapLogError::Corrupt { offset: 8, why, .. }) => {
                assert!(why.contains("left"), "{why}")
            }
            other => panic!("{other:?}"),
        }
    }
}

#[test]
fn a_zstd_chunk_larger_than_it_says_is_corruption_not_a_panic_or_a_bomb() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.mcap");
    // Records that decompress to far more than the chunk says: 200 MiB of
    // zeros in well under a megabyte (a zstd bomb), and a small overrun.
    for (real, said) in [(200usize << 20, 1000u64), (2000, 1000)] {
        let mut inner = vec![0x80];
        inner.extend_from_slice(&((real - 9) as u64).to_le_bytes());
        inner.resize(real, 0);
        let compressed = zstd::bulk::compress(&inner, 19).unwrap();
        drop(inner);
        assert!(compressed.len() < 1 << 20);
        let mut bytes = colony_mcap::MAGIC.to_vec();
        bytes.extend(chunk("zstd", said, 0, &compressed, &[]));
        std::fs::write(&path, &bytes).unwrap();
        match read_to_error(&path) {
            Some(McapLogError::Corrupt { offset: 8, why, .. }) => {
                assert!(why.contains("uncompressed size"), "{why}")
            }
            other => panic!("{other:?}"),
        }
    }
}

#[test]
fn a_chunk_compressed_otherwise_than_zstd_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.mcap");
    let mut bytes = colony_mcap::MAGIC.to_vec();
    bytes.extend(chunk("lz4", 4, 0, b"abcd", &[]));
    std::fs::write(&path, &bytes).unwrap();
    match read_to_error(&path) {
        Some(McapLogError::Corrupt { why, .. }) => assert!(why.contains("lz4"), "{why}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn no_damage_makes_the_reader_panic() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.mcap");
    write(&path, 300, 100, true);
    let whole = std::fs::read(&path).unwrap();
    let spans = chunks(&whole);
    assert_eq!(spans.len(), 3);
    let bad = dir.path().join("bad.mcap");
    let mut seed = 0x9e3779b97f4a7c15u64;
    let mut next = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    let mut reached_the_records = 0;
    for round in 0..600 {
        let mut bytes = whole.clone();
        if round % 2 == 0 {
            // Damage inside a chunk's records, with the chunk's sizes and CRC
            // made to match, so that it reaches the record parser.
            let (at, len) = spans[next() as usize % spans.len()];
            let mut records = Vec::new();
            let header_len = 8 + 8 + 8 + 4 + 4 + 4;
            let data = &whole[at + 9 + header_len + 8..at + len];
            records.extend(zstd::bulk::decompress(data, 64 << 20).unwrap());
            for _ in 0..1 + next() % 4 {
                let i = next() as usize % records.len();
                if next() % 3 == 0 && i + 8 <= records.len() {
                    let forged =
                        [u64::MAX, u64::MAX / 2, 1 << 40, next() % 4096][next() as usize % 4];
                    records[i..i + 8].copy_from_slice(&forged.to_le_bytes());
                } else {
                    records[i] = next() as u8;
                }
            }
            let crc = if next() % 2 == 0 {
                0
            } else {
                crc32fast::hash(&records)
            };
            let compressed = zstd::bulk::compress(&records, 1).unwrap();
            let rebuilt = chunk("zstd", records.len() as u64, crc, &compressed, &[]);
            bytes.splice(at..at + len, rebuilt);
            reached_the_records += 1;
        } else {
            let at = 8 + (next() as usize) % (bytes.len() - 8);
            bytes[at] = (next() >> 32) as u8;
            if next() % 5 == 0 {
                // A forged length.
                let at = 8 + (next() as usize >> 3) % (bytes.len() - 16);
                bytes[at..at + 8].copy_from_slice(&u64::MAX.to_le_bytes());
            }
        }
        std::fs::write(&bad, &bytes).unwrap();
        let mut r = McapReader::open(&bad).unwrap();
        for x in r.by_ref() {
            if x.is_err() {
                break;
            }
        }
        let out = dir.path().join(format!("out{round}.mcap"));
        let _ = recover(&bad, &out);
    }
    assert_eq!(reached_the_records, 300);
}

#[test]
fn a_damaged_chunk_loses_only_its_own_messages_not_its_channels_later_ones() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.mcap");
    write(&path, 500, 100, true);
    let mut bytes = std::fs::read(&path).unwrap();
    // The first chunk holds every channel record; damage its data.
    let (at, len) = chunks(&bytes)[0];
    bytes[at + len - 20] ^= 0x5a;
    std::fs::write(&path, &bytes).unwrap();
    let out = dir.path().join("b.mcap");
    let r = recover(&path, &out).unwrap();
    assert_eq!(r.skipped.len(), 1, "{r:?}");
    assert_eq!(r.foreign, 0, "{r:?}");
    assert_eq!(r.messages, 400, "{r:?}");
    let (got, end) = read_all(&out);
    assert_eq!(end, Some(McapEnd::Finished));
    assert_eq!(got, (100..500).map(record).collect::<Vec<_>>());
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
fn a_device_or_a_directory_is_refused() {
    // A device (whose writes may fail, or go nowhere) or a directory is no
    // log (a FIFO is: colony's tests pipe one).
    for path in ["/dev/full", "/dev/null", "/tmp"] {
        if !Path::new(path).exists() {
            continue;
        }
        match McapLogWriter::create(path) {
            Err(e) => {
                let said = format!("{e}: {}", std::error::Error::source(&e).unwrap());
                assert!(
                    said.contains(path) && said.contains("not a regular file"),
                    "{said}"
                )
            }
            Ok(_) => panic!("{path} taken as a log"),
        }
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
