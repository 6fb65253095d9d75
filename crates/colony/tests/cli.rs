//! The `colony` command as a user types it.

use std::fs::OpenOptions;
use std::process::{Output, Stdio};
use std::time::{Duration, Instant};

use colony_testkit::cli::{colony, HubProcess};
use colony_testkit::client::{drain_until, subscribed};

fn run(args: &[&str]) -> Output {
    colony()
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("run colony")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A loopback port with nothing listening on it.
fn closed_port() -> String {
    let s = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    s.local_addr().unwrap().to_string()
}

#[test]
fn a_packet_forged_with_printf_and_nc_reaches_colony_sub() {
    let hub = HubProcess::start(&[]);
    let sub = colony()
        .args([
            "sub",
            "--hub",
            &hub.addr.to_string(),
            "-n",
            "1",
            "vision_out",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Give `sub` time to take its lease; resend until it has answered (a generous wait: a busy
    // machine may be slow to start it).
    let deadline = Instant::now() + Duration::from_secs(30);
    let script = format!(
        "printf '@ <vision_out> 0\\nball x 5.3 y -2.5\\n' | nc -u -w1 127.0.0.1 {}",
        hub.addr.port()
    );
    let mut sub = sub;
    loop {
        std::thread::sleep(Duration::from_millis(200));
        let status = std::process::Command::new("sh")
            .args(["-c", &script])
            .status()
            .expect("sh");
        assert!(
            status.success(),
            "nc is needed for this test: run the README's test command, `scripts/test`, which \
             installs it (or: apt-get install netcat-openbsd)"
        );
        if sub.try_wait().unwrap().is_some() || Instant::now() > deadline {
            break;
        }
    }
    let _ = sub.kill();
    let out = sub.wait_with_output().unwrap();
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        "@ <vision_out> 0\nball x 5.3 y -2.5\n"
    );
}

#[test]
fn pub_and_sub_talk_through_the_hub() {
    let hub = HubProcess::start(&[]);
    let hub_arg = hub.addr.to_string();
    let mut sub = subscribed(hub.addr, &["radio"]);
    let o = run(&[
        "pub",
        "--hub",
        &hub_arg,
        "--priority",
        "3",
        "radio",
        "cmd id 3 vl 0.2 vr 0.2",
        "note text \"go\"",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let got = drain_until(&mut sub, Instant::now() + Duration::from_secs(3), |g| {
        !g.is_empty()
    });
    assert_eq!(
        got,
        ["@ <radio> 3\ncmd id 3 vl 0.2 vr 0.2\nnote text \"go\"\n"]
    );
}

#[test]
fn pub_reads_whole_packets_from_standard_input() {
    let hub = HubProcess::start(&[]);
    let mut sub = subscribed(hub.addr, &["a", "b"]);
    let mut child = colony()
        .args(["pub", "--hub", &hub.addr.to_string()])
        .stdin(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    use std::io::Write;
    child
        .stdin
        .take()
        .unwrap()
        .write_all(b"@ <a> 0\nx y 1\n\n@ <b> 2\nz w 2\n")
        .unwrap();
    assert!(child.wait().unwrap().success());
    let got = drain_until(&mut sub, Instant::now() + Duration::from_secs(3), |g| {
        g.len() >= 2
    });
    assert_eq!(got, ["@ <a> 0\nx y 1\n", "@ <b> 2\nz w 2\n"]);
}

#[test]
fn a_malformed_line_is_refused_with_its_position() {
    let o = run(&["pub", "--hub", &closed_port(), "radio", "cmd id 3 id 4"]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("line 2, column 10") && e.contains("duplicate name `id`"),
        "{e}"
    );
}

#[test]
fn a_bad_hub_address_is_named_in_the_error() {
    let o = run(&["pub", "--hub", "not-an-address", "radio", "cmd id 3"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("not-an-address"), "{}", stderr(&o));
    let o = run(&["hub", "--bind", "999.1.1.1:7400"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("999.1.1.1:7400"), "{}", stderr(&o));
    let o = run(&["hub", "--lease", "-1"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--lease"), "{}", stderr(&o));
}

#[test]
fn pub_says_so_when_no_hub_answers_instead_of_losing_the_packet() {
    let o = run(&["pub", "--hub", &closed_port(), "radio", "cmd id 3"]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("no answer from a hub") && e.contains("not sent"),
        "{e}"
    );
}

#[test]
fn status_says_so_when_no_hub_answers() {
    let o = run(&["status", "--hub", &closed_port(), "--timeout", "0.5"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("no answer from a hub"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn sub_says_so_within_seconds_when_no_hub_answers() {
    let mut sub = colony()
        .args(["sub", "--hub", &closed_port(), "vision"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // It says so after 3 s (it said nothing for 10 s before).
    std::thread::sleep(Duration::from_secs(6));
    let _ = sub.kill();
    let out = sub.wait_with_output().unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("no answer from a hub"), "{e}");
}

#[test]
fn status_lists_clients_channels_and_drops() {
    let hub = HubProcess::start(&[]);
    let _sub = subscribed(hub.addr, &["vision"]);
    let o = run(&[
        "pub",
        "--hub",
        &hub.addr.to_string(),
        "vision",
        "ball x 1 y 2",
    ]);
    assert!(o.status.success());
    // The hub builds its report at most every 100 ms, and `pub` asked for one
    // just before it published: ask until the packet shows.
    let deadline = Instant::now() + Duration::from_secs(10);
    let text = loop {
        let o = run(&["status", "--hub", &hub.addr.to_string()]);
        assert!(o.status.success(), "{}", stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        if text.contains("1 packets") || Instant::now() > deadline {
            break text;
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    assert!(
        text.contains("vision") && text.contains("1 packets") && text.contains("clients:"),
        "{text}"
    );
}

#[test]
fn a_log_with_a_torn_tail_replays_every_whole_record() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("traffic.clog");
    let log_arg = log.to_str().unwrap();
    {
        let hub = HubProcess::start(&["--log", log_arg]);
        let mut publisher = hub.client();
        for seq in 0..20 {
            publisher
                .publish(format!("@ <vision> 0\nball seq {seq}\n").as_bytes())
                .unwrap();
            std::thread::sleep(Duration::from_millis(5));
        }
        std::thread::sleep(Duration::from_millis(300));
    }
    // A crash mid-write: the last record loses its end.
    let len = std::fs::metadata(&log).unwrap().len();
    OpenOptions::new()
        .write(true)
        .open(&log)
        .unwrap()
        .set_len(len - 4)
        .unwrap();

    let listed = run(&["log", log_arg, "--channel", "vision"]);
    assert!(listed.status.success(), "{}", stderr(&listed));
    let text = String::from_utf8_lossy(&listed.stdout);
    assert_eq!(text.matches("ball seq").count(), 19, "{text}");
    assert!(
        stderr(&listed).contains("torn record"),
        "{}",
        stderr(&listed)
    );

    let hub = HubProcess::start(&[]);
    let mut sub = subscribed(hub.addr, &["vision"]);
    let o = run(&[
        "replay",
        "--hub",
        &hub.addr.to_string(),
        "--speed",
        "10",
        log_arg,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let got = drain_until(&mut sub, Instant::now() + Duration::from_secs(3), |g| {
        g.len() >= 19
    });
    let expected: Vec<String> = (0..19)
        .map(|s| format!("@ <vision> 0\nball seq {s}\n"))
        .collect();
    assert_eq!(got, expected);
}

#[test]
fn replay_keeps_the_original_timing_scaled_by_speed() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("t.clog");
    {
        let (mut w, _) = colony_hub::log::LogWriter::open(&log).unwrap();
        let src = "127.0.0.1:1".parse().unwrap();
        let t0 = std::time::UNIX_EPOCH + Duration::from_secs(1_000);
        w.append(t0, src, b"@ <a> 0\nx n 0\n").unwrap();
        w.append(t0 + Duration::from_millis(800), src, b"@ <a> 0\nx n 1\n")
            .unwrap();
        w.flush().unwrap();
    }
    let hub = HubProcess::start(&[]);
    let started = Instant::now();
    let o = run(&[
        "replay",
        "--hub",
        &hub.addr.to_string(),
        "--speed",
        "2",
        log.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let took = started.elapsed();
    assert!(
        took >= Duration::from_millis(400),
        "replay took {took:?}, less than 800 ms / 2"
    );
    let o = run(&["replay", "--speed", "0", log.to_str().unwrap()]);
    assert!(stderr(&o).contains("--speed"), "{}", stderr(&o));
}

#[test]
fn demo_runs_a_live_swarm_serves_the_monitor_and_stops_by_itself() {
    use std::io::{BufRead as _, BufReader, Read as _, Write as _};
    let hub_bind = closed_port();
    let mut child = colony()
        .args([
            "demo",
            "--hub-bind",
            &hub_bind,
            "--monitor-bind",
            "127.0.0.1:0",
        ])
        .args(["--seconds", "8", "--speed", "2"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("start colony demo");
    let stdout = child.stdout.take().expect("stdout");
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let first = rx
        .recv_timeout(Duration::from_secs(20))
        .expect("the demo prints the monitor's URL");
    let url = first
        .split_whitespace()
        .find(|w| w.starts_with("http://"))
        .unwrap_or_else(|| panic!("no URL in {first:?}"));
    // `http://ADDR/?token=...`: the page needs the token the demo prints.
    let rest = url.trim_start_matches("http://");
    let (addr, path) = rest.split_at(rest.find('/').unwrap_or(rest.len()));
    assert!(path.starts_with("/?token="), "{url}");
    // The monitor answers with its page.
    let mut http = std::net::TcpStream::connect(addr).expect("connect to the monitor");
    http.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    write!(http, "GET {path} HTTP/1.0\r\nHost: {addr}\r\n\r\n").unwrap();
    let mut page = String::new();
    http.read_to_string(&mut page).expect("read the page");
    assert!(
        page.starts_with("HTTP/1.0 200") && page.contains("<title>colony monitor</title>"),
        "{page}"
    );
    // The simulated swarm publishes the world on the demo's hub.
    let mut sub = subscribed(hub_bind.parse().unwrap(), &["vision"]);
    let got = drain_until(&mut sub, Instant::now() + Duration::from_secs(10), |g| {
        g.iter().any(|p| p.contains("robot id 0 x"))
    });
    assert!(
        got.iter().any(|p| p.contains("robot id 0 x")),
        "no vision from the simulator: {got:?}"
    );
    // --seconds ends everything cleanly.
    let status = child.wait().expect("wait for the demo");
    assert!(status.success(), "{status}");
    let rest: Vec<String> = rx.iter().collect();
    assert!(rest.iter().any(|l| l.contains("stopped")), "{rest:?}");
}

#[test]
fn the_monitor_answers_to_allowed_host_names_and_without_a_token_only_when_told() {
    use std::io::{BufRead as _, BufReader, Read as _, Write as _};
    let hub = closed_port();
    let mut child = colony()
        .args(["monitor", "--hub", &hub, "--bind", "127.0.0.1:0"])
        .args(["--no-token", "--allow-host", "robots.lab"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("start colony monitor");
    let mut line = String::new();
    BufReader::new(child.stdout.take().expect("stdout"))
        .read_line(&mut line)
        .expect("the monitor prints its URL");
    let url = line
        .split_whitespace()
        .find(|w| w.starts_with("http://"))
        .unwrap_or_else(|| panic!("no URL in {line:?}"));
    assert!(!url.contains("token"), "--no-token: {url}");
    let addr = url.trim_start_matches("http://").trim_end_matches('/');
    let port = addr.rsplit(':').next().unwrap();
    let get = |host: &str| {
        let mut http = std::net::TcpStream::connect(addr).expect("connect to the monitor");
        http.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        write!(http, "GET / HTTP/1.0\r\nHost: {host}\r\n\r\n").unwrap();
        let mut answer = String::new();
        http.read_to_string(&mut answer).expect("read the answer");
        answer
    };
    let allowed = get(&format!("robots.lab:{port}"));
    assert!(allowed.starts_with("HTTP/1.0 200"), "{allowed:.300}");
    let other = get(&format!("evil.example:{port}"));
    assert!(other.starts_with("HTTP/1.0 403"), "{other:.300}");
    let _ = child.kill();
    let _ = child.wait();
}

#[test]
fn extreme_seconds_and_speeds_get_an_answer_or_a_clear_error_never_a_panic() {
    let hub = HubProcess::start(&[]);
    let addr = hub.addr.to_string();
    // A timeout past a day is no timeout anyone means: a usage error (float_flags.rs has the rest).
    let o = run(&["status", "--hub", &addr, "--timeout", "1e300"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--timeout"), "{}", stderr(&o));
    // A generous one is answered as soon as the hub answers.
    let o = run(&["status", "--hub", &addr, "--timeout", "86400"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // A speed so small that one control step outlasts any clock.
    let o = run(&[
        "sort",
        "live",
        "--hub",
        &addr,
        "--speed",
        "1e-310",
        "--controllers",
        "external",
    ]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("speed") && !err.contains("panicked"), "{err}");
    // A run limit past what a clock holds is refused before anything starts.
    let o = run(&[
        "game",
        "ctf",
        "--seconds",
        "1e300",
        "--no-monitor",
        "--hub",
        &addr,
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--seconds"), "{}", stderr(&o));
}
