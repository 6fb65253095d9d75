//! The monitor's browser tests (`tests/browser/`, run by node's own test
//! runner with playwright-core driving Debian's headless Chromium) against
//! this build of `colony`: a real hub, a real simulator, a real monitor, and
//! (`game.test.mjs`) a real match of `colony game ctf` played from the game
//! page; `foxglove.test.mjs` drives the Foxglove endpoint of a live `colony
//! demo` with Foxglove's own client (npm `@foxglove/ws-protocol`). Screenshots
//! land in `test-artifacts/browser/`.

use std::path::{Path, PathBuf};
use std::process::Command;

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[test]
fn the_monitor_page_passes_its_browser_tests_in_headless_chromium() {
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
    // Each package the tests import: a node_modules from before one was added lacks it.
    if ["playwright-core", "@foxglove/ws-protocol", "ws"]
        .iter()
        .any(|p| !dir.join("node_modules").join(p).exists())
    {
        let npm = Command::new("npm")
            .args(["ci", "--no-audit", "--no-fund"])
            .current_dir(&dir)
            .output()
            .expect("run npm ci in tests/browser (is npm installed? `scripts/test` installs it)");
        assert!(
            npm.status.success(),
            "npm ci in tests/browser failed:\n{}{}",
            String::from_utf8_lossy(&npm.stdout),
            String::from_utf8_lossy(&npm.stderr)
        );
    }
    let out = Command::new("node")
        .args(["--test", "--test-concurrency=1", "tests/browser/"])
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
        "the browser tests failed (logs and screenshots in test-artifacts/browser/):\n{stdout}\n{stderr}"
    );
    assert!(
        stdout.contains("# fail 0") && !stdout.contains("# pass 0"),
        "the browser tests ran no test:\n{stdout}"
    );
    // node finds every *.test.mjs in the folder; make sure the game's and the
    // two-site monitor's and the task board's and the game orders' ran.
    for (suite, file) in [
        (
            "the game page, playing red against the scripted blue",
            "game.test.mjs",
        ),
        (
            "the monitor across two sites bridged over Zenoh",
            "federation.test.mjs",
        ),
        ("the task board", "tasks.test.mjs"),
        (
            "the game page's orders: paths, single robots, split, merge, driving, chat",
            "game-orders.test.mjs",
        ),
        ("the game's pre-match screen", "game-prematch.test.mjs"),
        (
            "the Foxglove WebSocket, against a live colony demo",
            "foxglove.test.mjs",
        ),
    ] {
        assert!(
            stdout
                .lines()
                .any(|l| l.starts_with("ok ") && l.ends_with(&format!(" - {suite}"))),
            "the browser test tests/browser/{file} did not run or failed:\n{stdout}"
        );
    }
}
