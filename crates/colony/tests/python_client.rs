//! Runs colony's Python test suites (standard-library unittest) against this
//! build's `colony` binary, so `cargo test --workspace` covers them:
//!
//! - the protocol client (`python/tests`) against the real hub;
//! - the `colony` package's environments (`crates/py/tests`: PettingZoo's and
//!   Gymnasium's own checkers, the reference policies against `colony sort run`,
//!   the examples), on the package `scripts/test` builds and installs under
//!   `target/pycolony` with the pinned third-party packages under `target/pydeps`.
//!
//! Without a `python3` on the PATH, or without the installed package, a test
//! fails and names the command that provides it (`scripts/test`): no test is
//! skipped silently.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

fn drain(mut pipe: impl Read + Send + 'static) -> thread::JoinHandle<String> {
    thread::spawn(move || {
        let mut bytes = Vec::new();
        let _ = pipe.read_to_end(&mut bytes);
        String::from_utf8_lossy(&bytes).into_owned()
    })
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Runs `python3 -m unittest discover -s DIR -v` from the repository's root with
/// `pythonpath`, and fails with Python's whole output unless every test passed
/// within `limit` (the suites bound every wait themselves; this is the backstop).
fn unittest(what: &str, dir: &str, pythonpath: &[PathBuf], limit: Duration) {
    let python = std::env::var("PYTHON").unwrap_or_else(|_| "python3".to_string());
    let mut command = Command::new(&python);
    command
        .args(["-m", "unittest", "discover", "-s", dir, "-v"])
        .current_dir(root())
        .env("COLONY_BIN", env!("CARGO_BIN_EXE_colony"))
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .env("PYTHONUNBUFFERED", "1")
        .env_remove("COLONY_HUB")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    if !pythonpath.is_empty() {
        command.env(
            "PYTHONPATH",
            std::env::join_paths(pythonpath).expect("paths without separators"),
        );
    }
    let mut child = match command.spawn() {
        Ok(child) => child,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => panic!(
            "no `{python}` to run {what}'s tests ({e}): run the README's test \
             command, `scripts/test`, which installs it (or: apt-get install python3)"
        ),
        Err(e) => panic!("cannot run `{python}`: {e}"),
    };
    let stdout = drain(child.stdout.take().expect("piped stdout"));
    let stderr = drain(child.stderr.take().expect("piped stderr"));

    let started = Instant::now();
    let status = loop {
        match child.try_wait().expect("waiting for python") {
            Some(status) => break Some(status),
            None if started.elapsed() > limit => {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
            None => thread::sleep(Duration::from_millis(50)),
        }
    };
    let out = stdout.join().unwrap_or_default();
    let err = stderr.join().unwrap_or_default();
    // unittest reports on stderr; show everything either way (cargo captures it on success).
    println!("--- python stdout ---\n{out}\n--- python stderr ---\n{err}");
    match status {
        None => panic!(
            "{what}'s Python tests ran longer than {} s and were killed",
            limit.as_secs()
        ),
        Some(status) => assert!(
            status.success(),
            "{what}'s Python tests failed ({status}); output above"
        ),
    }
}

/// The newest modification time of the files under `dir` (recursively).
fn newest(dir: &Path) -> std::time::SystemTime {
    let mut latest = std::time::UNIX_EPOCH;
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = entry.path();
        let t = if path.is_dir() {
            newest(&path)
        } else {
            entry
                .metadata()
                .and_then(|m| m.modified())
                .unwrap_or(latest)
        };
        latest = latest.max(t);
    }
    latest
}

/// Fails when the installed extension is older than the Rust or Python it is
/// built from: a plain `cargo test` after an edit would otherwise test the old code.
fn stale_check(installed: &Path) {
    let built = std::fs::metadata(installed.join("_native.abi3.so"))
        .and_then(|m| m.modified())
        .unwrap_or(std::time::UNIX_EPOCH);
    // The extension's crate and every crate of colony it is built from.
    let sources = [
        "crates/py/src",
        "crates/py/python",
        "crates/sort/src",
        "crates/game/src",
        "crates/env/src",
        "crates/behave/src",
        "crates/sim/src",
        "crates/node/src",
        "crates/hub/src",
        "crates/client/src",
        "crates/proto/src",
        "crates/wire/src",
        "crates/sys/src",
    ];
    for source in sources {
        let newer = newest(&root().join(source));
        assert!(
            newer <= built,
            "the installed `colony` package ({}) is older than {source}: run the README's \
             test command, `scripts/test`, which builds and installs it again",
            installed.display()
        );
    }
}

#[test]
fn python_client_unittests_pass_against_the_real_hub() {
    unittest(
        "the Python client",
        "python/tests",
        &[],
        Duration::from_secs(300),
    );
}

#[test]
fn python_environments_pass_pettingzoo_and_gymnasium_checks() {
    let package = root().join("target/pycolony");
    let deps = root().join("target/pydeps");
    for (dir, module, what) in [
        (&package, "colony", "the `colony` package"),
        (
            &deps,
            "pettingzoo",
            "PettingZoo (with the other pinned packages)",
        ),
    ] {
        assert!(
            dir.join(module).is_dir(),
            "{what} is not installed under {}: run the README's test command, \
             `scripts/test`, which builds and installs it",
            dir.display()
        );
    }
    stale_check(&package.join("colony"));
    unittest(
        "the colony package",
        "crates/py/tests",
        &[package, deps],
        Duration::from_secs(600),
    );
}
