//! Traffic logs as a user meets them: corruption is reported (non-zero exit)
//! and never cut by the hub, a torn tail is, `--log-max` rotates, and what
//! the hub writes to a pipe carries no colour codes.

use std::io::{BufRead as _, BufReader};
use std::net::{SocketAddr, UdpSocket};
use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};
use std::time::{Duration, Instant, UNIX_EPOCH};

use colony_hub::log::LogWriter;
use colony_testkit::cli::{self, colony, HubProcess};

const HEADER: u64 = 13; // `colony-log 1\n`

/// A log of `n` records on channel `vision`; returns where each record starts.
fn write_log(path: &Path, n: u64) -> Vec<u64> {
    let (mut w, _) = LogWriter::open(path).unwrap();
    let src: SocketAddr = "127.0.0.1:5000".parse().unwrap();
    let mut offsets = Vec::new();
    let mut at = HEADER;
    for i in 0..n {
        let payload = format!("@ <vision> 0\nball seq {i}\n");
        w.append(
            UNIX_EPOCH + Duration::from_millis(1_000 + i),
            src,
            payload.as_bytes(),
        )
        .unwrap();
        offsets.push(at);
        at += 8 + 8 + 1 + 14 + payload.len() as u64;
    }
    w.flush().unwrap();
    offsets
}

/// Overwrites the length field of the record at `offset` with one that runs past the end.
fn corrupt_length(path: &Path, offset: u64) {
    let mut bytes = std::fs::read(path).unwrap();
    let at = offset as usize;
    bytes[at..at + 4].copy_from_slice(&50_000u32.to_le_bytes());
    std::fs::write(path, bytes).unwrap();
}

/// Cuts the last `n` bytes off, as a crash in the middle of a write does.
fn tear_tail(path: &Path, n: u64) {
    let len = std::fs::metadata(path).unwrap().len();
    std::fs::OpenOptions::new()
        .write(true)
        .open(path)
        .unwrap()
        .set_len(len - n)
        .unwrap();
}

fn corrupt_log(dir: &Path) -> (PathBuf, u64) {
    let path = dir.join("traffic.clog");
    let offsets = write_log(&path, 10);
    corrupt_length(&path, offsets[4]);
    (path, offsets[4])
}

/// Runs `colony args` to its end, killing it after a generous wait.
fn run_bounded(args: &[&str]) -> (Option<i32>, String, String) {
    cli::run_bounded(args, "info")
}

#[test]
fn colony_log_reports_a_corrupt_length_mid_file_with_its_offset_and_fails() {
    let dir = tempfile::tempdir().unwrap();
    let (path, offset) = corrupt_log(dir.path());
    let (code, out, err) = run_bounded(&["log", path.to_str().unwrap()]);
    assert_eq!(code, Some(1), "{err}");
    assert_eq!(out.matches("ball seq").count(), 4, "{out}");
    assert!(
        err.contains("corrupt") && err.contains(&format!("byte {offset}")),
        "{err}"
    );
    assert!(!err.contains("torn"), "{err}");
}

#[test]
fn colony_replay_of_a_corrupt_log_fails() {
    let dir = tempfile::tempdir().unwrap();
    let (path, offset) = corrupt_log(dir.path());
    let sink = UdpSocket::bind("127.0.0.1:0").unwrap();
    let hub = sink.local_addr().unwrap().to_string();
    let (code, _, err) = run_bounded(&[
        "replay",
        "--hub",
        &hub,
        "--speed",
        "1000",
        path.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains(&format!("byte {offset}")), "{err}");
}

#[test]
fn the_hub_refuses_to_cut_a_log_corrupt_mid_file() {
    let dir = tempfile::tempdir().unwrap();
    let (path, offset) = corrupt_log(dir.path());
    let before = std::fs::read(&path).unwrap();
    let (code, _, err) = run_bounded(&[
        "hub",
        "--bind",
        "127.0.0.1:0",
        "--log",
        path.to_str().unwrap(),
    ]);
    assert_eq!(
        code,
        Some(1),
        "the hub must refuse the log, not serve: {err}"
    );
    assert!(
        err.contains(&format!("byte {offset}")) && err.contains("not a torn tail"),
        "{err}"
    );
    assert_eq!(std::fs::read(&path).unwrap(), before, "the log was changed");
}

/// Starts a hub with `args` and stderr to a pipe (colour not forbidden by
/// NO_COLOR), and returns every byte it wrote to stderr until it said where
/// it listens, and the child.
fn hub_stderr_until_listening(args: &[&str]) -> (Vec<u8>, std::process::Child) {
    let mut child = colony()
        .args(["hub", "--bind", "127.0.0.1:0"])
        .args(args)
        .env("COLONY_LOG", "info")
        .env_remove("NO_COLOR")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start colony hub");
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut seen = Vec::new();
        loop {
            let mut line = Vec::new();
            match stderr.read_until(b'\n', &mut line) {
                Ok(0) | Err(_) => break,
                Ok(_) => {}
            }
            seen.extend(&line);
            if String::from_utf8_lossy(&line).contains("hub listening") {
                break;
            }
        }
        let _ = tx.send(seen);
    });
    let seen = rx
        .recv_timeout(Duration::from_secs(20))
        .expect("the hub says where it listens");
    (seen, child)
}

#[test]
fn no_colour_codes_go_to_a_pipe() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("torn.clog");
    write_log(&path, 3);
    tear_tail(&path, 5);
    let (seen, mut child) = hub_stderr_until_listening(&["--log", path.to_str().unwrap()]);
    let _ = child.kill();
    let _ = child.wait();
    let text = String::from_utf8_lossy(&seen);
    assert!(text.contains("cut a torn record"), "{text}");
    assert!(!seen.contains(&0x1b), "colour codes in a pipe: {text:?}");
}

#[test]
fn the_hub_cuts_a_torn_tail_and_keeps_every_whole_record() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("torn.clog");
    let offsets = write_log(&path, 6);
    tear_tail(&path, 5);
    let hub = HubProcess::start(&["--log", path.to_str().unwrap()]);
    drop(hub);
    assert_eq!(std::fs::metadata(&path).unwrap().len(), offsets[5]);
    let o: Output = colony()
        .args(["log", path.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success());
    assert_eq!(
        String::from_utf8_lossy(&o.stdout)
            .matches("ball seq")
            .count(),
        5
    );
}

#[test]
fn log_max_rotates_the_hubs_log_and_keeps_as_many_as_asked() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hub.clog");
    let p = path.to_str().unwrap();
    let hub = HubProcess::start(&["--log", p, "--log-max", "64K", "--log-keep", "2"]);
    let publisher = UdpSocket::bind("127.0.0.1:0").unwrap();
    let packet = format!("@ <vision> 0\nball pad {}\n", "x".repeat(1_000));
    let earlier = |n: u32| PathBuf::from(format!("{p}.{n}"));
    // Publish until the log has rotated three times (a generous wait for a busy machine).
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut rotations = 0;
    let mut last_len = 0;
    while rotations < 3 {
        assert!(
            Instant::now() < deadline,
            "the log rotated {rotations} times"
        );
        for _ in 0..20 {
            publisher.send_to(packet.as_bytes(), hub.addr).unwrap();
        }
        std::thread::sleep(Duration::from_millis(20));
        let len = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        if len < last_len {
            rotations += 1;
        }
        last_len = len;
    }
    drop(hub);
    assert!(earlier(1).exists() && earlier(2).exists());
    assert!(!earlier(3).exists(), "only two rotated logs are kept");
    for f in [path.clone(), earlier(1), earlier(2)] {
        assert!(std::fs::metadata(&f).unwrap().len() <= 64 * 1024);
        let o = colony().args(["log"]).arg(&f).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
}

#[test]
fn log_info_summarises_channels_and_span_instead_of_listing_packets() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.clog");
    write_log(&path, 10);
    let (mut w, _) = LogWriter::open(&path).unwrap();
    let src: SocketAddr = "127.0.0.1:5001".parse().unwrap();
    // A subject set, and two records that are no packets (a subject may hold no
    // right-to-left override).
    for (i, p) in [
        &b"@ <radio> <mobile> 0\nstop\n"[..],
        "@ <x\u{202e}y> 0\nz\n".as_bytes(),
        b"not a packet",
    ]
    .iter()
    .enumerate()
    {
        w.append(UNIX_EPOCH + Duration::from_millis(2_000 + i as u64), src, p)
            .unwrap();
    }
    w.flush().unwrap();
    let (code, out, err) = run_bounded(&["log", "info", path.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{err}");
    assert!(out.contains("records:  13"), "{out}");
    assert!(out.contains("2 not packets"), "{out}");
    assert!(out.contains("duration: 1.002 s"), "{out}");
    assert!(
        out.lines()
            .any(|l| l.trim_start().starts_with("vision") && l.contains(" 10 packets")),
        "{out}"
    );
    assert!(out.contains("radio mobile"), "{out}");
    assert!(!out.contains("ball seq"), "it summarises: {out}");
    assert!(!out.contains('\u{202e}'), "{out}");
}
