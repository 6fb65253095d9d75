//! `--log-max`: a traffic log rotated by size, `FILE` → `FILE.1` → `FILE.2` ….

use std::net::{SocketAddr, UdpSocket};
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::{Duration, Instant, UNIX_EPOCH};

use colony_hub::log::{LogReader, LogWriter, Rotation};
use colony_hub::{HubSite, HubSpec};

fn records(path: &Path) -> Vec<Vec<u8>> {
    let mut reader = LogReader::open(path).unwrap();
    let all = reader.by_ref().map(|r| r.unwrap().payload).collect();
    assert!(reader.torn_tail().is_none());
    all
}

#[test]
fn a_rotated_log_keeps_the_newest_records_in_bounded_files() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    let rotation = Rotation {
        max_bytes: 1_000,
        keep: 2,
    };
    let (log, _) = LogWriter::open(&path).unwrap();
    let mut log = log.with_rotation(rotation);
    let src: SocketAddr = "127.0.0.1:5000".parse().unwrap();
    let sent: Vec<Vec<u8>> = (0..200)
        .map(|i| format!("@ <vision> 0\nball seq {i:04}\n").into_bytes())
        .collect();
    for p in &sent {
        log.append(UNIX_EPOCH, src, p).unwrap();
    }
    log.flush().unwrap();
    drop(log);
    let files = [
        Rotation::earlier(&path, 2),
        Rotation::earlier(&path, 1),
        path.clone(),
    ];
    for f in &files {
        let len = std::fs::metadata(f).unwrap().len();
        assert!(len <= rotation.max_bytes, "{} has {len} bytes", f.display());
    }
    assert!(
        !Rotation::earlier(&path, 3).exists(),
        "only two earlier files are kept"
    );
    // Oldest to newest, the kept files hold the last records sent, in order, with no gap.
    let kept: Vec<Vec<u8>> = files.iter().flat_map(|f| records(f)).collect();
    assert!(kept.len() > 20, "{} records kept", kept.len());
    assert_eq!(kept, sent[sent.len() - kept.len()..]);
}

#[test]
fn a_log_already_past_its_bound_rotates_at_the_first_record() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    let (mut log, _) = LogWriter::open(&path).unwrap();
    let src: SocketAddr = "127.0.0.1:5000".parse().unwrap();
    for _ in 0..50 {
        log.append(UNIX_EPOCH, src, b"@ <a> 0\nx n 1\n").unwrap();
    }
    log.flush().unwrap();
    drop(log);
    let (log, _) = LogWriter::open(&path).unwrap();
    let mut log = log.with_rotation(Rotation {
        max_bytes: 500,
        keep: 1,
    });
    log.append(UNIX_EPOCH, src, b"@ <a> 0\nx n 2\n").unwrap();
    log.flush().unwrap();
    assert_eq!(records(&Rotation::earlier(&path, 1)).len(), 50);
    assert_eq!(records(&path), vec![b"@ <a> 0\nx n 2\n".to_vec()]);
}

#[test]
fn keeping_no_earlier_file_starts_afresh() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    let (log, _) = LogWriter::open(&path).unwrap();
    let mut log = log.with_rotation(Rotation {
        max_bytes: 300,
        keep: 0,
    });
    let src: SocketAddr = "127.0.0.1:5000".parse().unwrap();
    for _ in 0..40 {
        log.append(UNIX_EPOCH, src, b"@ <a> 0\nx n 1\n").unwrap();
    }
    log.flush().unwrap();
    assert!(!Rotation::earlier(&path, 1).exists());
    assert!(std::fs::metadata(&path).unwrap().len() <= 300);
    assert!(!records(&path).is_empty());
}

#[test]
fn a_hub_started_with_a_rotation_rotates_its_log() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hub.clog");
    let spec = HubSpec {
        log: Some(path.clone()),
        log_rotation: Some(Rotation {
            max_bytes: 4_096,
            keep: 3,
        }),
        ..HubSpec::new("127.0.0.1:0")
    };
    let stop = Arc::new(AtomicBool::new(false));
    let site = HubSite::here_or_elsewhere(None, &spec, &stop).unwrap();
    let publisher = UdpSocket::bind("127.0.0.1:0").unwrap();
    let packet = format!("@ <vision> 0\nball pad {}\n", "x".repeat(200));
    // The hub flushes its log once per round; publish until the third earlier
    // file exists (a generous wait: a busy machine may be slow).
    let deadline = Instant::now() + Duration::from_secs(30);
    while !Rotation::earlier(&path, 3).exists() {
        assert!(
            Instant::now() < deadline,
            "the log never rotated three times"
        );
        for _ in 0..10 {
            publisher.send_to(packet.as_bytes(), site.addr()).unwrap();
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    site.stop().unwrap();
    assert!(!Rotation::earlier(&path, 4).exists());
    for f in [
        path.clone(),
        Rotation::earlier(&path, 1),
        Rotation::earlier(&path, 2),
        Rotation::earlier(&path, 3),
    ] {
        assert!(std::fs::metadata(&f).unwrap().len() <= 4_096);
        assert!(records(&f).iter().all(|p| p == packet.as_bytes()));
    }
}
