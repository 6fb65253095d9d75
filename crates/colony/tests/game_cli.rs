//! `colony game`: fast-forwarded matches with a replayable record, bad
//! input, and a live match whose parts are separate processes over a real
//! hub, one of which is killed and restarted.

use std::process::Stdio;
use std::time::{Duration, Instant};

use colony_testkit::cli::{colony, HubProcess, Killed, Proc};
use colony_testkit::client::{drain_until, subscribed};

fn run(args: &[&str]) -> (bool, String, String) {
    let out = colony().args(args).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn a_fast_forwarded_capture_the_flag_match_ends_and_its_record_replays() {
    let dir = tempfile::tempdir().unwrap();
    let record = dir.path().join("ctf.clog");
    let (ok, out, err) = run(&[
        "game",
        "ctf",
        "--fast",
        "--record",
        record.to_str().unwrap(),
    ]);
    assert!(ok, "{out}\n{err}");
    let result = out.lines().find(|l| l.starts_with("result: ")).unwrap();
    assert!(
        result.contains("wins") || result.contains("draw"),
        "{result}"
    );
    // The record is an ordinary traffic log: `colony log` lists its game states.
    let (ok, listed, err) = run(&["log", record.to_str().unwrap(), "-c", "game.state"]);
    assert!(ok, "{err}");
    assert!(
        listed.contains("game mode ctf status running"),
        "{listed:.300}"
    );
    assert!(listed.contains("status over"));
    // `colony replay` publishes it to a hub, where a monitor (or anyone)
    // sees the match again: here, its states and its map.
    let hub = HubProcess::start(&[]);
    let mut watch = subscribed(hub.addr, &["game.state"]);
    let mut map = subscribed(hub.addr, &["game.map"]);
    let _replay = Killed(
        colony()
            .args([
                "replay",
                record.to_str().unwrap(),
                "--hub",
                &hub.addr.to_string(),
                "--speed",
                "50",
                "-c",
                "game.state",
                "-c",
                "game.map",
            ])
            .stdout(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let states = drain_until(&mut watch, Instant::now() + Duration::from_secs(10), |g| {
        g.len() >= 20
    });
    assert!(states.len() >= 20, "{} states replayed", states.len());
    assert!(states[0].contains("game mode ctf"));
    let maps = drain_until(&mut map, Instant::now() + Duration::from_secs(5), |g| {
        !g.is_empty()
    });
    assert!(
        maps[0].contains("map width 64 height 48"),
        "{:.200}",
        maps[0]
    );
}

#[test]
fn a_fast_forwarded_record_appended_to_a_log_keeps_its_times_in_order() {
    use std::time::{SystemTime, UNIX_EPOCH};
    let dir = tempfile::tempdir().unwrap();
    let record = dir.path().join("two.clog");
    let micros = |t: SystemTime| t.duration_since(UNIX_EPOCH).unwrap().as_micros() as u64;
    let before = micros(SystemTime::now());
    // A record an hour ahead, as a fast run leaves: each run must stamp
    // after it, however fast or slow this build plays 5 s of game.
    let ahead = SystemTime::now() + std::time::Duration::from_secs(3600);
    let (mut log, _) = colony_hub::log::LogWriter::open(&record).unwrap();
    log.append(ahead, "127.0.0.1:5000".parse().unwrap(), b"@ <x> 0\n")
        .unwrap();
    log.flush().unwrap();
    drop(log);
    for _ in 0..2 {
        let path = record.to_str().unwrap();
        let (ok, out, err) = run(&[
            "game",
            "dm",
            "--fast",
            "--time-limit",
            "5",
            "--record",
            path,
        ]);
        assert!(ok, "{out}\n{err}");
    }
    let times: Vec<u64> = colony_hub::log::LogReader::open(&record)
        .unwrap()
        .map(|r| r.unwrap().time_us)
        .collect();
    assert!(times.len() > 20, "{} records", times.len());
    // Stamped from when each run started (they were from 1970 before), and in order
    // after the record ahead and across the two runs.
    assert!(
        times[0] >= before,
        "first record at {} us, run at {before} us",
        times[0]
    );
    assert_eq!(times[0], micros(ahead));
    assert!(
        times.windows(2).all(|w| w[0] <= w[1]),
        "times go back: {:?}",
        times.windows(2).find(|w| w[0] > w[1])
    );
}

#[test]
fn a_fast_forwarded_record_named_mcap_is_a_finished_mcap() {
    let dir = tempfile::tempdir().unwrap();
    let record = dir.path().join("dm.mcap");
    let (ok, out, err) = run(&[
        "game",
        "dm",
        "--fast",
        "--time-limit",
        "60",
        "--record",
        record.to_str().unwrap(),
    ]);
    assert!(ok, "{out}\n{err}");
    // As the hub writes one: the MCAP magic, and a summary a reader finds (a log whose
    // writer did not finish it would be reported torn).
    let bytes = std::fs::read(&record).unwrap();
    assert!(bytes.starts_with(colony_mcap::MAGIC), "not an MCAP");
    let mut log = colony_mcap::TrafficReader::open(&record).unwrap();
    let records = log.by_ref().filter_map(Result::ok).count();
    assert!(records > 100, "{records} records");
    assert_eq!(log.damage(), None);
    let (ok, listed, err) = run(&["log", record.to_str().unwrap(), "-c", "game.state"]);
    assert!(ok, "{err}");
    assert!(listed.contains("game mode dm"), "{listed:.300}");
}

#[test]
fn a_live_match_records_mcap_for_a_name_ending_in_mcap() {
    use std::io::{BufRead, BufReader};
    let dir = tempfile::tempdir().unwrap();
    let record = dir.path().join("live.mcap");
    let mut game = Killed(
        colony()
            .args([
                "game",
                "dm",
                "--no-monitor",
                "--player",
                "none",
                "--speed",
                "50",
                "--time-limit",
                "20",
                "--hub-bind",
                "127.0.0.1:0",
                "--record",
                record.to_str().unwrap(),
            ])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    // The match runs to its clock, then waits for Ctrl-C with its hub up.
    let out = BufReader::new(game.0.stdout.take().unwrap());
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let result = out
            .lines()
            .map_while(Result::ok)
            .find(|l| l.starts_with("result: "));
        let _ = tx.send(result);
    });
    // A generous wait for the match's end: 20 s of game time at 50 times real time.
    let result = rx.recv_timeout(Duration::from_secs(120)).ok().flatten();
    assert!(result.is_some(), "the match printed no result");
    let interrupted = std::process::Command::new("kill")
        .args(["-INT", &game.0.id().to_string()])
        .status()
        .unwrap();
    assert!(interrupted.success());
    let deadline = Instant::now() + Duration::from_secs(20);
    while game.0.try_wait().unwrap().is_none() {
        assert!(
            Instant::now() < deadline,
            "the match did not stop on Ctrl-C"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    // Stopped, the hub finished its MCAP: the magic, and the summary a reader finds.
    let bytes = std::fs::read(&record).unwrap();
    assert!(bytes.starts_with(colony_mcap::MAGIC), "not an MCAP");
    let mut log = colony_mcap::TrafficReader::open(&record).unwrap();
    assert!(log.by_ref().filter_map(Result::ok).count() > 100);
    assert_eq!(log.damage(), None);
}

#[test]
fn a_record_with_another_hub_is_refused() {
    let (ok, _, err) = run(&[
        "game",
        "dm",
        "--hub",
        "127.0.0.1:7400",
        "--record",
        "x.clog",
    ]);
    assert!(!ok);
    assert!(err.contains("--record") && err.contains("--hub"), "{err}");
}

#[test]
fn a_fast_forwarded_death_match_ends_with_a_team_standing_or_the_clock() {
    let (ok, out, err) = run(&["game", "dm", "--fast", "--time-limit", "300"]);
    assert!(ok, "{out}\n{err}");
    let result = out.lines().find(|l| l.starts_with("result: ")).unwrap();
    assert!(
        result.contains("last robots standing") || result.contains("time is up"),
        "{result}"
    );
}

#[test]
fn bad_setups_give_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let bad_map = dir.path().join("bad.map");
    std::fs::write(&bad_map, "type octile\nheight 2\nwidth 3\nmap\n...\n.x.\n").unwrap();
    let cases: [(&[&str], &str); 5] = [
        (
            &["game", "ctf", "--fast", "--red", "a:tank,robot"],
            "unknown robot type \"robot\"",
        ),
        (
            &[
                "game",
                "ctf",
                "--fast",
                "--red",
                "a:tank,tank,tank,tank,tank,tank,tank",
            ],
            "team red costs 35 points; the budget is 30",
        ),
        (
            &["game", "ctf", "--fast", "--player", "green"],
            "--player green: no such team",
        ),
        (
            &["game", "ctf", "--fast", "--map", bad_map.to_str().unwrap()],
            "line 6, column 2",
        ),
        (
            &["game", "ctf", "--fast", "--time-limit=-3"],
            "--time-limit",
        ),
    ];
    for (args, want) in cases {
        let (ok, out, err) = run(args);
        assert!(!ok, "{args:?} succeeded: {out}");
        assert!(err.contains(want), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

fn part(hub: &HubProcess, args: &[&str]) -> Killed {
    let addr = hub.addr.to_string();
    let mut all = vec!["game", "part"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--hub", &addr]);
    Killed(
        colony()
            .args(&all)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    )
}

/// Robot ids whose pose in the newest two game states differ.
fn moving(states: &[String]) -> Vec<i64> {
    let parsed: Vec<Vec<(i64, f64, f64)>> = states
        .iter()
        .filter_map(|t| {
            colony_wire::Packet::parse(t.as_bytes()).ok().map(|p| {
                p.lines_labelled("robot")
                    .filter_map(|l| Some((l.i64("id").ok()?, l.f64("x").ok()?, l.f64("y").ok()?)))
                    .collect()
            })
        })
        .collect();
    let (Some(a), Some(b)) = (parsed.first(), parsed.last()) else {
        return Vec::new();
    };
    a.iter()
        .zip(b)
        .filter(|(p, q)| (p.1 - q.1).hypot(p.2 - q.2) > 5.0)
        .map(|(p, _)| p.0)
        .collect()
}

#[test]
fn the_parts_of_a_live_match_are_processes_and_the_robots_can_restart() {
    let hub = HubProcess::start(&[]);
    let speed = ["--speed", "5"];
    let world = part(&hub, &["world", speed[0], speed[1]]);
    let _server = part(&hub, &["server"]);
    let robots = part(&hub, &["robots"]);
    let _red = part(&hub, &["bot", "--team", "red"]);
    let _blue = part(&hub, &["bot", "--team", "blue"]);
    let mut watch = subscribed(hub.addr, &["game.state"]);
    let states = drain_until(&mut watch, Instant::now() + Duration::from_secs(20), |g| {
        g.len() > 40 && !moving(&g[g.len() - 20..]).is_empty()
    });
    assert!(
        !moving(&states[states.len().saturating_sub(20)..]).is_empty(),
        "no robot moved in {} states",
        states.len()
    );
    // Kill every robot's intelligence: the world stops them (their commands lapse).
    drop(robots);
    std::thread::sleep(Duration::from_millis(600));
    let still = drain_until(&mut watch, Instant::now() + Duration::from_secs(3), |g| {
        g.len() > 8
    });
    assert!(
        moving(&still[still.len().saturating_sub(4)..]).is_empty(),
        "robots kept driving with no intelligence"
    );
    // Restart them: the swarm intelligence's next orders set them going again.
    let _robots = part(&hub, &["robots"]);
    let again = drain_until(&mut watch, Instant::now() + Duration::from_secs(20), |g| {
        g.len() > 20 && !moving(&g[g.len() - 20..]).is_empty()
    });
    assert!(
        !moving(&again[again.len().saturating_sub(20)..]).is_empty(),
        "the restarted robots never moved"
    );
    // Restart the world: it takes up the game's clock and poses from the
    // game state instead of starting the match over.
    let before = game_time(again.last().unwrap());
    drop(world);
    let _world = part(&hub, &["world", speed[0], speed[1]]);
    let resumed = drain_until(&mut watch, Instant::now() + Duration::from_secs(20), |g| {
        g.len() > 30 && !moving(&g[g.len() - 20..]).is_empty()
    });
    let after: Vec<f64> = resumed.iter().map(|t| game_time(t)).collect();
    assert!(
        after.iter().all(|&t| t >= before - 0.5),
        "the game clock went back from {before} to {:?}",
        after.iter().cloned().fold(f64::INFINITY, f64::min)
    );
    assert!(
        !moving(&resumed[resumed.len().saturating_sub(20)..]).is_empty(),
        "nothing moved after the world restarted"
    );
}

fn game_time(state: &str) -> f64 {
    colony_wire::Packet::parse(state.as_bytes())
        .ok()
        .and_then(|p| p.line("game").and_then(|l| l.f64("time").ok()))
        .unwrap_or(f64::NAN)
}

#[test]
fn a_match_plays_from_an_empty_directory_on_the_built_in_map() {
    // An installed binary has no source tree beside it: the maps are in it.
    let dir = tempfile::tempdir().unwrap();
    let out = colony()
        .args(["game", "dm", "--fast", "--time-limit", "5"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("on maps/dm.map (built in)"), "{text}");
    assert!(text.lines().any(|l| l.starts_with("result: ")), "{text}");
}

#[test]
fn a_part_says_what_it_is_and_where_it_plays() {
    let hub = HubProcess::start(&[]);
    let addr = hub.addr.to_string();
    let server = Proc::start(&["game", "part", "server", "--hub", &addr]);
    assert!(
        server
            .when("the game server of a", Duration::from_secs(20))
            .is_some(),
        "{}",
        server.text()
    );
    assert!(server.text().contains(&addr), "{}", server.text());
}
