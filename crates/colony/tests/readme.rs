//! The README is a contract: every command example in it runs as written, from an empty
//! directory with the installed binary. This test reads README.md's ```sh blocks, takes each
//! command line as one example (a trailing `# comment` stripped), classifies it by the table
//! below, and runs those that need no long setup, in README order, through `bash -c` in one
//! fresh directory, with the `colony` under test first on PATH: what `cargo install --path
//! crates/colony` and then the README would do.
//!
//! An example the table does not classify fails the test, by its line, so each new example
//! is classified here; so does a rule no example matches any more. Servers and `&` examples
//! run in a process group of their own, killed when their guard drops: nothing outlives the
//! test. The examples that talk to the default hub (127.0.0.1:7400) use the one their section
//! starts, as a reader would; this is the only test in this binary that uses 7400 (and the
//! monitor's 8080, and the bridge's 7447): the others use free ports. It needs `nc` and
//! `tmux`, as the README's examples do (`scripts/test` installs them).

use std::fmt::Write as _;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream, ToSocketAddrs, UdpSocket};
use std::os::unix::process::CommandExt as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How a rule recognises an example: its whole text, or how it starts.
#[derive(Clone, Copy, Debug)]
enum Pat {
    Exact(&'static str),
    Prefix(&'static str),
}

/// The evidence that a server (or a background process) serves.
#[derive(Clone, Copy, Debug)]
enum Ready {
    /// Its output (stdout or stderr) holds this text.
    Prints(&'static str),
    /// `colony status`, asked of the default hub, shows this text.
    Status(&'static str),
    /// It prints a page's address on 127.0.0.1:8080, and the page answers 200.
    Page,
}

#[derive(Clone, Copy, Debug)]
enum Class {
    /// Runs to its end: exit 0, and its output holds this text.
    Run(&'static str),
    /// As `Run`, but it needs no hub, no fixed port and no earlier example's file, so it
    /// runs beside the others (the slow computations: it keeps the test short).
    Beside(&'static str),
    /// A server a person stops with Ctrl-C: started, its evidence awaited, then stopped.
    Server(Ready),
    /// A server that later examples of its section use (a hub): kept to the end of its
    /// section, when it is stopped with Ctrl-C and its output must hold the text.
    Keep(Ready, &'static str),
    /// `... &`: started, its evidence awaited, and ended at the end of its section (SIGTERM,
    /// as `kill %1` would).
    Background(Ready),
    /// Draws in a terminal: run in tmux (80 x 24) until the screen shows the text, then `q`
    /// must end it with status 0.
    Terminal(&'static str),
    /// Not run here, for this reason.
    NotRun(&'static str),
}

struct Rule {
    pat: Pat,
    /// Only for an example whose section, subsection or the comment line above it in its
    /// block holds this text.
    within: Option<&'static str>,
    /// It talks to the default hub: when no hub of the README runs at that point, the
    /// README's `colony hub &` runs for it alone (the hub a reader has running). Only for
    /// examples that end before the next: not `Keep` or `Background`.
    hub: bool,
    class: Class,
}

const fn exact(text: &'static str, class: Class) -> Rule {
    Rule {
        pat: Pat::Exact(text),
        within: None,
        hub: false,
        class,
    }
}

const fn prefix(text: &'static str, class: Class) -> Rule {
    Rule {
        pat: Pat::Prefix(text),
        within: None,
        hub: false,
        class,
    }
}

impl Rule {
    const fn within(self, context: &'static str) -> Rule {
        Rule {
            within: Some(context),
            ..self
        }
    }

    const fn hub(self) -> Rule {
        Rule { hub: true, ..self }
    }

    fn matches(&self, ex: &Example) -> bool {
        let text = match self.pat {
            Pat::Exact(t) => ex.text == t,
            Pat::Prefix(p) => ex.text.starts_with(p),
        };
        text && self.within.is_none_or(|w| ex.context().contains(w))
    }
}

use Class::*;
use Ready::*;

/// Every README example, first match wins.
const RULES: &[Rule] = &[
    // The top of the README: the developer's commands, in a source checkout.
    prefix(
        "cargo run ",
        NotRun("builds colony with cargo, in a source checkout"),
    ),
    exact(
        "scripts/test",
        NotRun("runs every test of the repository, this one included"),
    ),
    // The hub in five commands, forged packets and request/reply: one hub for all of it.
    exact("colony hub --log traffic.clog", Keep(Status("hub up"), "")),
    exact(
        "colony sub vision_out",
        Keep(Status("vision_out ("), "ball x 5.3 y -2.5"),
    ),
    prefix("colony pub radio ", Run("")),
    // (Not `radio`: the hub serves one status report for 100 ms, so a status asked
    // straight after `colony pub` may predate its packet.)
    exact("colony status", Run("vision_out")).within("five commands"),
    prefix("colony replay traffic.clog", Run("replayed")),
    prefix("printf '@ <vision_out> 0", Run("")),
    prefix(
        "printf '@ <hub> 0\\ncookie v 0000000000000000\\n",
        Run("cookie v "),
    ),
    exact(
        "colony serve upper -- tr a-z A-Z",
        Keep(Prints("serves `upper`"), ""),
    ),
    exact(
        "colony serve upper -- tr a-z A-Z &",
        Background(Prints("serves `upper`")),
    ),
    prefix("colony call upper ", Run("TEXT VALUE \"HI\"")),
    exact("colony serve echo --echo", Server(Prints("serves `echo`"))),
    // Many sites: the lab's side runs here; the ops site is another machine.
    exact(
        "colony hub &",
        NotRun("the ops site's hub: a second machine (10.0.0.2)"),
    )
    .within("site \"ops\""),
    prefix(
        "colony bridge --site ops --connect tcp/10.0.0.1:",
        NotRun("connects to the lab at 10.0.0.1: a second machine"),
    ),
    exact("colony hub &", Background(Status("hub up"))),
    prefix(
        "colony bridge --site lab --listen ",
        Background(Status("bridge lab")),
    ),
    exact("colony sub vision", Keep(Status("vision ("), "")),
    exact("colony status", Run("bridge lab")).within("Many sites"),
    // The monitor, Foxglove and the spy.
    prefix("colony monitor --hub 127.0.0.1:7400", Server(Page)).hub(),
    prefix("colony demo --log run.mcap", Server(Page)),
    prefix("colony log export traffic.clog ", Run("")),
    prefix("colony log info run.mcap", Run("vision")),
    exact(
        "colony spy --hub 127.0.0.1:7400",
        Terminal("hub 127.0.0.1:7400 alive"),
    )
    .hub(),
    prefix("colony spy --log traffic.clog ", Terminal("vision_out")),
    // The C client: built from the source tree (tests/c_client.rs builds and drives it).
    prefix(
        "make -C clients/c",
        NotRun("builds the C client from the source tree"),
    ),
    prefix("cc ", NotRun("compiles the reader's own app.c")),
    exact(
        "colony hub & colony sort live --controllers external &",
        // (Not a printed line: two processes share the pipe, and their writes interleave.)
        Background(Status("camera.0")),
    ),
    prefix(
        "clients/c/build/sort_robot ",
        NotRun("the C client built from the source tree"),
    ),
    prefix(
        "pip install ",
        NotRun("builds the Python package with pip and cargo"),
    ),
    // Swarm sorting.
    prefix(
        "colony sort run --method cachecons --types 2 --trials 5 --steps 20000",
        Beside("sort-results"),
    ),
    prefix(
        "colony sort reproduce ",
        NotRun("the paper's experiments: about 20 minutes"),
    ),
    prefix(
        "colony sort supplementary --trials 3 ",
        NotRun("99 trials: minutes unoptimised"),
    ),
    prefix(
        "colony sort supplementary --only ",
        NotRun("experiments at full scale: hours"),
    ),
    prefix(
        "colony sort run --method cachecons --scale-robots ",
        NotRun("thousands of robots: minutes in a debug build, hours for 100,000 steps"),
    ),
    prefix(
        "colony sort run --method cachecons --trials 1 --steps 200 --engine ",
        Beside("CSV files in engine-results"),
    ),
    exact("colony sort live --speed 5", Server(Status("camera.0"))).hub(),
    // Task allocation.
    prefix("colony tasks demo ", Beside("awarded to")),
    prefix("colony tasks longterm ", Beside("wrote longterm")),
    prefix("colony tasks boxpush --off-at ", Beside("box at the goal")),
    prefix(
        "colony tasks boxpush --hub 127.0.0.1:7400 ",
        Server(Prints("took move-box")),
    )
    .hub(),
    prefix("colony tasks compare ", Beside("cost ratio")),
    prefix(
        "colony tasks agent --name r1 ",
        Background(Status("agent r1")),
    ),
    prefix(
        "colony tasks agent --name r2 ",
        Background(Status("agent r2")),
    ),
    prefix("colony tasks announce --name fetch ", Run("done by r2")),
    exact("colony status", Run("agent r1")).within("Task allocation"),
    exact("colony monitor", Server(Page)),
    prefix("colony tasks room ", Background(Prints("3 bodies"))),
    prefix(
        "colony tasks agent --name a ",
        Background(Prints("sees itself")),
    ),
    prefix(
        "colony tasks agent --name b ",
        Background(Prints("sees itself")),
    ),
    prefix("colony tasks announce --name visit ", Run("done by")),
    // The strategy game.
    prefix("colony game ctf --fast ", Beside("result:")),
    exact("colony game ctf --player red", Server(Page)),
    exact("colony game ctf --player red,blue", Server(Page)),
    exact("colony game ctf --player red --lobby", Server(Page)),
    prefix("colony game dm ", Server(Page)),
    exact(
        "colony game measure",
        NotRun("the paper's tables on a live match: about 5 minutes"),
    ),
    prefix("colony game part world ", Server(Prints("the world of a"))).hub(),
    prefix(
        "colony path maps/movingai/arena.map ",
        NotRun("the Moving AI maps are the repository's, read in a checkout"),
    ),
];

/// The longest a run-to-its-end example may take in the README's sequence, and beside it.
const RUN_BOUND: Duration = Duration::from_secs(90);
const BESIDE_BOUND: Duration = Duration::from_secs(240);
/// The longest a server may take to show that it serves, or to stop once told.
const READY_BOUND: Duration = Duration::from_secs(30);
const STOP_BOUND: Duration = Duration::from_secs(15);

/// One command line of a ```sh block.
#[derive(Clone, Debug)]
struct Example {
    /// Its line in README.md, from 1.
    line: usize,
    text: String,
    section: String,
    subsection: Option<String>,
    /// The last comment line above it in its block (`# site "lab" ...`), or "".
    note: String,
}

impl Example {
    fn context(&self) -> String {
        format!(
            "{} / {} / {}",
            self.section,
            self.subsection.as_deref().unwrap_or(""),
            self.note
        )
    }

    fn name(&self) -> String {
        format!("README.md:{} `{}`", self.line, self.text)
    }
}

/// A line without its trailing comment: a `#` that starts a word outside quotes, as sh reads it.
fn strip_comment(line: &str) -> &str {
    let (mut single, mut double, mut word_start) = (false, false, true);
    let mut escaped = false;
    for (i, c) in line.char_indices() {
        if escaped {
            escaped = false;
            word_start = false;
            continue;
        }
        match c {
            '\\' if !single => escaped = true,
            '\'' if !double => single = !single,
            '"' if !single => double = !double,
            '#' if !single && !double && word_start => return line[..i].trim_end(),
            _ => {}
        }
        word_start = c.is_whitespace();
    }
    line.trim_end()
}

/// Every command line of the README's ```sh blocks, in order.
fn parse(readme: &str) -> Vec<Example> {
    let mut out = Vec::new();
    let (mut section, mut subsection) = (String::new(), None);
    // Inside a block, and whether it is a ```sh one.
    let mut block: Option<bool> = None;
    let mut note = String::new();
    for (i, raw) in readme.lines().enumerate() {
        let trimmed = raw.trim();
        if let Some(lang) = trimmed.strip_prefix("```") {
            if block.is_some() {
                block = None;
            } else {
                block = Some(lang.trim() == "sh");
                note.clear();
            }
            continue;
        }
        match block {
            None => {
                if let Some(h) = raw.strip_prefix("### ") {
                    subsection = Some(h.trim().to_string());
                } else if let Some(h) = raw.strip_prefix("## ").or(raw.strip_prefix("# ")) {
                    section = h.trim().to_string();
                    subsection = None;
                }
            }
            Some(false) => {}
            Some(true) => {
                if trimmed.starts_with('#') {
                    note = trimmed.to_string();
                    continue;
                }
                let text = strip_comment(trimmed);
                if text.is_empty() {
                    continue;
                }
                out.push(Example {
                    line: i + 1,
                    text: text.to_string(),
                    section: section.clone(),
                    subsection: subsection.clone(),
                    note: note.clone(),
                });
            }
        }
    }
    out
}

fn readme() -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../README.md");
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("read {path}: {e}"))
}

/// A README's examples, each with the rule that classifies it; the examples no rule
/// classifies; whether each rule was used.
type Classes = (Vec<(Example, &'static Rule)>, Vec<String>, Vec<bool>);

fn classify(readme: &str) -> Classes {
    let mut plan: Vec<(Example, &'static Rule)> = Vec::new();
    let mut unclassified = Vec::new();
    let mut used = vec![false; RULES.len()];
    for ex in parse(readme) {
        match RULES.iter().position(|r| r.matches(&ex)) {
            Some(r) => {
                used[r] = true;
                plan.push((ex, &RULES[r]));
            }
            None => unclassified.push(ex.name()),
        }
    }
    (plan, unclassified, used)
}

/// The README's examples, classified; panics naming every example no rule classifies, and
/// every rule that classifies none.
fn classified(readme: &str) -> Vec<(Example, &'static Rule)> {
    let (plan, unclassified, used) = classify(readme);
    for r in RULES {
        assert!(
            !(r.hub && matches!(r.class, Keep(..) | Background(_))),
            "{:?}: a hub run for one example cannot outlive it",
            r.pat
        );
    }
    let stale: Vec<String> = RULES
        .iter()
        .zip(&used)
        .filter(|(_, used)| !**used)
        .map(|(r, _)| format!("{:?} (within {:?})", r.pat, r.within))
        .collect();
    assert!(
        unclassified.is_empty() && stale.is_empty(),
        "README.md and the table in crates/colony/tests/readme.rs disagree.\n\
         Examples no rule classifies (add a rule: run it, or say why not):\n  {}\n\
         Rules no example matches any more (remove or update them):\n  {}",
        unclassified.join("\n  "),
        stale.join("\n  "),
    );
    plan
}

#[test]
fn every_readme_example_is_classified() {
    let plan = classified(&readme());
    assert!(
        plan.iter().any(|(_, r)| !matches!(r.class, NotRun(_))),
        "no README example runs"
    );
}

/// The live, non-zombie processes of process group `pgid`.
fn group_members(pgid: u32) -> Vec<u32> {
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    let pgid = pgid.to_string();
    entries
        .flatten()
        .filter_map(|e| e.file_name().to_str()?.parse::<u32>().ok())
        .filter(|pid| {
            let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
                return false;
            };
            // pid (comm) state ppid pgrp ...: comm may hold anything but the last ')'.
            let Some((_, rest)) = stat.rsplit_once(')') else {
                return false;
            };
            let fields: Vec<&str> = rest.split_whitespace().collect();
            fields.len() > 2 && fields[2] == pgid && !matches!(fields[0], "Z" | "X")
        })
        .collect()
}

fn signal_group(pgid: u32, signal: &str) {
    let _ = Command::new("kill")
        .args(["-s", signal, "--", &format!("-{pgid}")])
        .stderr(Stdio::null())
        .status();
}

/// Where the examples run: the fresh directory, and the PATH with the binary under test first.
#[derive(Clone)]
struct Place {
    dir: PathBuf,
    path: String,
}

impl Place {
    fn command(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        c.current_dir(&self.dir)
            .env("PATH", &self.path)
            .env("NO_COLOR", "1")
            .env_remove("COLONY_HUB")
            .env_remove("COLONY_KEY")
            .env_remove("COLONY_LOG")
            .env_remove("TMUX");
        c
    }
}

/// An example run by `bash -c` as the leader of a process group of its own, its stdout and
/// stderr kept; the whole group is killed when dropped.
struct Proc {
    child: Child,
    pgid: u32,
    out: Arc<Mutex<String>>,
    pumps_done: Arc<AtomicUsize>,
    reaped: bool,
}

impl Proc {
    fn start(place: &Place, line: &str) -> Proc {
        let mut child = place
            .command("bash")
            .args(["-c", line])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .process_group(0)
            .spawn()
            .expect("start bash");
        let out = Arc::new(Mutex::new(String::new()));
        let pumps_done = Arc::new(AtomicUsize::new(0));
        let stdout = child.stdout.take().expect("stdout");
        let stderr = child.stderr.take().expect("stderr");
        pump(stdout, out.clone(), pumps_done.clone());
        pump(stderr, out.clone(), pumps_done.clone());
        let pgid = child.id();
        Proc {
            child,
            pgid,
            out,
            pumps_done,
            reaped: false,
        }
    }

    fn output(&self) -> String {
        self.out.lock().unwrap().clone()
    }

    /// Bash's exit status once it has ended, waiting up to `within`.
    fn exited(&mut self, within: Duration) -> Option<ExitStatus> {
        let deadline = Instant::now() + within;
        loop {
            if let Some(status) = self.child.try_wait().expect("try_wait") {
                return Some(status);
            }
            if Instant::now() > deadline {
                return None;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Whether a process of the group lives. A scan of /proc may list the pids before a
    /// fork and read the parent after its exit: a group is taken as ended only when three
    /// scans in a row find nobody (the last one lists what any earlier one missed).
    fn alive(&self) -> bool {
        (0..3).any(|_| !group_members(self.pgid).is_empty())
    }

    /// Waits up to `within` for the output to hold `text`; false if it did not, or if every
    /// process of the group ended first.
    fn prints(&self, text: &str, within: Duration) -> bool {
        let deadline = Instant::now() + within;
        loop {
            if self.output().contains(text) {
                return true;
            }
            if Instant::now() > deadline || !self.alive() {
                return self.output().contains(text);
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Sends `signal` to the group and waits for all of it to end; kills what is left after
    /// `STOP_BOUND`. True when the signal alone ended it.
    fn stop(&mut self, signal: &str) -> bool {
        if self.reaped {
            return true;
        }
        signal_group(self.pgid, signal);
        let deadline = Instant::now() + STOP_BOUND;
        while self.alive() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(50));
        }
        let clean = !self.alive();
        self.kill();
        clean
    }

    /// Kills whatever is left of the group, reaps bash and lets the output pumps finish.
    fn kill(&mut self) {
        if self.reaped {
            return;
        }
        // The group's id is bash's pid, held until bash is reaped: kill before waiting.
        signal_group(self.pgid, "KILL");
        let _ = self.child.wait();
        self.reaped = true;
        let deadline = Instant::now() + Duration::from_secs(5);
        while self.pumps_done.load(Ordering::SeqCst) < 2 && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        self.kill();
    }
}

fn pump(from: impl Read + Send + 'static, out: Arc<Mutex<String>>, done: Arc<AtomicUsize>) {
    std::thread::spawn(move || {
        let mut from = BufReader::new(from);
        let mut buf = Vec::new();
        while let Ok(n) = from.read_until(b'\n', &mut buf) {
            if n == 0 {
                break;
            }
            out.lock().unwrap().push_str(&String::from_utf8_lossy(&buf));
            buf.clear();
        }
        done.fetch_add(1, Ordering::SeqCst);
    });
}

/// The last lines of an output, indented, for a failure's message.
fn tail(output: &str) -> String {
    let lines: Vec<&str> = output.lines().collect();
    let from = lines.len().saturating_sub(25);
    let mut s = String::new();
    if from > 0 {
        let _ = writeln!(s, "    | ... ({from} lines before)");
    }
    for l in &lines[from..] {
        let _ = writeln!(s, "    | {l}");
    }
    if lines.is_empty() {
        s.push_str("    | (no output)\n");
    }
    if output.contains("command not found") {
        s.push_str("    (a program is missing: `scripts/test` installs nc, tmux and the rest)\n");
    }
    s
}

/// Runs `line` to its end (bounded by `within`): a failure's description, or None.
fn run_to_end(place: &Place, line: &str, within: Duration, expect: &str) -> Option<String> {
    let mut p = Proc::start(place, line);
    let status = p.exited(within);
    let left = p.alive();
    p.kill();
    let out = p.output();
    match status {
        None => Some(format!(
            "still running after {within:?}; killed\n{}",
            tail(&out)
        )),
        Some(s) if !s.success() => Some(format!("ended with {s}\n{}", tail(&out))),
        Some(_) if !out.contains(expect) => Some(format!(
            "ended with 0 but its output lacks `{expect}`\n{}",
            tail(&out)
        )),
        Some(_) if left => Some(format!(
            "ended with 0 but left processes running (killed)\n{}",
            tail(&out)
        )),
        Some(_) => None,
    }
}

/// `colony status` of the default hub, as a reader would ask it.
fn status_shows(place: &Place, text: &str, within: Duration) -> Result<(), String> {
    let deadline = Instant::now() + within;
    let mut last = String::new();
    loop {
        let mut p = Proc::start(place, "colony status");
        let done = p.exited(Duration::from_secs(10));
        p.kill();
        last = if done.is_some() { p.output() } else { last };
        if last.contains(text) {
            return Ok(());
        }
        if Instant::now() > deadline {
            return Err(format!(
                "`colony status` never showed `{text}` within {within:?}; it last said:\n{}",
                tail(&last)
            ));
        }
        std::thread::sleep(Duration::from_millis(300));
    }
}

/// A GET of an `http://` address; the response's status line.
fn http_get(url: &str) -> Result<String, String> {
    let rest = url
        .strip_prefix("http://")
        .ok_or("not an http:// address")?;
    let (host, path) = rest.split_at(rest.find('/').unwrap_or(rest.len()));
    let addr = host
        .to_socket_addrs()
        .map_err(|e| e.to_string())?
        .next()
        .ok_or("no address")?;
    let mut s =
        TcpStream::connect_timeout(&addr, Duration::from_secs(5)).map_err(|e| e.to_string())?;
    s.set_read_timeout(Some(Duration::from_secs(5)))
        .map_err(|e| e.to_string())?;
    let path = if path.is_empty() { "/" } else { path };
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n"
    )
    .map_err(|e| e.to_string())?;
    let mut line = String::new();
    BufReader::new(s)
        .read_line(&mut line)
        .map_err(|e| e.to_string())?;
    Ok(line.trim().to_string())
}

/// Waits for `p` to show the evidence that it serves.
fn ready(place: &Place, p: &Proc, how: Ready) -> Result<(), String> {
    match how {
        Prints(text) => {
            if p.prints(text, READY_BOUND) {
                Ok(())
            } else if !p.alive() {
                Err(format!("ended before printing `{text}`"))
            } else {
                Err(format!("never printed `{text}` within {READY_BOUND:?}"))
            }
        }
        Status(text) => status_shows(place, text, READY_BOUND),
        Page => {
            let at = "http://127.0.0.1:8080/";
            if !p.prints(at, READY_BOUND) {
                return Err(format!("never printed a page's address ({at}...)"));
            }
            let out = p.output();
            let start = out.find(at).unwrap();
            let url: String = out[start..]
                .chars()
                .take_while(|c| !c.is_whitespace())
                .collect();
            let deadline = Instant::now() + READY_BOUND;
            loop {
                match http_get(&url) {
                    Ok(line) if line.contains(" 200 ") || line.ends_with(" 200") => return Ok(()),
                    answer if Instant::now() > deadline => {
                        return Err(format!("{url} answered {answer:?}, not 200"))
                    }
                    _ => std::thread::sleep(Duration::from_millis(200)),
                }
            }
        }
    }
}

/// A tmux server of its own, with one 80 x 24 session running an example; killed when dropped.
struct Tmux {
    socket: String,
}

impl Tmux {
    fn start(place: &Place, line: &str, n: usize) -> Result<Tmux, String> {
        let socket = format!("colony-readme-{}-{n}", std::process::id());
        let quoted = format!("'{}'", line.replace('\'', r"'\''"));
        let script = format!("bash -c {quoted}; echo \"[exited $?]\"; sleep 300");
        let status = place
            .command("tmux")
            .args(["-L", &socket, "-f", "/dev/null", "new-session", "-d"])
            .args(["-x", "80", "-y", "24", "-s", "readme", &script])
            .status()
            .map_err(|e| {
                format!("no tmux to run it in a terminal ({e}): `scripts/test` installs it")
            })?;
        let tmux = Tmux { socket };
        if status.success() {
            Ok(tmux)
        } else {
            Err(format!("tmux new-session failed: {status}"))
        }
    }

    fn tmux(&self, args: &[&str]) -> String {
        let out = Command::new("tmux")
            .args(["-L", &self.socket])
            .args(args)
            .output()
            .expect("tmux");
        String::from_utf8_lossy(&out.stdout).into_owned()
    }

    fn screen(&self) -> String {
        self.tmux(&["capture-pane", "-p", "-t", "readme"])
    }

    /// Types `text` and, if asked, Enter.
    fn type_line(&self, text: &str, enter: bool) {
        self.tmux(&["send-keys", "-t", "readme", "-l", text]);
        if enter {
            self.tmux(&["send-keys", "-t", "readme", "Enter"]);
        }
    }

    /// The screen once `done` holds for it, or Err with the screen after `within`.
    fn wait_for(&self, within: Duration, done: impl Fn(&str) -> bool) -> Result<String, String> {
        let deadline = Instant::now() + within;
        loop {
            let s = self.screen();
            if done(&s) {
                return Ok(s);
            }
            if Instant::now() > deadline {
                return Err(s);
            }
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

fn screen_tail(screen: &str) -> String {
    tail(screen.trim_end())
}

/// A terminal example: the screen must show `shows`, and `q` must end it with 0.
fn terminal(place: &Place, line: &str, shows: &str, n: usize) -> Result<(), String> {
    let t = Tmux::start(place, line, n)?;
    t.wait_for(READY_BOUND, |s| s.contains(shows))
        .map_err(|s| format!("its screen never showed `{shows}`:\n{}", screen_tail(&s)))?;
    t.type_line("q", false);
    t.wait_for(STOP_BOUND, |s| s.contains("[exited "))
        .map_err(|s| format!("`q` did not end it:\n{}", screen_tail(&s)))
        .and_then(|s| {
            if s.contains("[exited 0]") {
                Ok(())
            } else {
                Err(format!("`q` ended it, not with 0:\n{}", screen_tail(&s)))
            }
        })
}

/// A process kept to the end of its section (or, for a hub started for one example, of it).
struct Live {
    proc: Proc,
    name: String,
    section: String,
    subsection: Option<String>,
    is_hub: bool,
    /// Ctrl-C (INT) for a foreground server, TERM for `&`.
    signal: &'static str,
    finally: &'static str,
}

/// The README's sequence: examples run in order, as one reader in one directory.
struct Reader {
    place: Place,
    live: Vec<Live>,
    failures: Arc<Mutex<Vec<String>>>,
    terminals: usize,
}

impl Reader {
    fn fail(&self, ex: &Example, why: String) {
        eprintln!("readme: FAILED {}: {why}", ex.name());
        self.failures
            .lock()
            .unwrap()
            .push(format!("{}: {why}", ex.name()));
    }

    /// Stops, newest first, the live processes whose section `ex` is not in (all, for None).
    fn end_scopes(&mut self, ex: Option<&Example>) {
        while let Some(at) = self.live.iter().rposition(|l| {
            ex.is_none_or(|ex| {
                l.section != ex.section || (l.subsection.is_some() && l.subsection != ex.subsection)
            })
        }) {
            let mut l = self.live.remove(at);
            self.stop(&mut l);
        }
    }

    fn stop(&self, l: &mut Live) {
        let clean = l.proc.stop(l.signal);
        let out = l.proc.output();
        let mut why = Vec::new();
        if !clean {
            why.push(format!(
                "did not end within {STOP_BOUND:?} of SIG{} (killed)",
                l.signal
            ));
        }
        if !out.contains(l.finally) {
            why.push(format!(
                "by the end of its section it had not printed `{}`",
                l.finally
            ));
        }
        if !why.is_empty() {
            let msg = format!("{}: {}\n{}", l.name, why.join("; "), tail(&out));
            eprintln!("readme: FAILED {msg}");
            self.failures.lock().unwrap().push(msg);
        }
    }

    fn hub_live(&self) -> bool {
        self.live.iter().any(|l| l.is_hub)
    }

    /// Starts a server or `&` example and waits for its evidence; kept live when `keep`.
    fn serve(
        &mut self,
        ex: &Example,
        how: Ready,
        signal: &'static str,
        finally: &'static str,
        keep: bool,
    ) {
        let p = Proc::start(&self.place, &ex.text);
        let mut l = Live {
            proc: p,
            name: ex.name(),
            section: ex.section.clone(),
            subsection: ex.subsection.clone(),
            is_hub: ex.text.starts_with("colony hub"),
            signal,
            finally,
        };
        if let Err(why) = ready(&self.place, &l.proc, how) {
            l.proc.kill();
            self.fail(ex, format!("{why}\n{}", tail(&l.proc.output())));
            return;
        }
        if keep {
            self.live.push(l);
        } else {
            self.stop(&mut l);
        }
    }

    fn example(&mut self, ex: &Example, rule: &Rule) {
        let started = Instant::now();
        let failed = self.failures.lock().unwrap().len();
        match rule.class {
            NotRun(_) | Beside(_) => return,
            Run(expect) => {
                if let Some(why) = run_to_end(&self.place, &ex.text, RUN_BOUND, expect) {
                    self.fail(ex, why);
                }
            }
            Server(how) => self.serve(ex, how, "INT", "", false),
            Keep(how, finally) => self.serve(ex, how, "INT", finally, true),
            Background(how) => self.serve(ex, how, "TERM", "", true),
            Terminal(shows) => {
                self.terminals += 1;
                if let Err(why) = terminal(&self.place, &ex.text, shows, self.terminals) {
                    self.fail(ex, why);
                }
            }
        }
        if self.failures.lock().unwrap().len() > failed {
            return;
        }
        eprintln!(
            "readme: {:?} {} ({:.1} s)",
            rule.class,
            ex.name(),
            started.elapsed().as_secs_f64()
        );
    }
}

/// Fails, naming the port, when something on this machine already holds one the README's
/// examples use.
fn ports_free() {
    let taken = |what: &str, e: std::io::Error| {
        panic!(
            "{what} is already taken on this machine ({e}); the README's examples need it: \
             stop whatever holds it and run this test again"
        )
    };
    if let Err(e) = UdpSocket::bind("127.0.0.1:7400") {
        taken("UDP port 7400 (the default hub)", e);
    }
    if let Err(e) = TcpListener::bind("127.0.0.1:8080") {
        taken("TCP port 8080 (the monitor's)", e);
    }
    if let Err(e) = TcpListener::bind("0.0.0.0:7447") {
        taken("TCP port 7447 (the bridge example's)", e);
    }
}

#[test]
fn the_readme_examples_run_as_written() {
    let started = Instant::now();
    let plan = classified(&readme());
    ports_free();
    let dir = tempfile::Builder::new()
        .prefix("colony-readme-")
        .tempdir()
        .expect("temporary directory");
    let bin = Path::new(env!("CARGO_BIN_EXE_colony"));
    let place = Place {
        dir: dir.path().to_path_buf(),
        path: format!(
            "{}:{}",
            bin.parent().unwrap().display(),
            std::env::var("PATH").unwrap_or_default()
        ),
    };
    let failures = Arc::new(Mutex::new(Vec::new()));

    // The examples beside the sequence: two at a time (the machine may have two cores).
    let beside: Arc<Mutex<Vec<(Example, &'static str)>>> = Arc::new(Mutex::new(
        plan.iter()
            .rev()
            .filter_map(|(ex, r)| match r.class {
                Beside(expect) => Some((ex.clone(), expect)),
                _ => None,
            })
            .collect(),
    ));
    let workers: Vec<_> = (0..2)
        .map(|_| {
            let (beside, place, failures) = (beside.clone(), place.clone(), failures.clone());
            std::thread::spawn(move || loop {
                let Some((ex, expect)) = beside.lock().unwrap().pop() else {
                    break;
                };
                let t = Instant::now();
                let why = run_to_end(&place, &ex.text, BESIDE_BOUND, expect);
                let secs = t.elapsed().as_secs_f64();
                match why {
                    Some(why) => {
                        eprintln!("readme: FAILED {}: {why}", ex.name());
                        failures
                            .lock()
                            .unwrap()
                            .push(format!("{}: {why}", ex.name()));
                    }
                    None => eprintln!("readme: Beside {} ({secs:.1} s)", ex.name()),
                }
            })
        })
        .collect();

    let mut reader = Reader {
        place: place.clone(),
        live: Vec::new(),
        failures: failures.clone(),
        terminals: 0,
    };
    for (ex, rule) in &plan {
        reader.end_scopes(Some(ex));
        if matches!(rule.class, NotRun(_) | Beside(_)) {
            continue;
        }
        let hub = if rule.hub && !reader.hub_live() {
            let mut hub = Proc::start(&place, "colony hub &");
            match status_shows(&place, "hub up", READY_BOUND) {
                Ok(()) => Some(Live {
                    proc: hub,
                    name: format!("the README's `colony hub &`, run for {}", ex.name()),
                    section: ex.section.clone(),
                    subsection: ex.subsection.clone(),
                    is_hub: true,
                    signal: "TERM",
                    finally: "",
                }),
                Err(why) => {
                    hub.kill();
                    reader.fail(
                        ex,
                        format!(
                            "the README's `colony hub &`, run for it: {why}\n{}",
                            tail(&hub.output())
                        ),
                    );
                    continue;
                }
            }
        } else {
            None
        };
        reader.example(ex, rule);
        if let Some(mut hub) = hub {
            reader.stop(&mut hub);
        }
    }
    reader.end_scopes(None);
    for w in workers {
        w.join().expect("a worker");
    }

    let count = |f: fn(&Class) -> bool| plan.iter().filter(|(_, r)| f(&r.class)).count();
    let mut summary = format!(
        "{} README examples: {} run to their end ({} of them beside the others), {} servers \
         ({} kept to the end of their section), {} in the background, {} in a terminal, \
         {} not run:\n",
        plan.len(),
        count(|c| matches!(c, Run(_) | Beside(_))),
        count(|c| matches!(c, Beside(_))),
        count(|c| matches!(c, Server(_) | Keep(..))),
        count(|c| matches!(c, Keep(..))),
        count(|c| matches!(c, Background(_))),
        count(|c| matches!(c, Terminal(_))),
        count(|c| matches!(c, NotRun(_))),
    );
    for (ex, r) in &plan {
        if let NotRun(why) = r.class {
            let _ = writeln!(summary, "  {}: {why}", ex.name());
        }
    }
    let _ = write!(summary, "in {:.0} s", started.elapsed().as_secs_f64());
    eprintln!("readme: {summary}");
    let failures = failures.lock().unwrap();
    assert!(
        failures.is_empty(),
        "{} README example(s) did not run as written:\n\n{}\n\n{summary}",
        failures.len(),
        failures.join("\n\n")
    );
}

#[test]
fn comments_are_read_as_a_person_reads_them() {
    assert_eq!(
        strip_comment(r#"colony call upper 'a # b' "c # d" e\#f   # a comment"#),
        r#"colony call upper 'a # b' "c # d" e\#f"#
    );
    assert_eq!(strip_comment("colony hub &  # the broker"), "colony hub &");
    assert_eq!(strip_comment("colony x#y"), "colony x#y");
    let page = "## A\n\n```sh\n# a note\ncolony tasks demo --seconds 2   # a demo\n```\n\n\
                ```sh\ncolony game measure\nmake it so\n```\n";
    let (plan, unclassified, _) = classify(page);
    let texts: Vec<(&str, &str)> = plan
        .iter()
        .map(|(ex, _)| (ex.text.as_str(), ex.note.as_str()))
        .collect();
    assert_eq!(
        texts,
        [
            ("colony tasks demo --seconds 2", "# a note"),
            ("colony game measure", "")
        ]
    );
    assert_eq!(plan[1].0.line, 9);
    assert_eq!(unclassified, ["README.md:10 `make it so`"]);
}
