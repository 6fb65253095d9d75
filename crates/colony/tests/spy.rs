//! `colony spy` as a person meets it: in a real terminal (tmux, 80 columns by 24 lines), on a
//! running `colony demo` and on a log written by `colony hub --log`. The spy's rates are checked
//! against the hub's own counts: the status report's packets over a span of its uptime.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use colony_client::status::fetch_status;
use colony_testkit::cli::{colony, run_bounded, HubProcess, Killed};
use colony_testkit::net::{free_tcp_port, free_udp_port};
use colony_wire::StatusReport;

/// The world's channels in `colony demo`.
const WORLD: [&str; 8] = [
    "vision", "camera.0", "camera.1", "camera.2", "camera.3", "debug", "radio", "metrics",
];
/// The rates are compared over this many seconds: the slowest channel (`metrics`, 0.4 a
/// second) then counts a dozen packets, so one packet more or less at an edge of the span is
/// under 10 %.
const WINDOW: u64 = 30;

/// A tmux server of its own with one 80×24 session running a command; killed when dropped.
struct Tmux {
    socket: String,
}

impl Tmux {
    /// Runs `args` (after the colony binary) in a fresh session, for 5 minutes at most (should
    /// the test be killed before it kills tmux). When the command ends, its last words stay
    /// on the screen for the test to show.
    fn start(name: &str, args: &[&str]) -> Tmux {
        let socket = format!("colony-spy-test-{name}-{}", std::process::id());
        let quoted: Vec<String> = std::iter::once(env!("CARGO_BIN_EXE_colony"))
            .chain(args.iter().copied())
            .map(|a| format!("'{}'", a.replace('\'', r"'\''")))
            .collect();
        let line = format!(
            "COLONY_LOG=warn timeout --foreground 300 {}; echo \"[colony exited: $?]\"; sleep 300",
            quoted.join(" ")
        );
        let status = Command::new("tmux")
            .args(["-L", &socket, "-f", "/dev/null", "new-session", "-d"])
            .args(["-x", "80", "-y", "24", "-s", "spy", &line])
            .status()
            .unwrap_or_else(|e| {
                panic!(
                    "no `tmux` to run the spy in ({e}): run the README's test command, \
                     `scripts/test`, which installs it"
                )
            });
        assert!(status.success(), "tmux new-session failed");
        Tmux { socket }
    }

    fn screen(&self) -> String {
        let out = Command::new("tmux")
            .args(["-L", &self.socket, "capture-pane", "-p", "-t", "spy"])
            .output()
            .expect("tmux capture-pane");
        String::from_utf8_lossy(&out.stdout).into_owned()
    }

    fn keys(&self, keys: &[&str]) {
        let status = Command::new("tmux")
            .args(["-L", &self.socket, "send-keys", "-t", "spy"])
            .args(keys)
            .status()
            .expect("tmux send-keys");
        assert!(status.success());
    }

    /// The screen once `done` holds for it, waiting up to `within`.
    fn wait_for(&self, within: Duration, what: &str, done: impl Fn(&str) -> bool) -> String {
        let deadline = Instant::now() + within;
        loop {
            let s = self.screen();
            if done(&s) {
                return s;
            }
            assert!(
                Instant::now() < deadline,
                "the spy never showed {what} within {within:?}; its screen:\n{s}"
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    }
}

impl Drop for Tmux {
    fn drop(&mut self) {
        let _ = Command::new("tmux")
            .args(["-L", &self.socket, "kill-server"])
            .stderr(Stdio::null())
            .status();
    }
}

/// Each channel's row on the spy's screen: its name and the rate column.
fn screen_rates(screen: &str) -> BTreeMap<String, f64> {
    screen
        .lines()
        .filter_map(|l| {
            let mut words = l.split_whitespace();
            let name = words.next()?;
            let rate = words.next()?.parse().ok()?;
            Some((name.to_string(), rate))
        })
        .collect()
}

fn packets(report: &StatusReport, channel: &str) -> Option<u64> {
    report
        .channels
        .iter()
        .find(|c| c.subjects == channel)
        .map(|c| c.packets)
}

#[test]
fn the_spy_shows_every_channel_of_a_running_demo_at_the_rate_the_hub_counts() {
    let (hub_port, monitor_port) = (free_udp_port(), free_tcp_port());
    let hub = format!("127.0.0.1:{hub_port}");
    let _demo = Killed(
        colony()
            .args(["demo", "--hub-bind", &hub])
            .args(["--monitor-bind", &format!("127.0.0.1:{monitor_port}")])
            .args(["--seconds", "180"])
            .env("COLONY_LOG", "warn")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("start colony demo"),
    );
    // The demo is up once every channel of its world has carried a packet.
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        let report = fetch_status(&hub, Duration::from_secs(1)).ok();
        if report.is_some_and(|r| WORLD.iter().all(|c| packets(&r, c).is_some())) {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "the demo's world never published"
        );
        std::thread::sleep(Duration::from_millis(200));
    }

    let window = WINDOW.to_string();
    let spy = Tmux::start("demo", &["spy", "--hub", &hub, "--window", &window]);
    // Every channel shows at once; its rate once it has been seen for a whole window.
    let screen = spy.wait_for(Duration::from_secs(30), "every channel", |s| {
        WORLD
            .iter()
            .all(|c| s.lines().any(|l| l.starts_with(&format!("{c} "))))
    });
    assert!(screen.contains("alive tapping"), "{screen}");

    // The hub's count over one window, and the spy's rate over the same span, read at once.
    // (Three seconds on, so the slowest channel, first seen as the wait ended, has been seen
    // for a whole window by the end of the span.)
    std::thread::sleep(Duration::from_secs(3));
    let a = fetch_status(&hub, Duration::from_secs(5)).expect("status");
    std::thread::sleep(Duration::from_secs(WINDOW));
    let b = fetch_status(&hub, Duration::from_secs(5)).expect("status");
    let screen = spy.screen();
    let span = (b.uptime_ms - a.uptime_ms) as f64 / 1000.0;
    let rates = screen_rates(&screen);
    let mut compared = Vec::new();
    for c in &b.channels {
        let before = packets(&a, &c.subjects).unwrap_or(0);
        let hub_rate = (c.packets - before) as f64 / span;
        let Some(&spy_rate) = rates.get(&c.subjects) else {
            panic!(
                "channel {} is not on the spy's screen:\n{screen}",
                c.subjects
            );
        };
        eprintln!(
            "{:<10} hub {hub_rate:7.3}/s  spy {spy_rate:7.3}/s  ({:+.1} %)",
            c.subjects,
            (spy_rate - hub_rate) / hub_rate * 100.0
        );
        compared.push((c.subjects.clone(), hub_rate, spy_rate));
    }
    for c in WORLD {
        assert!(
            compared.iter().any(|(n, ..)| n == c),
            "no channel {c}:\n{screen}"
        );
    }
    for (name, hub_rate, spy_rate) in &compared {
        assert!(
            (spy_rate - hub_rate).abs() <= 0.1 * hub_rate,
            "{name}: the spy shows {spy_rate}/s, the hub counted {hub_rate}/s over {span} s:\n{screen}"
        );
    }
    // The status line's figures.
    assert!(screen.contains("missed 0"), "{screen}");
    assert!(screen.contains("unparsed 0"), "{screen}");

    // Opening a channel decodes its last packet field by field and plots a number.
    spy.keys(&["Home", "Enter"]);
    let screen = spy.wait_for(Duration::from_secs(10), "the open channel", |s| {
        s.lines().nth(1).is_some_and(|l| l.starts_with(" camera.0"))
            && s.contains("field")
            && s.contains(" now ")
    });
    assert!(!screen.is_empty());
    spy.keys(&["q"]);
    spy.wait_for(Duration::from_secs(5), "the table again", |s| {
        s.lines().nth(1).is_some_and(|l| l.starts_with("channel"))
    });
    spy.keys(&["q"]);
    spy.wait_for(Duration::from_secs(10), "its exit", |s| {
        s.contains("[colony exited: 0]")
    });
}

/// Publishes `text` to the hub from a client of its own.
fn publish_all(hub: &HubProcess, packets: impl IntoIterator<Item = (String, Duration)>) {
    let mut client = hub.client();
    for (p, pause) in packets {
        client.publish(p.as_bytes()).expect("publish");
        std::thread::sleep(pause);
    }
}

fn log_records(path: &Path) -> usize {
    colony_mcap::TrafficReader::open(path)
        .map(|r| r.filter_map(Result::ok).count())
        .unwrap_or(0)
}

/// Waits (up to 10 s) until the log at `path` holds `n` records a reader can see.
fn wait_logged(path: &Path, n: usize) {
    let deadline = Instant::now() + Duration::from_secs(10);
    while log_records(path) < n {
        assert!(
            Instant::now() < deadline,
            "the hub never logged the packets"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn the_spy_plays_a_log_the_hub_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("traffic.clog");
    let log_text = log.to_str().unwrap().to_string();
    let mut hub = HubProcess::start(&["--log", &log_text]);
    // 60 packets on `pose` 20 ms apart (50 a second), a few on others.
    let pose = (0..60).map(|i| {
        (
            format!("@ <pose> 3\nrobot id 7 x {i}.5 y -2 name \"r7\"\n"),
            Duration::from_millis(20),
        )
    });
    let other = [
        ("@ <note> 0\nsay text \"hi\"\n".to_string(), Duration::ZERO),
        ("@ <a> <b> 9\nv n 1\n".to_string(), Duration::ZERO),
    ];
    publish_all(&hub, pose.chain(other));
    wait_logged(&log, 62);
    hub.kill();

    let spy = Tmux::start("log", &["spy", "--log", &log_text, "--speed", "2"]);
    let screen = spy.wait_for(Duration::from_secs(20), "the end of the log", |s| {
        s.contains("ended")
    });
    assert!(screen.contains("seen 62"), "{screen}");
    // Every channel, the subject set named as the hub names it; the last two came in the
    // log's last moment, too late for a rate.
    for c in ["pose ", "note ", "a b "] {
        assert!(
            screen.lines().any(|l| l.starts_with(c)),
            "no channel {c}:\n{screen}"
        );
    }
    // The recorded rate, whatever the speed it is played at: 50 a second, give or take the
    // pauses of a busy machine.
    let pose_rate = screen_rates(&screen)["pose"];
    assert!((25.0..=75.0).contains(&pose_rate), "{screen}");
    let row = screen.lines().find(|l| l.starts_with("pose")).unwrap();
    assert!(
        row.contains(" 3 ") && row.contains("robot id 7 x 59.5"),
        "{row}"
    );

    // (`g`: the first channel; Home would play the log again.)
    spy.keys(&["g", "Down", "Down", "Enter"]);
    let screen = spy.wait_for(Duration::from_secs(10), "the pose channel", |s| {
        s.lines().nth(1).is_some_and(|l| l.starts_with(" pose"))
    });
    assert!(screen.contains("60 packets"), "{screen}");
    for field in ["robot.id", "robot.x", "robot.y", "robot.name"] {
        assert!(screen.contains(field), "{field}:\n{screen}");
    }
    assert!(
        screen.contains("59.5") && screen.contains("\"r7\""),
        "{screen}"
    );
    // The first numeric field is plotted; Tab picks the next.
    assert!(screen.contains("robot.id  now 7"), "{screen}");
    spy.keys(&["Tab"]);
    let screen = spy.wait_for(Duration::from_secs(5), "robot.x plotted", |s| {
        s.contains("robot.x  now 59.5")
    });
    assert!(
        screen.contains("min 59.5"),
        "only the last packet was before opening: {screen}"
    );
    spy.keys(&["C-c"]);
    spy.wait_for(Duration::from_secs(10), "its exit", |s| {
        s.contains("[colony exited: 0]")
    });
}

#[test]
fn the_spy_plays_an_mcap_the_hub_wrote_and_says_what_a_kill_cut_short() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("traffic.mcap");
    let log_text = log.to_str().unwrap().to_string();
    let mut hub = HubProcess::start(&["--log", &log_text]);
    let pose = (0..30).map(|i| {
        (
            format!("@ <pose> 3\nrobot id 7 x {i}.5 y -2\n"),
            Duration::from_millis(10),
        )
    });
    publish_all(&hub, pose);
    // The hub closes a chunk once it is a second old: wait until all 30 are in whole chunks.
    wait_logged(&log, 30);
    // Killed, the hub never writes the MCAP's summary.
    hub.kill();

    let spy = Tmux::start("mcap", &["spy", "--log", &log_text, "--speed", "4"]);
    let screen = spy.wait_for(Duration::from_secs(20), "the end of the log", |s| {
        s.contains("ended")
    });
    assert!(screen.contains("seen 30"), "{screen}");
    let row = screen.lines().find(|l| l.starts_with("pose")).unwrap();
    assert!(row.contains("robot id 7 x 29.5"), "{row}");
    // The note is wrapped at word boundaries.
    let words = screen.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(words.contains("before its writer finished it"), "{screen}");
    spy.keys(&["C-c"]);
    spy.wait_for(Duration::from_secs(10), "its exit", |s| {
        s.contains("[colony exited: 0]")
    });
}

/// The log's time on the status line (`log +12.3 s`), in tenths of a second.
fn log_time(screen: &str) -> Option<u64> {
    let text = screen.split("log +").nth(1)?.split_whitespace().next()?;
    let (whole, tenth) = text.split_once('.')?;
    Some(whole.parse::<u64>().ok()? * 10 + tenth.parse::<u64>().ok()?)
}

#[test]
fn a_paused_log_stands_still_seeks_and_filters() {
    // A minute of log: `tick` every 100 ms, `slow` every second, the last record at 59.9 s.
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("minute.clog");
    let log_text = log.to_str().unwrap().to_string();
    let (mut w, _) = colony_hub::log::LogWriter::open(&log).unwrap();
    let base = std::time::SystemTime::now() - Duration::from_secs(3600);
    let from = "127.0.0.1:5".parse().unwrap();
    for i in 0..600u64 {
        let at = base + Duration::from_millis(i * 100);
        w.append(at, from, format!("@ <tick> 0\nt n {i}\n").as_bytes())
            .unwrap();
        if i % 10 == 0 {
            w.append(at, from, format!("@ <slow> 0\ns n {i}\n").as_bytes())
                .unwrap();
        }
    }
    w.flush().unwrap();
    drop(w);

    let spy = Tmux::start("pause", &["spy", "--log", &log_text]);
    spy.wait_for(Duration::from_secs(20), "the log playing", |s| {
        s.contains("playing") && log_time(s).is_some_and(|t| t >= 10)
    });
    spy.keys(&["Space"]);
    let paused = spy.wait_for(Duration::from_secs(10), "PAUSED", |s| s.contains("PAUSED"));
    let at = log_time(&paused).expect("the log's time");
    // However long it stays paused, the log's time and what was taken stand.
    std::thread::sleep(Duration::from_secs(3));
    let still = spy.screen();
    assert!(still.contains("PAUSED"), "{still}");
    assert_eq!(
        log_time(&still),
        Some(at),
        "the time moved while paused:\n{still}"
    );
    assert_eq!(seen(&still), seen(&paused), "{still}");

    // Paused, a seek lands on its target and stays there: 10 s on, 10 s back, the start.
    spy.keys(&["Right"]);
    spy.wait_for(Duration::from_secs(20), "10 s on", |s| {
        log_time(s) == Some(at + 100) && s.contains("PAUSED") && !s.contains("seeking")
    });
    spy.keys(&["Left"]);
    spy.wait_for(Duration::from_secs(20), "10 s back", |s| {
        log_time(s) == Some(at) && s.contains("PAUSED") && !s.contains("seeking")
    });
    spy.keys(&["Home"]);
    let start = spy.wait_for(Duration::from_secs(20), "the start", |s| {
        log_time(s) == Some(0) && s.contains("PAUSED") && !s.contains("seeking")
    });
    assert_eq!(seen(&start), 2, "{start}");
    // Past the end: the last record.
    spy.keys(&[
        "Right", "Right", "Right", "Right", "Right", "Right", "Right",
    ]);
    let end = spy.wait_for(Duration::from_secs(20), "the end", |s| {
        s.contains("ended") && log_time(s) == Some(599)
    });
    assert_eq!(seen(&end), 660, "{end}");

    // A filter: only `slow` is listed, and the status line says so.
    spy.keys(&["/", "slow", "Enter"]);
    let filtered = spy.wait_for(Duration::from_secs(10), "the filter", |s| {
        s.contains("/slow: 1 of 2")
    });
    assert!(
        filtered.lines().any(|l| l.starts_with("slow ")),
        "{filtered}"
    );
    assert!(
        !filtered.lines().any(|l| l.starts_with("tick ")),
        "{filtered}"
    );
    spy.keys(&["Escape"]);
    spy.wait_for(Duration::from_secs(10), "every channel again", |s| {
        s.lines().any(|l| l.starts_with("tick ")) && !s.contains("/slow")
    });

    // Going on from 10 s before the end, paused no more: the time moves again.
    spy.keys(&["Left", "Space"]);
    spy.wait_for(Duration::from_secs(20), "the log playing on", |s| {
        !s.contains("PAUSED") && log_time(s).is_some_and(|t| t > 499)
    });
    spy.keys(&["C-c"]);
    spy.wait_for(Duration::from_secs(10), "its exit", |s| {
        s.contains("[colony exited: 0]")
    });
}

/// The `seen N` figure of the status line.
fn seen(screen: &str) -> u64 {
    screen
        .split("seen ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or(0)
}

#[test]
fn the_spy_says_when_the_hub_is_gone_and_carries_on_when_it_is_back() {
    let addr = format!("127.0.0.1:{}", free_udp_port());
    let mut hub = HubProcess::start_on(&addr, &[]);
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let publisher = {
        let (stop, addr) = (stop.clone(), addr.clone());
        std::thread::spawn(move || {
            let mut client = colony_client::UdpClient::connect(addr.as_str()).unwrap();
            let mut i = 0u64;
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                let _ = client.publish(format!("@ <tick> 0\nt n {i}\n").as_bytes());
                i += 1;
                std::thread::sleep(Duration::from_millis(50));
            }
        })
    };
    let spy = Tmux::start("restart", &["spy", "--hub", &addr]);
    spy.wait_for(Duration::from_secs(20), "the tick channel", |s| {
        s.contains("alive tapping") && s.lines().any(|l| l.starts_with("tick "))
    });
    hub.kill();
    let screen = spy.wait_for(Duration::from_secs(30), "the hub unreachable", |s| {
        s.contains("UNREACHABLE")
    });
    let before = seen(&screen);
    let _hub = HubProcess::start_on(&addr, &[]);
    let screen = spy.wait_for(Duration::from_secs(30), "the hub back", |s| {
        s.contains("alive tapping") && seen(s) > before + 10
    });
    assert!(screen.lines().any(|l| l.starts_with("tick ")), "{screen}");
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    publisher.join().unwrap();
}

#[test]
fn a_refused_tap_shows_and_a_console_key_taps_anyway() {
    // A hub lets two clients of one host tap, and a console more.
    let dir = tempfile::tempdir().unwrap();
    let key = dir.path().join("colony.key");
    std::fs::write(
        &key,
        "a key shared by the hub and its consoles, long enough",
    )
    .unwrap();
    let key = key.to_str().unwrap();
    let hub = HubProcess::start(&["--key", key]);
    let addr = hub.addr.to_string();
    let plain: Vec<Tmux> = (0..2)
        .map(|i| {
            let spy = Tmux::start(&format!("tap{i}"), &["spy", "--hub", &addr]);
            spy.wait_for(Duration::from_secs(20), "its tap", |s| {
                s.contains("alive tapping")
            });
            spy
        })
        .collect();
    let third = Tmux::start("tap2", &["spy", "--hub", &addr]);
    third.wait_for(Duration::from_secs(20), "its tap refused", |s| {
        s.contains("TAP REFUSED")
    });
    let console = Tmux::start("tap3", &["spy", "--hub", &addr, "--key", key]);
    console.wait_for(Duration::from_secs(20), "its tap", |s| {
        s.contains("alive tapping")
    });
    drop(plain);
}

/// Whether a process runs whose command line holds `text`.
fn running(text: &str) -> bool {
    std::fs::read_dir("/proc")
        .unwrap()
        .filter_map(Result::ok)
        .filter_map(|e| std::fs::read(e.path().join("cmdline")).ok())
        .any(|c| {
            String::from_utf8_lossy(&c)
                .replace('\0', " ")
                .contains(text)
        })
}

#[test]
fn the_spy_ends_when_its_terminal_hangs_up() {
    // crossterm's reader spins for ever on a terminal that hung up: the spy must still see
    // SIGHUP and end, live and at the end of a log alike.
    let hub = HubProcess::start(&[]);
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("hangup.clog");
    let log_text = log.to_str().unwrap().to_string();
    let (mut w, _) = colony_hub::log::LogWriter::open(&log).unwrap();
    w.append(
        std::time::SystemTime::now(),
        "127.0.0.1:5".parse().unwrap(),
        b"@ <x> 0\nv n 1\n",
    )
    .unwrap();
    w.flush().unwrap();
    let addr = hub.addr.to_string();
    let live = Tmux::start("hangup-live", &["spy", "--hub", &addr]);
    let played = Tmux::start("hangup-log", &["spy", "--log", &log_text]);
    live.wait_for(Duration::from_secs(20), "the hub", |s| s.contains("alive"));
    played.wait_for(Duration::from_secs(20), "the log's end", |s| {
        s.contains("ended")
    });
    let live_cmd = format!("spy --hub {addr}");
    let log_cmd = format!("spy --log {log_text}");
    assert!(running(&live_cmd) && running(&log_cmd));
    drop(live);
    drop(played);
    let deadline = Instant::now() + Duration::from_secs(10);
    while running(&live_cmd) || running(&log_cmd) {
        assert!(
            Instant::now() < deadline,
            "a spy outlived its terminal by 10 s"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn a_bad_window_or_speed_is_a_usage_error_and_no_terminal_is_an_error() {
    for (args, flag) in [
        (vec!["spy", "--log", "x.clog", "--speed", "nan"], "--speed"),
        (
            vec!["spy", "--log", "x.clog", "--speed", "1e300"],
            "--speed",
        ),
        (vec!["spy", "--log", "x.clog", "--speed", "0"], "--speed"),
        (vec!["spy", "--window", "0"], "--window"),
        (vec!["spy", "--window", "1e300"], "--window"),
        (vec!["spy", "--window", "inf"], "--window"),
    ] {
        let (code, _, err) = run_bounded(&args, "warn");
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(err.contains(flag) && err.contains("must be from"), "{err}");
    }
    // --speed belongs to --log.
    let (code, _, err) = run_bounded(&["spy", "--speed", "2"], "warn");
    assert_eq!(code, Some(2), "{err}");
    // Standard output is a pipe here: the spy says it needs a terminal, and changes nothing.
    let (code, out, err) = run_bounded(&["spy", "--hub", "127.0.0.1:9"], "warn");
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("terminal") && out.is_empty(), "{err}");
}
