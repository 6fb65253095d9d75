//! Runs the Python client's tests (`python/tests`, standard-library unittest)
//! against this build's `colony` binary, so `cargo test --workspace` covers them.
//!
//! Without a `python3` on the PATH the test fails and names the command that
//! installs it (`scripts/test`): no test is skipped silently.

use std::io::Read;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

/// The Python suite bounds every wait itself; this is the backstop.
const LIMIT: Duration = Duration::from_secs(300);

fn drain(mut pipe: impl Read + Send + 'static) -> thread::JoinHandle<String> {
    thread::spawn(move || {
        let mut bytes = Vec::new();
        let _ = pipe.read_to_end(&mut bytes);
        String::from_utf8_lossy(&bytes).into_owned()
    })
}

#[test]
fn python_client_unittests_pass_against_the_real_hub() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let python = std::env::var("PYTHON").unwrap_or_else(|_| "python3".to_string());
    let spawned = Command::new(&python)
        .args(["-m", "unittest", "discover", "-s", "python/tests", "-v"])
        .current_dir(&root)
        .env("COLONY_BIN", env!("CARGO_BIN_EXE_colony"))
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .env("PYTHONUNBUFFERED", "1")
        .env_remove("COLONY_HUB")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn();
    let mut child = match spawned {
        Ok(child) => child,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => panic!(
            "no `{python}` to run the Python client's tests ({e}): run the README's test \
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
            None if started.elapsed() > LIMIT => {
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
            "the Python tests ran longer than {} s and were killed",
            LIMIT.as_secs()
        ),
        Some(status) => assert!(
            status.success(),
            "the Python client's tests failed ({status}); output above"
        ),
    }
}
