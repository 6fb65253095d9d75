//! `colony sort`: experiments from the command line, and live mode over a real hub.

use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use colony_testkit::cli::{colony, run_bounded, HubProcess};
use colony_testkit::client::{drain_until, subscribed};

fn stderr_of(args: &[&str]) -> (bool, String) {
    let o = colony().args(args).stdin(Stdio::null()).output().unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn bad_inputs_give_clear_errors() {
    let (ok, e) = stderr_of(&[
        "sort",
        "run",
        "--method",
        "quicksort",
        "--steps",
        "10",
        "--trials",
        "1",
    ]);
    assert!(
        !ok && e.contains("unknown method `quicksort`") && e.contains("cachecons"),
        "{e}"
    );
    let (ok, e) = stderr_of(&[
        "sort", "run", "--method", "bhd", "--robots", "0", "--steps", "10", "--trials", "1",
    ]);
    assert!(!ok && e.contains("robots.count"), "{e}");
    let (ok, e) = stderr_of(&[
        "sort", "run", "--method", "bhd", "--types", "2", "--steps", "10", "--trials", "1",
    ]);
    assert!(!ok && e.contains("BHD"), "{e}");
    let (ok, e) = stderr_of(&[
        "sort",
        "run",
        "--method",
        "cachecons",
        "--scene",
        "/nonexistent/scene.toml",
    ]);
    assert!(!ok && e.contains("/nonexistent/scene.toml"), "{e}");
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "[robots]\ncount = \"four\"\n").unwrap();
    let (ok, e) = stderr_of(&[
        "sort",
        "run",
        "--method",
        "cachecons",
        "--scene",
        bad.to_str().unwrap(),
    ]);
    assert!(!ok && e.contains("bad.toml") && e.contains("count"), "{e}");
    let (ok, e) = stderr_of(&["sort", "run", "--method", "cachecons", "--trials", "0"]);
    assert!(!ok && e.contains("--trials"), "{e}");
}

#[test]
fn a_short_run_writes_deterministic_csv_files() {
    let dir = tempfile::tempdir().unwrap();
    let run = |out: &str| {
        let o = colony()
            .args([
                "sort", "run", "--method", "probseek", "--trials", "2", "--steps", "300", "--seed",
                "5", "--out",
            ])
            .arg(dir.path().join(out))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    run("a");
    run("b");
    for f in [
        "summary.csv",
        "probseek-types2-trial00.csv",
        "probseek-types2-trial01.csv",
    ] {
        let a = std::fs::read_to_string(dir.path().join("a").join(f)).unwrap();
        let b = std::fs::read_to_string(dir.path().join("b").join(f)).unwrap();
        assert_eq!(a, b, "{f}");
        assert!(a.lines().count() >= 2, "{f}: {a}");
    }
}

#[test]
fn reproduce_writes_a_report_with_figures_and_tests() {
    let dir = tempfile::tempdir().unwrap();
    let o = colony()
        .args([
            "sort",
            "reproduce",
            "--trials",
            "2",
            "--steps",
            "200",
            "--out",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
    for needle in [
        "## 1 puck type",
        "Repeated-measures ANOVA",
        "Tukey",
        "Paired t-test",
        "## 8 puck types",
        "Cache-point convergence",
    ] {
        assert!(report.contains(needle), "report lacks {needle}");
    }
    for png in [
        "pc_types1.png",
        "stc_types1.png",
        "twc_types1.png",
        "pc_types4.png",
        "cache_convergence.png",
        "snap_types1_cachecons_step0.png",
    ] {
        let bytes = std::fs::read(dir.path().join(png)).unwrap_or_else(|e| panic!("{png}: {e}"));
        assert_eq!(&bytes[1..4], b"PNG", "{png}");
    }
    // `compare` reads a run's CSV directory: a run agrees with itself in every respect.
    let csv = dir.path().join("csv");
    let o = colony()
        .args(["sort", "compare", "--names", "first,again"])
        .arg(&csv)
        .arg(&csv)
        .output()
        .unwrap();
    let md = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        md.contains("| method | first: mean STC (95 % CI) | again: mean STC"),
        "{md}"
    );
    assert!(md.contains("Method orders the same: 4 of 4."), "{md}");
    assert!(!md.contains("**no**"), "{md}");
    // A summary written by hand with a TWC of NaN is refused, naming its line.
    let forged = tempfile::tempdir().unwrap();
    std::fs::write(
        forged.path().join("summary.csv"),
        "method,types,trial,seed,steps,stc,twc,final_pc\ncachecons,2,0,1,100,5,nan,1\n",
    )
    .unwrap();
    let (ok, e) = stderr_of(&[
        "sort",
        "compare",
        forged.path().to_str().unwrap(),
        csv.to_str().unwrap(),
    ]);
    assert!(
        !ok && e.contains("summary.csv:2: TWC is not a finite number"),
        "{e}"
    );
    let (ok, e) = stderr_of(&["sort", "compare", "/nonexistent/run", csv.to_str().unwrap()]);
    assert!(
        !ok && e.contains("cannot read the run in /nonexistent/run"),
        "{e}"
    );
}

#[test]
fn supplementary_runs_chosen_experiments_into_one_report() {
    let dir = tempfile::tempdir().unwrap();
    let run = |only: &str| {
        colony()
            .args([
                "sort",
                "supplementary",
                "--trials",
                "2",
                "--steps",
                "200",
                "--only",
                only,
                "--out",
            ])
            .arg(dir.path())
            .output()
            .unwrap()
    };
    let o = run("physical,reinsert");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = run("k2");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
    let sections: Vec<&str> = report.lines().filter(|l| l.starts_with("## ")).collect();
    assert_eq!(
        sections,
        [
            "## PROBSEEK's k2 (Sect. 4.1)",
            "## The physical robots' trials (Sect. 4.3)",
            "## Random re-insertion (Sect. 4.4)"
        ]
    );
    assert!(report.contains("--only physical,reinsert"), "{report}");
    assert_eq!(report.matches("**Agrees with the paper: ").count(), 3);
    let bytes = std::fs::read(dir.path().join("reinsert_pc.png")).unwrap();
    assert_eq!(&bytes[1..4], b"PNG");

    // The report again from the CSV files, without running a trial.
    let o = colony()
        .args([
            "sort",
            "supplementary",
            "--trials",
            "2",
            "--steps",
            "200",
            "--only",
            "reinsert",
            "--report-only",
            "--out",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!String::from_utf8_lossy(&o.stderr).contains("trials on"));
    let again = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
    assert_eq!(again.matches("**Agrees with the paper: ").count(), 3);
    // Settings that do not match the files are refused with a clear error.
    let (ok, e) = stderr_of(&[
        "sort",
        "supplementary",
        "--steps",
        "300",
        "--only",
        "reinsert",
        "--report-only",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(!ok && e.contains("run the trials again"), "{e}");

    let (ok, e) = stderr_of(&[
        "sort",
        "supplementary",
        "--trials",
        "99999999999",
        "--out",
        "x",
    ]);
    assert!(!ok && e.contains("more than 10000"), "{e}");
    let (ok, e) = stderr_of(&["sort", "supplementary", "--only", "pucs", "--out", "x"]);
    assert!(!ok && e.contains("unknown experiment `pucs`"), "{e}");
}

/// A child process (a robot's controller, or the world) killed when dropped.
struct Robot(Child);

impl Drop for Robot {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn robot(hub: &HubProcess, id: usize) -> Robot {
    Robot(
        colony()
            .args([
                "sort",
                "robot",
                "--hub",
                &hub.addr.to_string(),
                "--id",
                &id.to_string(),
            ])
            .stdin(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    )
}

/// Which robots' commands appear on `radio` within `window`.
fn commanding(
    radio: &mut colony_client::UdpClient,
    window: Duration,
) -> std::collections::BTreeSet<i64> {
    let got = drain_until(radio, Instant::now() + window, |_| false);
    got.iter()
        .filter_map(|t| {
            colony_wire::Packet::parse(t.as_bytes())
                .ok()
                .and_then(|p| p.line("cmd").and_then(|l| l.i64("id").ok()))
        })
        .collect()
}

#[test]
fn a_robot_controller_can_be_killed_and_restarted_while_the_others_sort_on() {
    let hub = HubProcess::start(&[]);
    // Killed on drop, so a failed assertion doesn't leave the world running.
    let _world = Robot(
        colony()
            .args([
                "sort",
                "live",
                "--hub",
                &hub.addr.to_string(),
                "--controllers",
                "external",
                "--speed",
                "10",
            ])
            .stdin(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let mut vision = subscribed(hub.addr, &["vision"]);
    let first = drain_until(&mut vision, Instant::now() + Duration::from_secs(10), |g| {
        !g.is_empty()
    });
    assert!(
        first[0].contains("robot id 3") && first[0].matches("puck id").count() == 40,
        "{}",
        first[0]
    );

    let mut robots: Vec<Robot> = (0..4).map(|i| robot(&hub, i)).collect();
    let mut radio = subscribed(hub.addr, &["radio"]);
    let all: std::collections::BTreeSet<i64> = (0..4).collect();
    let deadline = Instant::now() + Duration::from_secs(10);
    while commanding(&mut radio, Duration::from_millis(500)) != all {
        assert!(Instant::now() < deadline, "not every robot was commanded");
    }
    // Kill robot 2's controller: the others keep going.
    // Commands it sent just before may still be queued at a loaded hub, so
    // wait for the first whole second without it rather than a fixed time.
    drop(robots.remove(2));
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        let seen = commanding(&mut radio, Duration::from_secs(1));
        if !seen.contains(&2) {
            assert_eq!(seen, [0, 1, 3].into_iter().collect(), "only robot 2 stops");
            break;
        }
        assert!(
            Instant::now() < deadline,
            "robot 2 was still commanded 10 s after its controller was killed"
        );
    }
    // Restart it: it picks up from the next observation.
    robots.push(robot(&hub, 2));
    let deadline = Instant::now() + Duration::from_secs(10);
    while commanding(&mut radio, Duration::from_millis(500)) != all {
        assert!(Instant::now() < deadline, "robot 2 never came back");
    }
}

#[test]
fn robot_and_puck_counts_past_what_a_world_takes_are_refused_before_any_memory_is_reserved() {
    // Each once asked for gigabytes and aborted; `--scale-robots` multiplies its count by 10.
    for (flag, n, what) in [
        ("--robots", "1000000000", "robots"),
        ("--pucks", "1000000000", "pucks"),
        ("--scale-robots", "1000000000", "robots"),
        ("--scale-robots", "18446744073709551615", "robots"),
        ("--scale-robots", "10000000", "robots"),
        // One past the most a world takes (100,000 robots, 10 pucks each).
        ("--scale-robots", "100001", "robots"),
    ] {
        let (code, _, e) = run_bounded(
            &[
                "sort",
                "run",
                "--method",
                "bhd",
                "--types",
                "1",
                flag,
                n,
                "--steps",
                "10",
                "--trials",
                "1",
                "--out",
                "/nonexistent/out",
            ],
            "warn",
        );
        assert_eq!(code, Some(1), "{flag} {n}: {e}");
        assert!(
            e.contains(&format!("{n} {what} is more than the")) && !e.contains("panicked"),
            "{flag} {n}: {e}"
        );
    }
}

#[test]
fn a_scale_of_zero_robots_is_refused() {
    let (code, _, e) = run_bounded(
        &[
            "sort",
            "run",
            "--method",
            "cachecons",
            "--scale-robots",
            "0",
            "--steps",
            "10",
            "--trials",
            "1",
            "--out",
            "/nonexistent/out",
        ],
        "warn",
    );
    assert_eq!(code, Some(1), "{e}");
    assert!(
        e.contains("--scale-robots must be at least 1") && !e.contains("panicked"),
        "{e}"
    );
}

#[test]
fn non_finite_numbers_in_a_scene_file_are_refused_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    for (text, field) in [
        ("[arena]\nwidth = nan\n", "arena.width"),
        ("[arena]\nheight = inf\n", "arena.height"),
        ("[arena]\ncorner_radius = -inf\n", "arena.corner_radius"),
        ("[robots]\nmass = inf\n", "robots.mass"),
        (
            "[robots]\ncommand_duration = nan\n",
            "robots.command_duration",
        ),
        ("[pucks]\nfriction = -inf\n", "pucks.friction"),
        ("[camera]\noffset = nan\n", "camera.offset"),
        ("[physics]\ndt = inf\n", "physics.dt"),
        (
            "[carrying]\nkeep_fraction = -nan\n",
            "carrying.keep_fraction",
        ),
    ] {
        let scene = dir.path().join("scene.toml");
        std::fs::write(&scene, text).unwrap();
        let (code, _, e) = run_bounded(
            &[
                "sort",
                "run",
                "--method",
                "cachecons",
                "--scene",
                scene.to_str().unwrap(),
                "--steps",
                "10",
                "--trials",
                "1",
                "--out",
                "/nonexistent/out",
            ],
            "warn",
        );
        assert_eq!(code, Some(1), "{text}: {e}");
        assert!(
            e.contains("scene.toml:2")
                && e.contains(&format!("`{field}`"))
                && !e.contains("panicked"),
            "{text}: {e}"
        );
    }
}

#[test]
fn an_engine_that_does_not_exist_is_refused_naming_those_that_do() {
    for args in [
        &["sort", "run", "--method", "cachecons", "--engine", "warp"][..],
        &[
            "sort",
            "reproduce",
            "--engine",
            "warp",
            "--out",
            "/nonexistent/out",
        ],
        &[
            "sort",
            "supplementary",
            "--engine",
            "warp",
            "--out",
            "/nonexistent/out",
        ],
        &["sort", "live", "--engine", "warp", "--hub", "127.0.0.1:9"],
        &["demo", "--engine", "warp", "--hub-bind", "127.0.0.1:0"],
    ] {
        let (code, _, e) = run_bounded(args, "warn");
        assert_eq!(code, Some(2), "{args:?}: {e}");
        assert!(
            e.contains("--engine")
                && e.contains("no contact engine named \"warp\" (there are: rapier, disc)"),
            "{args:?}: {e}"
        );
    }
}

#[test]
fn the_engine_can_be_chosen_on_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let o = colony()
        .args([
            "sort", "run", "--method", "probseek", "--trials", "1", "--steps", "100", "--engine",
            "rapier", "--out",
        ])
        .arg(dir.path())
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(dir.path().join("summary.csv").exists());
}

#[test]
fn long_work_shows_progress_lines_when_stderr_is_not_a_terminal() {
    // A line every 20 ms rather than every 10 s: a run of a second or so shows
    // several, whatever the machine's speed (the first comes 20 ms in).
    let dir = tempfile::tempdir().unwrap();
    let started = Instant::now();
    let o = colony()
        .args([
            "sort",
            "run",
            "--method",
            "cachecons",
            "--trials",
            "2",
            "--steps",
            "2000",
            "--out",
        ])
        .arg(dir.path())
        .env("COLONY_PROGRESS_SECS", "0.02")
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{e}");
    assert!(
        e.contains(
            "colony: sort run: building 2 worlds of 4 robots and 40 pucks for 2 trials \
             (4,000 control steps in all) on "
        ),
        "{e}"
    );
    let lines: Vec<&str> = e
        .lines()
        .filter(|l| l.starts_with("sort run: ") && l.contains(" of 4,000 control steps ("))
        .collect();
    assert!(
        !lines.is_empty(),
        "no progress line in {:?}: {e}",
        started.elapsed()
    );
    assert!(lines.iter().all(|l| l.contains(" elapsed")), "{e}");
    // Nothing drawn for a terminal: no bar, no carriage returns.
    assert!(!e.contains('\r') && !e.contains('\u{1b}'), "{e}");
}

#[test]
fn a_process_for_each_of_thousands_of_robots_is_refused_before_any_starts() {
    let (code, _, e) = run_bounded(
        &[
            "sort",
            "live",
            "--scale-robots",
            "2000",
            "--controllers",
            "process",
            "--steps",
            "1",
            "--hub",
            "127.0.0.1:9",
        ],
        "warn",
    );
    assert_eq!(code, Some(1), "{e}");
    assert!(
        e.contains("would start 2000 processes") && e.contains("in-world"),
        "{e}"
    );
}
