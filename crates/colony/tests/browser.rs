//! The monitor's browser tests (`tests/browser/`, run by node's own test
//! runner with playwright-core driving Debian's headless Chromium) against
//! this build of `colony`: a real hub, a real simulator, a real monitor, and
//! (`game.test.mjs`) a real match of `colony game ctf` played from the game
//! page; `foxglove.test.mjs` drives the Foxglove endpoint of a live `colony
//! demo` with Foxglove's own client (npm `@foxglove/ws-protocol`). Screenshots
//! land in `test-artifacts/browser/`.
//!
//! One test per file, so that the test runner can run a file beside other tests while its
//! browser waits on a page; the files' own tests run one at a time, as they always did.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Every `*.test.mjs` file and the suites each must report as passed.
const FILES: &[(&str, &[&str])] = &[
    (
        "common.test.mjs",
        &["the pages' shared module", "the link to the monitor server"],
    ),
    (
        "federation.test.mjs",
        &["the monitor across two sites bridged over Zenoh"],
    ),
    (
        "foxglove.test.mjs",
        &["the Foxglove WebSocket, against a live colony demo"],
    ),
    (
        "game-orders.test.mjs",
        &["the game page's orders: paths, single robots, split, merge, driving, chat"],
    ),
    ("game-prematch.test.mjs", &["the game's pre-match screen"]),
    (
        "game.test.mjs",
        &["the game page, playing red against the scripted blue"],
    ),
    (
        "monitor.test.mjs",
        &["the monitor page, against a live swarm"],
    ),
    ("scale.test.mjs", &["the monitor with 256 robots"]),
    ("swarm.test.mjs", &["the monitor with 2,000 robots"]),
    ("tasks.test.mjs", &["the task board"]),
];

/// Checks the browser and node are here and the npm packages installed (installing them if
/// not, one test at a time), then runs one file's tests.
fn run(file: &str) {
    assert!(
        Path::new("/usr/bin/chromium").exists(),
        "/usr/bin/chromium is missing: the monitor's browser tests need Debian's chromium; \
         run the README's test command, `scripts/test`, which installs it (or: apt-get install chromium)"
    );
    let root = repo_root();
    let dir = root.join("tests/browser");
    let node = Command::new("node").arg("--version").output();
    assert!(
        node.as_ref().is_ok_and(|o| o.status.success()),
        "node is missing: the browser tests run under node; run `scripts/test`, which installs it \
         (or: apt-get install nodejs npm)"
    );
    install_packages(&dir);
    let out = Command::new("node")
        .args(["--test", "--test-concurrency=1"])
        .arg(Path::new("tests/browser").join(file))
        .current_dir(&root)
        .env("COLONY_BIN", env!("CARGO_BIN_EXE_colony"))
        .output()
        .expect("run node --test");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    println!("{stdout}");
    eprintln!("{stderr}");
    assert!(
        out.status.success(),
        "the browser tests of {file} failed (logs and screenshots in test-artifacts/browser/):\n{stdout}\n{stderr}"
    );
    assert!(
        stdout.contains("# fail 0") && !stdout.contains("# pass 0"),
        "the browser tests of {file} ran no test:\n{stdout}"
    );
    let (_, suites) = FILES
        .iter()
        .find(|(f, _)| *f == file)
        .expect("every file run is listed");
    for suite in *suites {
        assert!(
            stdout
                .lines()
                .any(|l| l.starts_with("ok ") && l.ends_with(&format!(" - {suite}"))),
            "the browser test tests/browser/{file} did not run `{suite}` or it failed:\n{stdout}"
        );
    }
}

/// Installs the npm packages the tests import when one is missing (a node_modules from
/// before it was added). Tests run side by side: creating a directory succeeds for exactly
/// one of them, which installs while the others wait.
fn install_packages(dir: &Path) {
    let missing = || {
        ["playwright-core", "@foxglove/ws-protocol", "ws"]
            .iter()
            .any(|p| !dir.join("node_modules").join(p).exists())
    };
    let lock = std::env::temp_dir().join("colony-browser-npm.lock");
    let deadline = Instant::now() + Duration::from_secs(600);
    while missing() {
        if std::fs::create_dir(&lock).is_err() {
            assert!(
                Instant::now() < deadline,
                "another test has held {} for 10 minutes; remove it if no test runs",
                lock.display()
            );
            std::thread::sleep(Duration::from_millis(500));
            continue;
        }
        let npm = Command::new("npm")
            .args(["ci", "--no-audit", "--no-fund"])
            .current_dir(dir)
            .output();
        let _ = std::fs::remove_dir(&lock);
        let npm = npm
            .expect("run npm ci in tests/browser (is npm installed? `scripts/test` installs it)");
        assert!(
            npm.status.success(),
            "npm ci in tests/browser failed:\n{}{}",
            String::from_utf8_lossy(&npm.stdout),
            String::from_utf8_lossy(&npm.stderr)
        );
    }
}

#[test]
fn every_browser_test_file_has_its_test_here() {
    let mut found: Vec<String> = std::fs::read_dir(repo_root().join("tests/browser"))
        .expect("read tests/browser")
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.ends_with(".test.mjs"))
        .collect();
    found.sort();
    let listed: Vec<&str> = FILES.iter().map(|(f, _)| *f).collect();
    assert_eq!(
        found, listed,
        "each tests/browser/*.test.mjs needs its entry in FILES and its #[test] here"
    );
}

#[test]
fn the_pages_shared_module_passes_in_node() {
    run("common.test.mjs");
}

#[test]
fn the_monitor_across_two_sites_bridged_over_zenoh() {
    run("federation.test.mjs");
}

#[test]
fn the_foxglove_endpoint_serves_foxglove_s_own_client() {
    run("foxglove.test.mjs");
}

#[test]
fn the_game_page_s_orders_reach_the_game() {
    run("game-orders.test.mjs");
}

#[test]
fn the_game_s_pre_match_screen() {
    run("game-prematch.test.mjs");
}

#[test]
fn the_game_page_plays_red_against_the_scripted_blue() {
    run("game.test.mjs");
}

#[test]
fn the_monitor_page_against_a_live_swarm() {
    run("monitor.test.mjs");
}

#[test]
fn the_monitor_page_with_256_robots() {
    run("scale.test.mjs");
}

#[test]
fn the_monitor_page_with_2000_robots() {
    run("swarm.test.mjs");
}

#[test]
fn the_task_board() {
    run("tasks.test.mjs");
}
