//! The `colony` binary's processes: a hub, a run to its end, a process whose
//! lines are kept, MURDOCH's agents and announcers.

use std::io::{BufRead, BufReader};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use colony_client::UdpClient;

/// The `colony` binary of this build. Cargo builds it before the colony
/// crate's integration tests, next to the directory their executables are in
/// (nextest names it in an environment variable instead).
pub fn colony() -> Command {
    Command::new(colony_path())
}

fn colony_path() -> PathBuf {
    if let Some(path) = std::env::var_os("NEXTEST_BIN_EXE_colony") {
        return path.into();
    }
    let test = std::env::current_exe().expect("the test's own path");
    let path = test
        .parent()
        .and_then(|deps| deps.parent())
        .expect("a test executable in target/<profile>/deps")
        .join(format!("colony{}", std::env::consts::EXE_SUFFIX));
    assert!(
        path.is_file(),
        "no colony binary at {}: only the colony crate's tests can run it",
        path.display()
    );
    path
}

/// A `colony hub` process, killed when dropped.
pub struct HubProcess {
    pub child: Child,
    pub addr: SocketAddr,
}

impl HubProcess {
    /// Starts a hub on a free loopback port.
    pub fn start(extra: &[&str]) -> HubProcess {
        HubProcess::start_on("127.0.0.1:0", extra)
    }

    /// Starts a hub on `bind`, and waits until it says where it listens.
    pub fn start_on(bind: &str, extra: &[&str]) -> HubProcess {
        let mut child = colony()
            .args(["hub", "--bind", bind])
            .args(extra)
            .env("COLONY_LOG", "info")
            .env("NO_COLOR", "1")
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start colony hub");
        let stderr = child.stderr.take().expect("stderr");
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                if let Some(rest) = line.split("addr=").nth(1) {
                    let addr: String = rest.chars().take_while(|c| !c.is_whitespace()).collect();
                    let _ = tx.send(addr);
                }
            }
        });
        let addr = rx
            .recv_timeout(Duration::from_secs(10))
            .expect("the hub reports its address");
        let addr = strip_ansi(&addr).parse().expect("a socket address");
        HubProcess { child, addr }
    }

    pub fn client(&self) -> UdpClient {
        UdpClient::connect(self.addr).expect("client")
    }

    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for HubProcess {
    fn drop(&mut self) {
        self.kill();
    }
}

fn strip_ansi(s: &str) -> String {
    let mut out = String::new();
    let mut chars = s.chars();
    while let Some(c) = chars.next() {
        if c == '\u{1b}' {
            for c in chars.by_ref() {
                if c.is_ascii_alphabetic() {
                    break;
                }
            }
        } else {
            out.push(c);
        }
    }
    out
}

/// Runs `colony args` to its end with `COLONY_LOG=log`, killing it if it has
/// not ended within a generous wait; returns its exit code (None: it had to be
/// killed), stdout and stderr.
pub fn run_bounded(args: &[&str], log: &str) -> (Option<i32>, String, String) {
    use std::io::Read as _;
    let mut child = colony()
        .args(args)
        .env("COLONY_LOG", log)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run colony");
    let mut out = child.stdout.take().unwrap();
    let mut err = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = out.read_to_string(&mut s);
        s
    });
    let deadline = Instant::now() + Duration::from_secs(20);
    let code = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status.code();
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut e = String::new();
    let _ = err.read_to_string(&mut e);
    (code, reader.join().unwrap(), e)
}

/// A colony process whose stdout lines are kept, killed when dropped.
pub struct Proc {
    child: Child,
    lines: Arc<Mutex<Vec<(Instant, String)>>>,
}

impl Proc {
    pub fn start(args: &[&str]) -> Proc {
        let mut child = colony()
            .args(args)
            .env("COLONY_LOG", "warn")
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("start colony");
        let lines = Arc::new(Mutex::new(Vec::new()));
        let out = child.stdout.take().unwrap();
        let keep = lines.clone();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                keep.lock().unwrap().push((Instant::now(), line));
            }
        });
        Proc { child, lines }
    }

    /// When a line containing `text` was printed, waiting up to `within`.
    pub fn when(&self, text: &str, within: Duration) -> Option<Instant> {
        let deadline = Instant::now() + within;
        loop {
            if let Some((at, _)) = self
                .lines
                .lock()
                .unwrap()
                .iter()
                .find(|(_, l)| l.contains(text))
            {
                return Some(*at);
            }
            if Instant::now() > deadline {
                return None;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    pub fn text(&self) -> String {
        let lines = self.lines.lock().unwrap();
        lines
            .iter()
            .map(|(_, l)| l.as_str())
            .collect::<Vec<_>>()
            .join("\n")
    }

    /// Waits for the process to end on its own; its exit code.
    pub fn exit(&mut self, within: Duration) -> Option<i32> {
        let deadline = Instant::now() + within;
        loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                return status.code();
            }
            if Instant::now() > deadline {
                return None;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        self.kill();
    }
}

/// A child process killed when dropped.
pub struct Killed(pub Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A `colony tasks agent` process on `hub`, once it has joined.
pub fn tasks_agent(hub: &str, name: &str, resources: &str, extra: &[&str]) -> Proc {
    let mut args = vec![
        "tasks",
        "agent",
        "--hub",
        hub,
        "--name",
        name,
        "--resources",
        resources,
    ];
    args.extend_from_slice(extra);
    let p = Proc::start(&args);
    assert!(
        p.when("joins with", Duration::from_secs(20)).is_some(),
        "agent {name} never started"
    );
    p
}

/// `colony tasks announce` of a task `length` seconds long, on `hub`, giving up after 60 s.
pub fn tasks_announce(hub: &str, name: &str, needs: &str, length: &str) -> Proc {
    Proc::start(&[
        "tasks",
        "announce",
        "--hub",
        hub,
        "--name",
        name,
        "--needs",
        needs,
        "--length",
        length,
        "--deadline",
        "60",
    ])
}
