//! The C client (`clients/c`) against the real hub: built with `make` and the C
//! compiler alone, then run as separate programs that publish, subscribe to
//! subject sets, talk with Rust and Python clients, follow a hub restart, skip
//! malformed datagrams with their place, sign a console's request, and drive a
//! robot of a live sort world. Its parser is also held to the Rust parser's
//! verdict (kind, line and column) on the fuzz corpora and thousands of
//! mutations of them, and the corpora run under AddressSanitizer and UBSan.
//!
//! Without `cc` or `make` these tests fail and name `scripts/test`, which
//! installs them: nothing is skipped silently.

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader, Write as _};
use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

use colony_testkit::cli::{colony, HubProcess};
use colony_testkit::client::{drain_until, subscribed};
use colony_wire::{ErrorKind, Packet};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Builds the library, its tests, the example and the sanitized corpus replay
/// once per test process, into cargo's scratch directory.
fn built() -> &'static Path {
    static OUT: OnceLock<PathBuf> = OnceLock::new();
    OUT.get_or_init(|| {
        let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("c-client");
        let made = Command::new("make")
            .args(["-s", "-C"])
            .arg(root().join("clients/c"))
            .arg(format!("OUT={}", out.display()))
            .arg("all")
            .output();
        match made {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => panic!(
                "no `make` to build the C client ({e}): run the README's test command, \
                 `scripts/test`, which installs make and gcc (or: apt-get install make gcc)"
            ),
            Err(e) => panic!("cannot run make: {e}"),
            Ok(o) => assert!(
                o.status.success(),
                "building clients/c failed (is `cc` installed? `scripts/test` installs it):\n{}{}",
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            ),
        }
        out
    })
}

fn tool() -> Command {
    Command::new(built().join("colony_tool"))
}

/// A C program whose stdout lines are kept as they come; killed when dropped.
struct CProc {
    child: Child,
    lines: Arc<Mutex<Vec<String>>>,
}

impl CProc {
    fn start(mut cmd: Command) -> CProc {
        let mut child = cmd
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("start a C program");
        let lines = Arc::new(Mutex::new(Vec::new()));
        let keep = lines.clone();
        let out = child.stdout.take().expect("piped stdout");
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                keep.lock().unwrap().push(line);
            }
        });
        CProc { child, lines }
    }

    /// Waits up to `within` for a line containing `text`.
    fn saw(&self, text: &str, within: Duration) -> bool {
        let deadline = Instant::now() + within;
        loop {
            if self.lines.lock().unwrap().iter().any(|l| l.contains(text)) {
                return true;
            }
            if Instant::now() > deadline {
                return false;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn text(&self) -> String {
        self.lines.lock().unwrap().join("\n")
    }
}

impl Drop for CProc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn sub(hub: &str, seconds: u32, subjects: &[&str]) -> CProc {
    let mut c = tool();
    c.arg("sub")
        .arg(hub)
        .arg(seconds.to_string())
        .args(subjects);
    let p = CProc::start(c);
    assert!(
        p.saw("lease", Duration::from_secs(10)),
        "the C subscriber got no lease from {hub}: {}",
        p.text()
    );
    p
}

fn publish(hub: &str, subjects: &str, prio: i32, count: u32, line: &str) {
    let status = tool()
        .args([
            "pub",
            hub,
            subjects,
            &prio.to_string(),
            &count.to_string(),
            "50",
            line,
        ])
        .status()
        .expect("run the C publisher");
    assert!(status.success(), "the C publisher failed");
}

fn run_checked(cmd: &mut Command, what: &str) -> String {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("cannot run {what}: {e}"));
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{what} failed:\n{text}");
    text
}

#[test]
fn c_unit_tests_and_the_fuzz_corpora_pass_under_sanitizers() {
    run_checked(&mut Command::new(built().join("test_unit")), "test_unit");
    let replay = run_checked(
        Command::new(built().join("fuzz_replay"))
            .arg(root().join("fuzz/c/corpus"))
            .arg(root().join("fuzz/corpus/parse_packet")),
        "the C fuzz corpus replay (ASan + UBSan)",
    );
    assert!(replay.contains(" 0 named for a verdict"), "{replay}");
}

fn kind_name(kind: &ErrorKind) -> &'static str {
    match kind {
        ErrorKind::TooLarge { .. } => "too-large",
        ErrorKind::Empty => "empty",
        ErrorKind::NotUtf8 => "not-utf8",
        ErrorKind::BadHeader(_) => "bad-header",
        ErrorKind::BadSubject(_) => "bad-subject",
        ErrorKind::DuplicateSubject(_) => "duplicate-subject",
        ErrorKind::BadPriority(_) => "bad-priority",
        ErrorKind::ControlChar(_) => "control-char",
        ErrorKind::ExpectedLabel(_) => "expected-label",
        ErrorKind::ExpectedName(_) => "expected-name",
        ErrorKind::MissingValue { .. } => "missing-value",
        ErrorKind::DuplicateName { .. } => "duplicate-name",
        ErrorKind::UnclosedGroup => "unclosed-group",
        ErrorKind::UnmatchedClose => "unmatched-close",
        ErrorKind::UnterminatedString => "unterminated-string",
        ErrorKind::BadEscape(_) => "bad-escape",
        ErrorKind::TooDeep => "too-deep",
        _ => "unknown",
    }
}

/// The Rust parser's verdict, spelt as the C replay prints it.
fn rust_verdict(data: &[u8]) -> String {
    match Packet::parse(data) {
        Ok(_) => "ok".to_string(),
        Err(e) => format!("{} {} {}", kind_name(&e.kind), e.line, e.column),
    }
}

/// Small, deterministic mutations of the seeds under 8 KB: the bytes the
/// grammar turns on, put where they were not.
fn mutations(seeds: &[Vec<u8>], per_seed: usize) -> Vec<Vec<u8>> {
    let small: Vec<Vec<u8>> = seeds.iter().filter(|s| s.len() < 8192).cloned().collect();
    mutations_of_any_size(&small, per_seed)
}

fn mutations_of_any_size(seeds: &[Vec<u8>], per_seed: usize) -> Vec<Vec<u8>> {
    const SPECIAL: &[u8] = b" \t\n\r()\"\\<>@#0-+.e\x00\x7f\x80\xc3\xe2\xed\xf0\xf4\xff";
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move |n: usize| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state % n.max(1) as u64) as usize
    };
    let mut out = Vec::new();
    for seed in seeds.iter().filter(|s| !s.is_empty()) {
        for _ in 0..per_seed {
            let mut m = seed.clone();
            for _ in 0..1 + next(3) {
                let at = next(m.len() + 1);
                match next(5) {
                    0 if at < m.len() => m[at] = SPECIAL[next(SPECIAL.len())],
                    1 => m.insert(at, SPECIAL[next(SPECIAL.len())]),
                    2 if at < m.len() => {
                        m.remove(at);
                    }
                    3 => {
                        // A copy of a slice elsewhere: repeated names, subjects, groups.
                        let from = next(m.len());
                        let len = next(24).min(m.len() - from);
                        let piece = m[from..from + len].to_vec();
                        m.splice(at..at, piece);
                    }
                    _ => m.truncate(at),
                }
            }
            out.push(m);
        }
    }
    out
}

/// Packets near the 64 KB limit in the shapes that once made the C parser
/// quadratic (the same names in frame after frame), the fullest name table a
/// packet can make, and each with a repeat, a stray byte or an unclosed
/// group at its end.
fn large_shapes() -> Vec<(String, Vec<u8>)> {
    let limit = colony_wire::MAX_PACKET;
    let seventeen: String = ('A'..='Q').map(|c| format!("{c}()")).collect();
    let mut groups = String::from("@ <a> 0\nl");
    for g in 0.. {
        if groups.len() >= limit - 80 {
            break;
        }
        groups.push_str(&format!(" g{g}({seventeen})"));
    }
    let mut lines = String::from("@ <a> 0\n");
    while lines.len() < limit - 60 {
        lines.push_str(&format!("l {seventeen}\n"));
    }
    let mut most = String::from("@ <a> 0\nl");
    for i in 0.. {
        if most.len() >= limit - 8 {
            break;
        }
        most.push_str(&format!(" {i:x}()"));
    }
    let mut out = Vec::new();
    for (name, body, repeat) in [
        ("groups", groups, " g0()"),
        ("lines", lines.trim_end().to_string(), " Q()"),
        ("most", most, " 0()"),
    ] {
        out.push((format!("large-{name}"), format!("{body}\n").into_bytes()));
        out.push((
            format!("large-{name}-repeat"),
            format!("{body}{repeat}\n").into_bytes(),
        ));
        out.push((
            format!("large-{name}-stray"),
            format!("{body} )\n").into_bytes(),
        ));
        out.push((
            format!("large-{name}-unclosed"),
            format!("{body} z(\n").into_bytes(),
        ));
    }
    out
}

#[test]
fn the_c_parser_gives_the_rust_parsers_verdict_on_the_corpora_and_their_mutations() {
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    for dir in ["fuzz/c/corpus", "fuzz/corpus/parse_packet"] {
        for entry in std::fs::read_dir(root().join(dir)).expect("a corpus directory") {
            let path = entry.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            files.push((name, std::fs::read(&path).unwrap()));
        }
    }
    let seeds: Vec<Vec<u8>> = files.iter().map(|(_, d)| d.clone()).collect();
    let scratch = tempfile::tempdir().unwrap();
    for (i, m) in mutations(&seeds, 60).into_iter().enumerate() {
        files.push((format!("mutant-{i:05}"), m));
    }
    // The large shapes and mutations of them (the seeds above are all under 8 KB).
    let large = large_shapes();
    let large_seeds: Vec<Vec<u8>> = large.iter().map(|(_, d)| d.clone()).collect();
    files.extend(large);
    for (i, m) in mutations_of_any_size(&large_seeds, 10)
        .into_iter()
        .enumerate()
    {
        files.push((format!("large-mutant-{i:03}"), m));
    }
    for (name, data) in &files {
        std::fs::write(scratch.path().join(name), data).unwrap();
    }
    let out = Command::new(built().join("fuzz_replay"))
        .arg("--verdicts")
        .arg(scratch.path())
        .output()
        .expect("run the C replay");
    assert!(
        out.status.success(),
        "the C replay failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let c: BTreeMap<String, String> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.split_once('\t'))
        .map(|(n, v)| (n.to_string(), v.to_string()))
        .collect();
    let mut differ = Vec::new();
    for (name, data) in &files {
        let want = rust_verdict(data);
        match c.get(name) {
            Some(got) if *got == want => {}
            got => differ.push(format!("{name}: C {got:?}, Rust {want:?}")),
        }
    }
    assert!(
        differ.is_empty(),
        "{} of {} inputs differ:\n{}",
        differ.len(),
        files.len(),
        differ.join("\n")
    );
}

#[test]
fn a_c_client_publishes_to_and_receives_from_rust_clients_on_channels_and_subject_sets() {
    let hub = HubProcess::start(&[]);
    let addr = hub.addr.to_string();
    let c = sub(&addr, 30, &["t", "a"]);
    let mut rust = subscribed(hub.addr, &["from-c", "x", "y"]);
    let mut publisher = hub.client();

    // Rust to C, on a channel and on a subject set the C client holds.
    let deadline = Instant::now() + Duration::from_secs(10);
    while !c.saw("set n 2", Duration::from_millis(200)) {
        assert!(
            Instant::now() < deadline,
            "C never heard Rust: {}",
            c.text()
        );
        publisher
            .publish(b"@ <t> 0\nnote n 1 text \"hi \\\"there\\\"\"\n")
            .unwrap();
        publisher.publish(b"@ <a> <z> 0\nnotme n 9\n").unwrap();
        publisher
            .publish(b"@ <a> <t> 3\nset n 2 g (x 1)\n")
            .unwrap();
    }
    assert!(c.saw(
        r#"packet <t> 0 :: note n 1 text "hi \"there\"""#,
        Duration::from_secs(1)
    ));
    assert!(c.saw(
        "packet <a> <t> 3 :: set n 2 g (x 1)",
        Duration::from_secs(1)
    ));
    assert!(
        !c.text().contains("notme"),
        "a set the C client does not hold all of reached it"
    );

    // C to Rust, on a channel and on a set.
    publish(&addr, "from-c", 0, 5, "c n 3 pose (x 1.5 y -2.0)");
    publish(&addr, "x y", 7, 5, "both n 4");
    let got = drain_until(&mut rust, Instant::now() + Duration::from_secs(10), |g| {
        g.iter().any(|p| p.contains("both n 4")) && g.iter().any(|p| p.contains("c n 3"))
    });
    assert!(
        got.iter()
            .any(|p| p == "@ <from-c> 0\nc n 3 pose (x 1.5 y -2.0)\n"),
        "{got:?}"
    );
    assert!(
        got.iter().any(|p| p == "@ <x> <y> 7\nboth n 4\n"),
        "{got:?}"
    );
}

#[test]
fn c_and_python_clients_talk_both_ways_through_the_hub() {
    let hub = HubProcess::start(&[]);
    let addr = hub.addr.to_string();
    let c = sub(&addr, 40, &["from-py"]);
    let script = r#"
import select, sys, time
from colony_client import Client
c = Client(sys.argv[1])
c.subscribe("from-c")
end = time.monotonic() + 30
while time.monotonic() < end:
    c.publish_raw(b'@ <from-py> 0\npy n 1 text "snake"\n')
    select.select([c.fileno()], [], [], 0.1)
    c.poll()
    for p in c:
        print("python got", p.lines, flush=True)
        sys.exit(0)
sys.exit("python heard nothing from C")
"#;
    let python = std::env::var("PYTHON").unwrap_or_else(|_| "python3".to_string());
    let mut py = match Command::new(&python)
        .args(["-c", script, &addr])
        .env("PYTHONPATH", root().join("python"))
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
    {
        Ok(p) => p,
        Err(e) => panic!(
            "no `{python}` ({e}): run the README's test command, `scripts/test`, which installs it"
        ),
    };
    let mut c_pub = CProc::start({
        let mut t = tool();
        t.args([
            "pub",
            &addr,
            "from-c",
            "0",
            "400",
            "50",
            "c n 2 text \"crab\"",
        ]);
        t
    });
    assert!(
        c.saw(
            r#"packet <from-py> 0 :: py n 1 text "snake""#,
            Duration::from_secs(30)
        ),
        "C heard nothing from Python: {}",
        c.text()
    );
    let deadline = Instant::now() + Duration::from_secs(35);
    let status = loop {
        if let Some(s) = py.try_wait().unwrap() {
            break s;
        }
        assert!(Instant::now() < deadline, "python ran too long");
        std::thread::sleep(Duration::from_millis(50));
    };
    let out = py.wait_with_output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        status.success() && text.contains("'c'") && text.contains("'text': 'crab'"),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let _ = c_pub.child.kill();
}

#[test]
fn a_c_subscriber_receives_again_after_a_hub_restart_without_being_restarted() {
    let mut hub = HubProcess::start(&[]);
    let addr = hub.addr;
    let c = sub(&addr.to_string(), 60, &["t"]);
    let mut publisher = hub.client();
    let deadline = Instant::now() + Duration::from_secs(10);
    while !c.saw("before n 1", Duration::from_millis(100)) {
        assert!(Instant::now() < deadline, "C heard nothing: {}", c.text());
        publisher.publish(b"@ <t> 0\nbefore n 1\n").unwrap();
    }
    hub.kill();
    // The C client is left running while no hub listens, then a new hub,
    // which knows nothing of it, takes the same port.
    std::thread::sleep(Duration::from_millis(500));
    let hub = HubProcess::start_on(&addr.to_string(), &[]);
    let mut publisher = hub.client();
    let deadline = Instant::now() + Duration::from_secs(20);
    while !c.saw("after n 2", Duration::from_millis(100)) {
        assert!(
            Instant::now() < deadline,
            "the C client never heard the restarted hub: {}",
            c.text()
        );
        publisher.publish(b"@ <t> 0\nafter n 2\n").unwrap();
    }
}

#[test]
fn forged_datagrams_are_skipped_with_their_place_and_forged_replies_do_not_chatter() {
    // A fake hub: the C client's socket takes datagrams from its hub's address
    // only, so that is where anything hostile would have to come from.
    let fake = UdpSocket::bind("127.0.0.1:0").unwrap();
    fake.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let c = CProc::start({
        let mut t = tool();
        t.args(["sub", &fake.local_addr().unwrap().to_string(), "30", "t"]);
        t
    });
    let mut buf = vec![0u8; 65536];
    let (n, client) = fake.recv_from(&mut buf).expect("the C client subscribes");
    let first = String::from_utf8_lossy(&buf[..n]).into_owned();
    assert_eq!(
        first,
        "@ <hub> 0\ncookie v 0000000000000000\nsubscribe ch t\n"
    );
    // The hub's round trip: a cookie, and the subscription again with it.
    fake.send_to(b"@ <hub> 0\ncookie v 00112233aabbccdd\n", client)
        .unwrap();
    let (n, _) = fake.recv_from(&mut buf).expect("the subscription again");
    assert_eq!(
        &buf[..n],
        b"@ <hub> 0\ncookie v 00112233aabbccdd\nsubscribe ch t\n"
    );
    fake.send_to(b"@ <hub> 0\nlease ms 0\n", client).unwrap();

    let mut hostile: Vec<Vec<u8>> = Vec::new();
    for dir in ["fuzz/corpus/parse_packet", "fuzz/c/corpus"] {
        let mut names: Vec<PathBuf> = std::fs::read_dir(root().join(dir))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.file_name().unwrap().to_string_lossy().starts_with("bad-"))
            .collect();
        names.sort();
        hostile.extend(names.iter().map(|p| std::fs::read(p).unwrap()));
    }
    // Empty datagrams and ones over a UDP payload cannot be sent.
    hostile.retain(|d| !d.is_empty() && d.len() <= colony_wire::MAX_PACKET);
    let mut want = Vec::new();
    let errors_seen = |c: &CProc| {
        c.lines
            .lock()
            .unwrap()
            .iter()
            .filter(|l| l.starts_with("error "))
            .count()
    };
    for d in &hostile {
        fake.send_to(d, client).unwrap();
        let e = Packet::parse(d).unwrap_err();
        want.push(format!(
            "error {} {} {}",
            kind_name(&e.kind),
            e.line,
            e.column
        ));
        // One at a time: the next is sent once this one's error is out, so no
        // datagram is dropped from a full socket buffer on a busy machine.
        let deadline = Instant::now() + Duration::from_secs(10);
        while errors_seen(&c) < want.len() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(1));
        }
    }
    fake.send_to(b"@ <t> 0\nafter n 1\n", client).unwrap();
    assert!(
        c.saw("packet <t> 0 :: after n 1", Duration::from_secs(10)),
        "the C client stopped at a hostile datagram: {}",
        c.text()
    );
    let errors: Vec<String> = c
        .lines
        .lock()
        .unwrap()
        .iter()
        .filter(|l| l.starts_with("error "))
        .cloned()
        .collect();
    assert_eq!(errors, want);

    // Forged cookies, two in quick succession after a quiet while: the first
    // is taken (everything is asked for again with it), the second is not,
    // so a forger alternating cookies cannot keep the client resending. And
    // the forged `lease ms 0` above did not set it chattering: it believes
    // no lease under 100 ms.
    std::thread::sleep(Duration::from_millis(400));
    fake.send_to(b"@ <hub> 0\ncookie v 1111111111111111\n", client)
        .unwrap();
    fake.send_to(b"@ <hub> 0\ncookie v 2222222222222222\n", client)
        .unwrap();
    fake.set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    let mut sent = Vec::new();
    let window = Instant::now() + Duration::from_millis(1500);
    while Instant::now() < window {
        if let Ok((n, _)) = fake.recv_from(&mut buf) {
            sent.push(String::from_utf8_lossy(&buf[..n]).into_owned());
        }
    }
    assert!(
        sent.iter()
            .any(|d| d.contains("cookie v 1111111111111111\nsubscribe ch t")),
        "{sent:?}"
    );
    assert!(
        !sent.iter().any(|d| d.contains("2222222222222222")),
        "{sent:?}"
    );
    assert!(
        sent.len() < 100,
        "{} datagrams in 1.5 s: the client believed `lease ms 0`",
        sent.len()
    );
}

#[test]
fn c_signs_exactly_as_rust_and_a_hub_with_a_key_takes_a_c_consoles_min_priority() {
    let dir = tempfile::tempdir().unwrap();
    let key_file = dir.path().join("colony.key");
    std::fs::write(&key_file, "0123456789abcdef-a-c-test-key\n").unwrap();
    let key = colony_wire::auth::Key::new(&std::fs::read(&key_file).unwrap()).unwrap();

    let packet = b"@ <hub> 0\ncookie v 0000000000000000\nmin_priority value 5\n";
    let mut signer = tool()
        .args(["sign", &key_file.to_string_lossy(), "1764000000000001"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    signer.stdin.take().unwrap().write_all(packet).unwrap();
    let out = signer.wait_with_output().unwrap();
    let mut by_rust = packet.to_vec();
    key.sign(&mut by_rust, 1_764_000_000_000_001);
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&by_rust)
    );
    assert_eq!(key.verify(&out.stdout).unwrap().body, &packet[..]);

    let hub = HubProcess::start(&["--key", &key_file.to_string_lossy()]);
    let text = run_checked(
        tool().args([
            "console",
            &hub.addr.to_string(),
            &key_file.to_string_lossy(),
            "7",
            "15",
        ]),
        "the C console",
    );
    assert!(text.contains("min_priority 7"), "{text}");
}

#[test]
fn c_clients_signing_with_the_key_talk_through_a_hub_that_refuses_everything_unsigned() {
    let dir = tempfile::tempdir().unwrap();
    let key_file = dir.path().join("colony.key");
    std::fs::write(&key_file, "0123456789abcdef-a-c-test-key\n").unwrap();
    let hub = HubProcess::start(&["--key", &key_file.to_string_lossy(), "--auth-all"]);
    let addr = hub.addr.to_string();
    let mut sub_cmd = tool();
    sub_cmd
        .args(["sub", &addr, "30", "signed"])
        .env("COLONY_KEY_FILE", &key_file);
    let c = CProc::start(sub_cmd);
    assert!(
        c.saw("lease", Duration::from_secs(10)),
        "a signed subscription got no lease: {}",
        c.text()
    );
    let publish = |signed: bool, line: &str| {
        let mut p = tool();
        p.args(["pub", &addr, "signed", "0", "5", "50", line]);
        if signed {
            p.env("COLONY_KEY_FILE", &key_file);
        }
        assert!(p.status().unwrap().success());
    };
    publish(false, "unsigned n 1");
    publish(true, "signed n 2");
    // The hub forwards a signed packet without its `auth` line.
    assert!(
        c.saw("packet <signed> 0 :: signed n 2", Duration::from_secs(10)),
        "{}",
        c.text()
    );
    assert!(!c.text().contains("unsigned"), "{}", c.text());
    assert!(!c.text().contains("auth n"), "{}", c.text());
}

#[test]
fn the_c_example_drives_a_robot_of_a_live_sort_world() {
    let hub = HubProcess::start(&[]);
    let addr = hub.addr.to_string();
    let _world = CProc::start({
        let mut w = colony();
        w.args(["sort", "live", "--hub", &addr, "--controllers", "external"])
            .env("COLONY_LOG", "warn");
        w
    });
    let mut vision = subscribed(hub.addr, &["vision"]);
    let pose = |text: &str, id: u32| -> Option<(f64, f64)> {
        let p = Packet::parse(text.as_bytes()).ok()?;
        let line = p
            .lines_labelled("robot")
            .find(|l| l.i64("id").ok() == Some(id as i64))?;
        Some((line.f64("x").ok()?, line.f64("y").ok()?))
    };
    let first = drain_until(&mut vision, Instant::now() + Duration::from_secs(15), |g| {
        g.iter().any(|p| pose(p, 0).is_some())
    });
    let start = first
        .iter()
        .find_map(|p| pose(p, 0))
        .expect("the world publishes robot 0 on vision");
    let other = first.iter().find_map(|p| pose(p, 1)).expect("robot 1");

    let mut robot = Command::new(built().join("sort_robot"));
    robot.args([&addr, "0", "60"]);
    let controller = CProc::start(robot);
    let deadline = Instant::now() + Duration::from_secs(40);
    let moved = loop {
        let got = drain_until(
            &mut vision,
            Instant::now() + Duration::from_millis(500),
            |_| false,
        );
        if let Some(now) = got.iter().rev().find_map(|p| pose(p, 0)) {
            let d = ((now.0 - start.0).powi(2) + (now.1 - start.1).powi(2)).sqrt();
            if d > 10.0 {
                break Some((d, got));
            }
        }
        if Instant::now() > deadline {
            break None;
        }
    };
    let (distance, last) = moved.unwrap_or_else(|| {
        panic!(
            "robot 0 did not move under the C controller: {}",
            controller.text()
        )
    });
    let still = last.iter().rev().find_map(|p| pose(p, 1)).expect("robot 1");
    let drift = ((still.0 - other.0).powi(2) + (still.1 - other.1).powi(2)).sqrt();
    assert!(
        drift < distance,
        "robot 1, with no controller, moved {drift} cm, as far as robot 0 ({distance} cm)"
    );
    assert!(
        controller.saw("commands", Duration::from_secs(5)),
        "{}",
        controller.text()
    );
}
