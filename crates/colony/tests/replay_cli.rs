//! `colony replay` against logs with long silences: a forged record time a
//! century ahead is skipped, not waited out, and Ctrl-C or SIGTERM stops a
//! replay in the middle of a wait.

use std::path::Path;
use std::process::{Child, Stdio};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use colony_hub::log::LogWriter;
use colony_testkit::cli::{colony, run_bounded, HubProcess};
use colony_testkit::client::{drain_until, subscribed};

const YEAR: Duration = Duration::from_secs(365 * 24 * 3600);

/// Writes a `.clog` holding `packets`, each at the given time after the first.
fn write_log(path: &Path, packets: &[(Duration, &str)]) {
    let (mut w, _) = LogWriter::open(path).unwrap();
    let t0 = UNIX_EPOCH + Duration::from_secs(1_700_000_000);
    let src = "127.0.0.1:5".parse().unwrap();
    for (at, text) in packets {
        let time: SystemTime = t0 + *at;
        w.append(time, src, text.as_bytes()).unwrap();
    }
    w.flush().unwrap();
}

/// Waits generously for `child` to end; its exit code, or None if it had to be killed.
fn exit_within(child: &mut Child, wait: Duration) -> Option<i32> {
    let deadline = Instant::now() + wait;
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status.code();
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn stderr_of(child: Child) -> String {
    String::from_utf8_lossy(&child.wait_with_output().unwrap().stderr).into_owned()
}

#[test]
fn a_record_a_century_ahead_is_skipped_with_a_note_not_waited_for() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("forged.clog");
    write_log(
        &log,
        &[
            (Duration::ZERO, "@ <vision> 0\nball seq 1\n"),
            (100 * YEAR, "@ <vision> 0\nball seq 2\n"),
            (
                100 * YEAR + Duration::from_millis(10),
                "@ <vision> 0\nball seq 3\n",
            ),
        ],
    );
    let hub = HubProcess::start(&[]);
    let mut sub = subscribed(hub.addr, &["vision"]);
    let mut replay = colony()
        .args(["replay", "--hub", &hub.addr.to_string()])
        .arg(&log)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let got = drain_until(&mut sub, Instant::now() + Duration::from_secs(30), |g| {
        g.len() >= 3
    });
    let code = exit_within(&mut replay, Duration::from_secs(30));
    let err = stderr_of(replay);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(got.len(), 3, "{got:?}\n{err}");
    assert!(
        err.contains("skipped") && err.contains("--max-gap 10 s"),
        "{err}"
    );
}

#[test]
fn sigterm_stops_a_replay_waiting_out_a_gap() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("slow.clog");
    // An hour's silence, under the bound given: the replay waits for it.
    write_log(
        &log,
        &[
            (Duration::ZERO, "@ <vision> 0\nball seq 1\n"),
            (Duration::from_secs(3600), "@ <vision> 0\nball seq 2\n"),
        ],
    );
    let hub = HubProcess::start(&[]);
    let mut sub = subscribed(hub.addr, &["vision"]);
    let mut replay = colony()
        .args([
            "replay",
            "--max-gap",
            "7200",
            "--hub",
            &hub.addr.to_string(),
        ])
        .arg(&log)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let got = drain_until(&mut sub, Instant::now() + Duration::from_secs(30), |g| {
        !g.is_empty()
    });
    if got.is_empty() {
        let _ = replay.kill();
        panic!("the first packet never came: {}", stderr_of(replay));
    }
    let killed = std::process::Command::new("kill")
        .args(["-TERM", &replay.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    // Far less than the hour, however slow the machine.
    let code = exit_within(&mut replay, Duration::from_secs(60));
    let err = stderr_of(replay);
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("replayed 1 packets"), "{err}");
}

#[test]
fn a_max_gap_that_is_not_a_sensible_number_of_seconds_is_refused() {
    for bad in ["-1", "nan", "inf", "-inf", "0", "1e300", "1e-300", "ten"] {
        let flag = format!("--max-gap={bad}");
        let (code, _, err) = run_bounded(&["replay", &flag, "no-such.clog"], "warn");
        assert_eq!(code, Some(2), "--max-gap {bad}: {err}");
        assert!(
            err.contains("--max-gap")
                && (err.contains("must be from") || err.contains("not a number"))
                && !err.contains("panicked"),
            "--max-gap {bad}: {err}"
        );
    }
}
