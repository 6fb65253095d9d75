//! MCAP logs end to end: the hub writes one during `colony demo`, `colony log export` makes one
//! of a `.clog` the hub wrote, and the `mcap` package from PyPI (a reader colony did not write)
//! reads both whole; one replays into a monitor that draws the run; a hub killed while logging
//! at 1 kHz leaves a file `colony log` reads as far as its whole chunks and `colony log recover`
//! makes valid; a file damaged in the middle is an error with its offset.
//!
//! Needs python3 with `mcap` and `zstandard` in target/pydeps: `scripts/test` installs them.

use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use colony_hub::log::{LogReader, Record};
use colony_mcap::{McapReader, TrafficReader};
use colony_testkit::cli::{colony, run_bounded, HubProcess};
use colony_testkit::client::{drain_until, subscribed};
use colony_testkit::monitor::with_token;
use colony_testkit::web::Ws;
use colony_wire::Packet;
use serde_json::Value;

/// `colony log export FROM --mcap TO` with these filters, to its end.
fn export(from: &Path, to: &Path, filters: &[&str]) -> (Option<i32>, String, String) {
    let (from, to) = (from.to_str().unwrap(), to.to_str().unwrap());
    let mut args = vec!["log", "export", from, "--mcap", to];
    args.extend_from_slice(filters);
    run_bounded(&args, "warn")
}

/// `colony log recover FROM TO`, to its end.
fn recover(from: &Path, to: &Path) -> (Option<i32>, String, String) {
    run_bounded(
        &[
            "log",
            "recover",
            from.to_str().unwrap(),
            to.to_str().unwrap(),
        ],
        "warn",
    )
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A directory that lives as long as the test binary.
fn scratch() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| tempfile::tempdir().unwrap()).path()
}

/// Every message of an MCAP as the `mcap` package from PyPI reads it, then its summary.
fn python_reads(file: &Path) -> (Vec<Value>, Value) {
    let deps = std::env::var_os("COLONY_PYDEPS")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("target/pydeps"));
    assert!(
        deps.join("mcap").exists() && deps.join("zstandard").exists(),
        "the mcap and zstandard Python packages are not in {}: run the README's test command, \
         `scripts/test`, which installs them (python3 -m pip install --target target/pydeps \
         mcap==1.6.0 zstandard==0.25.0)",
        deps.display()
    );
    let mut child = std::process::Command::new("python3")
        .arg(root().join("python/tests/mcap_dump.py"))
        .arg(file)
        .env("PYTHONPATH", &deps)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run python3");
    let out = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || std::io::read_to_string(out).unwrap());
    let deadline = Instant::now() + Duration::from_secs(60);
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(
            Instant::now() < deadline,
            "the Python reader took over 60 s"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    let err = std::io::read_to_string(child.stderr.take().unwrap()).unwrap();
    assert!(
        status.success(),
        "the mcap package could not read {}: {err}",
        file.display()
    );
    let mut lines: Vec<Value> = reader
        .join()
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let summary = lines.pop().expect("a summary line")["summary"].clone();
    (lines, summary)
}

/// Holds what Python read to `records`, one for one, in order.
fn same_messages(python: &[Value], summary: &Value, records: &[Record]) {
    assert_eq!(python.len(), records.len(), "message count");
    assert_eq!(summary["message_count"], records.len() as u64);
    assert!(summary["chunk_indexes"].as_u64().unwrap() >= 1, "{summary}");
    for (i, (m, r)) in python.iter().zip(records).enumerate() {
        let packet = Packet::parse(&r.payload).unwrap();
        assert_eq!(m["topic"], colony_schema::topic(&packet), "message {i}");
        assert_eq!(m["message_encoding"], "json");
        assert_eq!(m["schema_encoding"], "jsonschema");
        assert_eq!(m["schema_is_object"], true);
        assert!(m["schema"].as_str().is_some_and(|s| !s.is_empty()));
        assert_eq!(m["sequence"], i as u64, "in order");
        assert_eq!(m["log_time"], r.time_us * 1000, "message {i}");
        assert_eq!(m["publish_time"], r.time_us * 1000);
        assert_eq!(
            m["message"]["packet"].as_str().unwrap().as_bytes(),
            r.payload.as_slice(),
            "message {i} keeps its packet's text"
        );
        assert_eq!(m["message"]["source"], r.source.as_str());
    }
}

/// The robots' poses in a `vision` message as Python decoded it.
fn poses(m: &Value) -> Vec<(i64, f64, f64)> {
    m["message"]["lines"]["robot"]
        .as_array()
        .expect("robot lines")
        .iter()
        .map(|r| {
            (
                r["id"].as_i64().expect("an integer id"),
                r["x"].as_f64().expect("a number x"),
                r["y"].as_f64().expect("a number y"),
            )
        })
        .collect()
}

/// Runs `colony demo` for 3 s logging to `name` in the scratch directory.
fn demo_log(name: &str) -> PathBuf {
    let log = scratch().join(name);
    let log_arg = log.to_str().unwrap();
    let (code, _, err) = run_bounded(
        &[
            "demo",
            "--hub-bind",
            "127.0.0.1:0",
            "--monitor-bind",
            "127.0.0.1:0",
            "--seconds",
            "3",
            "--log",
            log_arg,
        ],
        "warn",
    );
    assert_eq!(code, Some(0), "colony demo: {err}");
    log
}

/// An MCAP the demo's hub wrote, made once for the tests that read it.
fn demo_mcap() -> &'static Path {
    static LOG: OnceLock<PathBuf> = OnceLock::new();
    LOG.get_or_init(|| demo_log("demo.mcap"))
}

fn read_mcap(file: &Path) -> Vec<Record> {
    McapReader::open(file)
        .unwrap()
        .map(Result::unwrap)
        .collect()
}

#[test]
fn the_hub_writes_an_mcap_during_the_demo_that_the_mcap_package_reads_whole() {
    let file = demo_mcap();
    let records = read_mcap(file);
    assert!(records.len() > 50, "{} messages", records.len());
    let (python, summary) = python_reads(file);
    same_messages(&python, &summary, &records);
    let vision: Vec<&Value> = python.iter().filter(|m| m["topic"] == "vision").collect();
    assert!(vision.len() > 10, "{} vision messages", vision.len());
    let last = poses(vision.last().unwrap());
    assert_eq!(last.len(), 4, "the demo's four robots: {last:?}");
    assert!(last.iter().all(|(_, x, y)| x.is_finite() && y.is_finite()));
    // The JSON's poses are the packet's.
    let text = vision.last().unwrap()["message"]["packet"]
        .as_str()
        .unwrap();
    let packet = Packet::parse(text.as_bytes()).unwrap();
    let robot = packet.lines().find(|l| l.label() == "robot").unwrap();
    let x = robot.f64("x").unwrap();
    assert!((x - last[0].1).abs() < 1e-9, "{x} against {:?}", last[0]);
}

#[test]
fn a_clog_the_hub_wrote_exports_to_an_mcap_the_mcap_package_reads_whole() {
    let clog = demo_log("demo.clog");
    let records: Vec<Record> = LogReader::open(&clog)
        .unwrap()
        .map(Result::unwrap)
        .collect();
    assert!(records.len() > 50);
    let out = scratch().join("exported.mcap");
    let (code, _, err) = export(&clog, &out, &[]);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        err.contains(&format!("wrote {} messages", records.len())),
        "{err}"
    );
    let (python, summary) = python_reads(&out);
    same_messages(&python, &summary, &records);
    let vision = python.iter().rfind(|m| m["topic"] == "vision").unwrap();
    assert_eq!(poses(vision).len(), 4);

    // The filters of `colony log` apply: only vision, from the second second on.
    let t0 = records[0].time_us;
    let kept: Vec<Record> = records
        .iter()
        .filter(|r| r.time_us - t0 >= 1_000_000)
        .filter(|r| Packet::parse(&r.payload).unwrap().has_subject("vision"))
        .cloned()
        .collect();
    let part = scratch().join("vision.mcap");
    let (code, _, err) = export(&clog, &part, &["--channel", "vision", "--from", "1"]);
    assert_eq!(code, Some(0), "{err}");
    let (python, summary) = python_reads(&part);
    same_messages(&python, &summary, &kept);
    // An existing file is not written over.
    let (code, _, err) = export(&clog, &part, &[]);
    assert_eq!(code, Some(1));
    assert!(err.contains("exists"), "{err}");
}

#[test]
fn an_mcap_log_replays_into_a_monitor_that_draws_the_run() {
    let file = demo_mcap();
    let hub = HubProcess::start(&[]);
    let monitor = colony_monitor::Monitor::start(&colony_monitor::MonitorConfig {
        hub: hub.addr.to_string(),
        bind: "127.0.0.1:0".into(),
        ..Default::default()
    })
    .unwrap();
    let mut ws = Ws::connect(monitor.local_addr(), &with_token(&monitor, "/ws"));
    // The last poses the log holds for each robot.
    let mut last = std::collections::BTreeMap::new();
    for r in read_mcap(file) {
        let p = Packet::parse(&r.payload).unwrap();
        if p.has_subject("vision") {
            for l in p.lines().filter(|l| l.label() == "robot") {
                let f = &l;
                let id = f.f64("id").unwrap() as i64;
                last.insert(id, (f.f64("x").unwrap(), f.f64("y").unwrap()));
            }
        }
    }
    assert_eq!(last.len(), 4);
    let addr = hub.addr.to_string();
    let (code, _, err) = run_bounded(
        &[
            "replay",
            "--hub",
            &addr,
            "--speed",
            "4",
            file.to_str().unwrap(),
        ],
        "warn",
    );
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("replayed"), "{err}");
    // The monitor's world holds each robot where the log last put it.
    let world = ws.until(Duration::from_secs(10), "the run's last poses", |v| {
        v["t"] == "world"
            && last.iter().all(|(id, (x, y))| {
                v["robots"].as_array().is_some_and(|rs| {
                    // Each robot is [id, x, y, theta, carrying], to the centimetre.
                    rs.iter().any(|r| {
                        r[0].as_i64() == Some(*id)
                            && (r[1].as_f64().unwrap_or(f64::NAN) - x).abs() < 0.01
                            && (r[2].as_f64().unwrap_or(f64::NAN) - y).abs() < 0.01
                    })
                })
            })
    });
    assert_eq!(world["robots"].as_array().unwrap().len(), 4, "{world}");
    monitor.shutdown().unwrap();
}

/// Publishes numbered packets on `load` at 1 kHz for `seconds`, then kills the hub with
/// SIGKILL; returns how many were sent.
fn load_then_kill(hub: &mut HubProcess, seconds: f64) -> u64 {
    let mut client = colony_client::UdpClient::connect(hub.addr).unwrap();
    let start = Instant::now();
    let mut n = 0u64;
    while start.elapsed().as_secs_f64() < seconds {
        let due = start + Duration::from_micros(n * 1000);
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
        client
            .publish(format!("@ <load> 0\nmsg n {n}\n").as_bytes())
            .unwrap();
        n += 1;
    }
    // Let the hub take in what is in its socket, then kill it mid-run.
    std::thread::sleep(Duration::from_millis(20));
    hub.kill();
    n
}

/// The `n` of every logged `load` packet, in order.
fn numbers(records: impl Iterator<Item = Record>) -> Vec<u64> {
    records
        .filter_map(|r| {
            let p = Packet::parse(&r.payload).ok()?;
            if !p.has_subject("load") {
                return None;
            }
            p.lines().next()?.f64("n").ok().map(|n| n as u64)
        })
        .collect()
}

#[test]
fn a_hub_killed_while_logging_mcap_at_1khz_loses_at_most_its_last_chunk() {
    let dir = tempfile::tempdir().unwrap();
    let mcap = dir.path().join("killed.mcap");
    let mut hub = HubProcess::start(&["--log", mcap.to_str().unwrap()]);
    let sent = load_then_kill(&mut hub, 3.0);

    // What `colony log` reads: a prefix of what was sent, without a gap, and a report of it.
    let (code, out, err) = run_bounded(&["log", mcap.to_str().unwrap(), "-c", "load"], "warn");
    assert_eq!(code, Some(0), "{err}");
    assert!(
        err.contains("ends before its writer finished") && err.contains("log recover"),
        "{err}"
    );
    let listed = out.matches("@ <load>").count() as u64;
    let mut log = TrafficReader::open(&mcap).unwrap();
    let got = numbers(log.by_ref().map(Result::unwrap));
    assert_eq!(got.len() as u64, listed);
    assert_eq!(
        got,
        (0..got.len() as u64).collect::<Vec<_>>(),
        "a prefix, in order"
    );
    // Its first chunk was a second old two seconds before the kill.
    assert!(
        !got.is_empty() && got.len() as u64 <= sent,
        "{} of {sent}",
        got.len()
    );
    let lost = sent - got.len() as u64;
    eprintln!("# MCAP: kill -9 at 1 kHz lost {lost} of {sent} packets (the chunk in memory)");

    // `colony log recover` writes a valid MCAP with all of them.
    let fixed = dir.path().join("fixed.mcap");
    let (code, _, err) = recover(&mcap, &fixed);
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("recovered"), "{err}");
    let (python, summary) = python_reads(&fixed);
    let all = read_mcap(&fixed);
    same_messages(&python, &summary, &all);
    assert_eq!(numbers(all.into_iter()), got);
}

#[test]
fn a_hub_killed_while_logging_clog_at_1khz_keeps_every_packet_it_flushed_in_order() {
    let dir = tempfile::tempdir().unwrap();
    let clog = dir.path().join("killed.clog");
    let mut hub = HubProcess::start(&["--log", clog.to_str().unwrap()]);
    let sent = load_then_kill(&mut hub, 3.0);
    let got = numbers(LogReader::open(&clog).unwrap().map(Result::unwrap));
    assert_eq!(
        got,
        (0..got.len() as u64).collect::<Vec<_>>(),
        "a prefix, in order"
    );
    let lost = sent - got.len() as u64;
    eprintln!("# .clog: kill -9 at 1 kHz lost {lost} of {sent} packets");
}

#[test]
fn an_mcap_damaged_in_the_middle_is_an_error_with_its_offset() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("bad.mcap");
    let mut w = colony_mcap::McapLogWriter::create(&file).unwrap();
    for n in 0..3000u64 {
        let text = format!("@ <vision> 20\nrobot id 3 x {n}.25 y 1 theta 0\n");
        w.append_raw(1_700_000_000_000_000 + n, "127.0.0.1:1", text.as_bytes())
            .unwrap();
        if n % 500 == 499 {
            w.close_chunk().unwrap();
        }
    }
    w.finish().unwrap();
    let mut bytes = std::fs::read(&file).unwrap();
    let original = bytes.clone();
    let mid = bytes.len() / 2;
    for b in &mut bytes[mid..mid + 8] {
        *b = !*b;
    }
    std::fs::write(&file, &bytes).unwrap();
    for args in [
        vec!["log"],
        vec!["replay", "--hub", "127.0.0.1:9", "--speed", "1000"],
    ] {
        let mut args = args.clone();
        args.push(file.to_str().unwrap());
        let (code, _, err) = run_bounded(&args, "warn");
        assert_eq!(code, Some(1), "{args:?}: {err}");
        assert!(
            err.contains("is corrupt") && err.contains("at byte"),
            "{err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
    // An export that fails on the damage leaves neither OUT nor a partial
    // file, so that it can be run again.
    let out = dir.path().join("out.mcap");
    let partial = dir.path().join("out.mcap.partial");
    for _ in 0..2 {
        let (code, _, err) = export(&file, &out, &[]);
        assert_eq!(code, Some(1), "{err}");
        assert!(
            err.contains("is corrupt") && err.contains("was not written"),
            "{err}"
        );
        assert!(!out.exists() && !partial.exists(), "{err}");
    }
    // Damage to the first chunk, which holds the channel records, loses only
    // that chunk's messages: the later ones on the same channel are recovered.
    let mut fixed = original;
    let header_len = u64::from_le_bytes(fixed[9..17].try_into().unwrap()) as usize;
    let chunk = 8 + 9 + header_len;
    assert_eq!(fixed[chunk], 0x06);
    let chunk_len = u64::from_le_bytes(fixed[chunk + 1..chunk + 9].try_into().unwrap()) as usize;
    fixed[chunk + 9 + chunk_len - 16] ^= 0x5a;
    std::fs::write(&file, &fixed).unwrap();
    let (code, _, err) = recover(&file, &out);
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("recovered 2500 messages"), "{err}");
    assert!(!partial.exists());
    assert_eq!(read_mcap(&out).len(), 2500);
}

/// A chunk whose inner record runs past its records, and a zstd chunk that
/// decompresses to more than it says, as a hostile file would hold them: an
/// error from `colony log`, a skipped chunk for `colony log recover`, never a
/// panic.
#[test]
fn a_forged_chunk_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let chunk = |compression: &str, size: u64, records: &[u8], padding: &[u8]| {
        let mut body = vec![0u8; 16];
        body.extend_from_slice(&size.to_le_bytes());
        body.extend_from_slice(&0u32.to_le_bytes());
        body.extend_from_slice(&(compression.len() as u32).to_le_bytes());
        body.extend_from_slice(compression.as_bytes());
        body.extend_from_slice(&(records.len() as u64).to_le_bytes());
        body.extend_from_slice(records);
        body.extend_from_slice(padding);
        let mut file = colony_mcap::MAGIC.to_vec();
        file.push(0x06);
        file.extend_from_slice(&(body.len() as u64).to_le_bytes());
        file.extend_from_slice(&body);
        file
    };
    let mut past = vec![0x05];
    past.extend_from_slice(&27u64.to_le_bytes());
    past.extend_from_slice(&[0u8; 22]);
    let mut big = vec![0x80];
    big.extend_from_slice(&1991u64.to_le_bytes());
    big.resize(2000, 0);
    let big = zstd::bulk::compress(&big, 3).unwrap();
    for (i, bytes) in [
        chunk("", past.len() as u64, &past, &[0u8; 64]),
        chunk("zstd", 1000, &big, &[]),
    ]
    .into_iter()
    .enumerate()
    {
        let file = dir.path().join(format!("forged{i}.mcap"));
        std::fs::write(&file, &bytes).unwrap();
        let (code, _, err) = run_bounded(&["log", file.to_str().unwrap()], "warn");
        assert_eq!(code, Some(1), "{err}");
        assert!(
            err.contains("is corrupt") && !err.contains("panicked"),
            "{err}"
        );
        let out = dir.path().join(format!("out{i}.mcap"));
        let (code, _, err) = recover(&file, &out);
        assert_eq!(code, Some(0), "{err}");
        assert!(
            err.contains("skipped the corrupt record at byte 8"),
            "{err}"
        );
    }
}

/// BENCHMARKS.md's figures: packets a kill -9 loses at 1 kHz, for each format, with the kill
/// falling at different points of the MCAP writer's one-second chunk.
#[test]
#[ignore = "a measurement (about 40 s): cargo test -p colony --test mcap_logs kill_loss -- --ignored --nocapture"]
fn kill_loss_at_1khz_for_both_formats() {
    let dir = tempfile::tempdir().unwrap();
    for (format, ext) in [("MCAP", "mcap"), (".clog", "clog")] {
        let mut losses = Vec::new();
        for (i, seconds) in [2.1, 2.3, 2.5, 2.7, 2.9, 3.1].into_iter().enumerate() {
            let file = dir.path().join(format!("{i}.{ext}"));
            let mut hub = HubProcess::start(&["--log", file.to_str().unwrap()]);
            let sent = load_then_kill(&mut hub, seconds);
            let got = numbers(TrafficReader::open(&file).unwrap().map(Result::unwrap));
            assert_eq!(got, (0..got.len() as u64).collect::<Vec<_>>());
            losses.push(sent - got.len() as u64);
        }
        let mean = losses.iter().sum::<u64>() as f64 / losses.len() as f64;
        eprintln!(
            "# {format}: lost {losses:?} packets (mean {mean:.0}, max {})",
            losses.iter().max().unwrap()
        );
    }
}

#[test]
fn a_hub_refuses_to_rotate_an_mcap_log_or_to_write_over_one() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("run.mcap");
    let (code, _, err) = run_bounded(
        &[
            "hub",
            "--bind",
            "127.0.0.1:0",
            "--log",
            file.to_str().unwrap(),
            "--log-max",
            "1M",
        ],
        "warn",
    );
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("--log-max rotates .clog logs only"), "{err}");
    std::fs::write(&file, b"an earlier run").unwrap();
    let (code, _, err) = run_bounded(
        &[
            "hub",
            "--bind",
            "127.0.0.1:0",
            "--log",
            file.to_str().unwrap(),
        ],
        "warn",
    );
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("is never appended to"), "{err}");
    assert_eq!(std::fs::read(&file).unwrap(), b"an earlier run");
}

#[test]
fn a_hub_whose_mcap_log_fails_says_so_and_serves_on() {
    use std::io::Read as _;
    let dir = tempfile::tempdir().unwrap();
    // A pipe whose reader goes away: the next write fails (EPIPE) as a full disk's would.
    let fifo = dir.path().join("log.mcap");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    assert!(made.is_ok_and(|s| s.success()), "mkfifo");
    let (close, closing) = std::sync::mpsc::channel::<()>();
    let reader_path = fifo.clone();
    let reader = std::thread::spawn(move || {
        let mut pipe = std::fs::File::open(&reader_path).unwrap();
        let mut magic = [0u8; 8];
        pipe.read_exact(&mut magic).unwrap();
        let _ = closing.recv_timeout(Duration::from_secs(20));
        magic
    });
    let err_file = dir.path().join("hub.err");
    let mut child = colony()
        .args([
            "hub",
            "--bind",
            "127.0.0.1:0",
            "--log",
            fifo.to_str().unwrap(),
        ])
        .env("COLONY_LOG", "info")
        .env("NO_COLOR", "1")
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&err_file).unwrap())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(10);
    let addr = loop {
        let text = std::fs::read_to_string(&err_file).unwrap();
        if let Some(rest) = text.split("addr=").nth(1) {
            break rest.split_whitespace().next().unwrap().to_string();
        }
        assert!(Instant::now() < deadline, "the hub never listened: {text}");
        std::thread::sleep(Duration::from_millis(20));
    };
    close.send(()).unwrap();
    assert_eq!(&reader.join().unwrap(), colony_mcap::MAGIC);
    let hub: std::net::SocketAddr = addr.parse().unwrap();
    let mut sub = subscribed(hub, &["after"]);
    let mut client = colony_client::UdpClient::connect(hub).unwrap();
    // Traffic for over a second: a chunk is closed and its write fails.
    let deadline = Instant::now() + Duration::from_secs(10);
    while !std::fs::read_to_string(&err_file)
        .unwrap()
        .contains("traffic log failed")
    {
        assert!(Instant::now() < deadline, "the log never failed");
        client.publish(b"@ <load> 0\nmsg n 1\n").unwrap();
        std::thread::sleep(Duration::from_millis(50));
    }
    // The hub serves on, without its log.
    client
        .publish(b"@ <after> 0\nnote text \"still here\"\n")
        .unwrap();
    let got = drain_until(&mut sub, Instant::now() + Duration::from_secs(5), |g| {
        !g.is_empty()
    });
    assert!(got.iter().any(|p| p.contains("still here")), "{got:?}");
    assert!(
        child.try_wait().unwrap().is_none(),
        "the hub is still running"
    );
    let _ = child.kill();
    let _ = child.wait();
    let text = std::fs::read_to_string(&err_file).unwrap();
    assert!(!text.contains("panicked"), "{text}");
}
