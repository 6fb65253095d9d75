//! `colony tasks`: the paper's two experiments from the command line, the live
//! demo, and clear errors for bad options.

use std::process::Stdio;

use colony_testkit::cli::colony;

fn run(args: &[&str]) -> (bool, String, String) {
    let o = colony()
        .args(args)
        .env("COLONY_LOG", "warn")
        .stdin(Stdio::null())
        .output()
        .unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn number_after(text: &str, label: &str) -> u64 {
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with(label))
        .unwrap_or_else(|| panic!("no `{label}` line in\n{text}"));
    line[line.find(label).unwrap() + label.len()..]
        .split_whitespace()
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no number in `{line}`"))
}

#[test]
fn longterm_prints_and_writes_what_happened() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("lt");
    let (ok, stdout, stderr) = run(&[
        "tasks",
        "longterm",
        "--hours",
        "0.25",
        "--seed",
        "5",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    for label in [
        "tasks introduced",
        "auctions announced",
        "allocated (started)",
        "completed",
        "re-allocated after failure",
        "unachievable reports",
        "recharges",
        "still open at the end",
        "messages per allocation",
    ] {
        assert!(stdout.contains(label), "no `{label}` in\n{stdout}");
    }
    assert!(number_after(&stdout, "tasks introduced") > 0);
    let json = std::fs::read_to_string(out.join("longterm-summary.json")).unwrap();
    let field = |name: &str| -> u64 {
        let key = format!("\"{name}\": ");
        let at = json
            .find(&key)
            .unwrap_or_else(|| panic!("no {name} in {json}"))
            + key.len();
        json[at..]
            .split([',', '\n'])
            .next()
            .unwrap()
            .trim()
            .parse()
            .unwrap()
    };
    assert_eq!(field("seed"), 5);
    assert!(field("achievable") > 0);
    // A quarter of an hour exactly: every task is done, given up or still open then.
    assert_eq!(
        field("completed") + field("gave_up") + field("open_at_end"),
        field("introduced"),
        "{json}"
    );
    assert!(field("completed") > 0, "{json}");
    let csv = std::fs::read_to_string(out.join("longterm-events.csv")).unwrap();
    assert!(csv.starts_with("time_s,kind,request,task,agent,detail\n"));
    assert!(csv.contains(",completed,"), "{csv}");
    // The same seed gives the same run.
    let (_, again, _) = run(&["tasks", "longterm", "--hours", "0.25", "--seed", "5"]);
    let strip = |s: &str| {
        s.lines()
            .filter(|l| !l.starts_with("wrote"))
            .collect::<Vec<_>>()
            .join("\n")
    };
    assert_eq!(strip(&stdout), strip(&again));
}

#[test]
fn boxpush_reaches_the_goal_with_two_pushers_and_with_one_switched_off() {
    let dir = tempfile::tempdir().unwrap();
    let (ok, stdout, stderr) = run(&["tasks", "boxpush", "--out", dir.path().to_str().unwrap()]);
    assert!(ok, "{stdout}{stderr}");
    assert!(stdout.contains("box at the goal"), "{stdout}");
    let track = std::fs::read_to_string(dir.path().join("boxpush-track.csv")).unwrap();
    assert!(track.starts_with("time_s,x,y,theta\n") && track.lines().count() > 10);
    let (ok, stdout, stderr) = run(&["tasks", "boxpush", "--off-at", "30"]);
    assert!(ok, "{stdout}{stderr}");
    assert!(
        stdout.contains("pusher1 switched off") && stdout.contains("box at the goal"),
        "{stdout}"
    );
    let (ok, stdout, stderr) = run(&["tasks", "boxpush", "--off-at", "30", "--on-at", "90"]);
    assert!(ok, "{stdout}{stderr}");
    assert!(stdout.contains("switched on again"), "{stdout}");
}

#[test]
fn the_demo_allocates_tasks_over_a_hub_of_its_own() {
    let (ok, stdout, stderr) = run(&["tasks", "demo", "--seconds", "3"]);
    assert!(ok, "{stderr}");
    assert!(stdout.contains("hub on 127.0.0.1:"), "{stdout}");
    assert!(stdout.contains("awarded to"), "{stdout}");
    assert!(stdout.contains("introduced"), "{stdout}");
}

#[test]
fn bad_options_give_clear_errors() {
    let cases: [(&[&str], &str); 7] = [
        (
            &["tasks", "longterm", "--hours=-2"],
            "invalid value '-2' for '--hours <HOURS>': must be from 0.001 to 720 hours",
        ),
        (
            &["tasks", "longterm", "--hours", "lots"],
            "invalid value 'lots'",
        ),
        (
            &["tasks", "boxpush", "--off-at", "50", "--on-at", "10"],
            "must come after --off-at",
        ),
        (
            &["tasks", "boxpush", "--on-at", "10"],
            "--on-at needs --off-at",
        ),
        (
            &["tasks", "boxpush", "--goal", "5000,20"],
            "off the 700 x 600 cm field",
        ),
        (&["tasks", "boxpush", "--goal", "x"], "is not X,Y"),
        (
            &["tasks", "demo", "--seconds", "0"],
            "invalid value '0' for '--seconds <SECONDS>': must be from",
        ),
    ];
    for (args, want) in cases {
        let (ok, _, stderr) = run(args);
        assert!(!ok && stderr.contains(want), "{args:?}: {stderr}");
    }
}
