//! A service served by a program: each call runs a command, its lines on the
//! command's standard input, the command's standard output the answer.
//! `colony serve -- COMMAND` is this on a [`ServeClient`].
//!
//! Commands run one at a time on a worker thread while the serving loop keeps
//! the hub's lease and the provider's announcements going, so a long command
//! does not make callers think the provider died. Each command leads a
//! process group of its own, killed when it ends, so what it started in the
//! background cannot hold its answer back or outlive it.

use std::io::{self, Read as _, Write as _};
use std::os::unix::process::CommandExt as _;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::thread;
use std::time::{Duration, Instant};

use colony_wire::MAX_PACKET;

use super::{Asked, ServeClient, Ticket};

/// Calls waiting for the command beyond the one it runs; more are refused
/// at once, so a flood of calls costs a refusal each, not a queue.
pub const QUEUE: usize = 64;

/// What the caller is told of a call the provider dropped because it is stopping.
const STOPPING: &str = "the provider is stopping";

/// Serves every call `server` takes with `command` (see [`run_command`]),
/// one at a time in the order they arrive, until `stop` is set; then refuses
/// what is still queued and says the provider is leaving.
pub fn serve_command(
    server: &mut ServeClient,
    command: Vec<String>,
    limit: Duration,
    stop: &Arc<AtomicBool>,
) -> io::Result<()> {
    let (jobs, queue) = mpsc::sync_channel::<Asked>(QUEUE);
    let (done_tx, done) = mpsc::channel::<(Ticket, Result<Vec<String>, String>)>();
    // Not scoped: a loop that fails must not wait for the commands still queued.
    let worker = {
        let stop = stop.clone();
        thread::spawn(move || {
            for asked in queue {
                let result = run_command(&command, &asked, limit, &stop);
                if done_tx.send((asked.ticket, result)).is_err() {
                    return;
                }
            }
        })
    };
    let finish = |server: &mut ServeClient,
                  (ticket, result): (Ticket, Result<Vec<String>, String>)| {
        match result {
            Ok(lines) => server.answer(&ticket, &lines),
            Err(why) => server.refuse(&ticket, &why),
        }
    };
    while !stop.load(Ordering::Relaxed) {
        let wake = Instant::now() + Duration::from_millis(20);
        server
            .client()
            .wait(Some(server.next_deadline().map_or(wake, |d| d.min(wake))))?;
        for asked in server.poll_calls(Instant::now())? {
            if let Err(mpsc::TrySendError::Full(asked)) = jobs.try_send(asked) {
                let why = format!("busy: {QUEUE} calls already wait for the command");
                server.refuse(&asked.ticket, &why)?;
            }
        }
        while let Ok(result) = done.try_recv() {
            finish(server, result)?;
        }
    }
    // The worker refuses what is left at once (the stop flag is set); every
    // taken call gets its refusal before the provider says it is leaving.
    drop(jobs);
    for result in done.iter() {
        finish(server, result)?;
    }
    let _ = worker.join();
    server.leave()
}

/// Runs `command` for one call: the call's lines on its standard input (and
/// its id in `COLONY_CALL_ID`), its standard output's non-blank lines the
/// answer; a non-zero exit refuses the call with the last line of its
/// standard error. It is killed, with its process group, when it runs past
/// `limit` or `stop` is set.
pub fn run_command(
    command: &[String],
    asked: &Asked,
    limit: Duration,
    stop: &AtomicBool,
) -> Result<Vec<String>, String> {
    if stop.load(Ordering::Relaxed) {
        return Err(STOPPING.into());
    }
    let (program, rest) = command.split_first().ok_or("no command to run")?;
    let mut child = Command::new(program)
        .args(rest)
        .env("COLONY_CALL_ID", asked.ticket.id.to_string())
        // A group of its own, so what it starts in the background is killed with it.
        .process_group(0)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot run `{program}`: {e}"))?;
    let group = child.id();
    let mut input = asked.lines.join("\n");
    input.push('\n');
    let stdin = child.stdin.take();
    // Written from a thread of its own: a command that prints before it
    // reads could otherwise fill both pipes and wait on us forever.
    let writer = thread::spawn(move || {
        if let Some(mut stdin) = stdin {
            let _ = stdin.write_all(input.as_bytes());
        }
    });
    let stdout = read_bounded(child.stdout.take().map(|p| Box::new(p) as _));
    let stderr = read_bounded(child.stderr.take().map(|p| Box::new(p) as _));
    let started = Instant::now();
    let ended = loop {
        match child.try_wait() {
            Ok(Some(status)) => break Ok(status),
            // Stopping is not waited out: the caller hears at once.
            Ok(None) if stop.load(Ordering::Relaxed) => break Err(STOPPING.to_string()),
            // Named as `colony serve` spells `limit`: the caller's operator sets it there.
            Ok(None) if started.elapsed() > limit => {
                break Err(format!(
                    "`{program}` ran past --command-timeout ({:.1} s) and was stopped",
                    limit.as_secs_f64()
                ))
            }
            Ok(None) => thread::sleep(Duration::from_millis(2)),
            Err(e) => break Err(format!("cannot wait for `{program}`: {e}")),
        }
    };
    // Whatever the command left behind goes with it; that also closes the
    // pipes a background child held open, so the readers end.
    colony_sys::process::kill_group(group);
    let _ = child.wait();
    let _ = writer.join();
    let (out, out_len) = stdout.join().unwrap_or_default();
    let (err, _) = stderr.join().unwrap_or_default();
    let status = ended?;
    if !status.success() {
        let last = err.lines().rev().find(|l| !l.trim().is_empty());
        return Err(match last {
            Some(line) => format!("`{program}` failed ({status}): {}", line.trim()),
            None => format!("`{program}` failed ({status})"),
        });
    }
    if out_len > MAX_PACKET {
        return Err(format!(
            "`{program}` printed {out_len} bytes, more than one packet holds"
        ));
    }
    Ok(out
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(str::to_owned)
        .collect())
}

/// Reads `pipe` to its end on a thread of its own: what it kept, and how many
/// bytes came. An answer is one datagram, so the first bytes are kept and the
/// rest read and dropped: the command is never stopped by a full pipe.
fn read_bounded(pipe: Option<Box<dyn io::Read + Send>>) -> thread::JoinHandle<(String, usize)> {
    thread::spawn(move || {
        let mut kept = Vec::new();
        let mut all = 0usize;
        if let Some(mut pipe) = pipe {
            let mut buf = [0u8; 8192];
            while let Ok(n @ 1..) = pipe.read(&mut buf) {
                all += n;
                let room = (MAX_PACKET + 1).saturating_sub(kept.len());
                kept.extend_from_slice(&buf[..n.min(room)]);
            }
        }
        (String::from_utf8_lossy(&kept).into_owned(), all)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rpc::{Id, Service};
    use colony_wire::Priority;

    fn asked(lines: &[&str]) -> Asked {
        Asked {
            ticket: Ticket {
                id: Id(7),
                reply_to: Service::new("runner").unwrap().inbox(Id(1)),
                priority: Priority(0),
            },
            lines: lines.iter().map(|l| l.to_string()).collect(),
        }
    }

    fn sh(script: &str) -> Vec<String> {
        ["sh", "-c", script].map(String::from).to_vec()
    }

    const LIMIT: Duration = Duration::from_secs(10);

    #[test]
    fn the_answer_is_what_the_command_prints_for_the_call() {
        let stop = AtomicBool::new(false);
        let got = run_command(
            &sh("cat; echo; echo \"id $COLONY_CALL_ID\""),
            &asked(&["text a \"x\"", "n v 2"]),
            LIMIT,
            &stop,
        );
        assert_eq!(
            got.unwrap(),
            ["text a \"x\"", "n v 2", "id 0000000000000007"]
        );
    }

    #[test]
    fn a_failure_refuses_with_the_last_line_of_its_errors() {
        let stop = AtomicBool::new(false);
        let why = run_command(
            &sh("echo one >&2; echo two >&2; exit 3"),
            &asked(&[]),
            LIMIT,
            &stop,
        )
        .unwrap_err();
        assert!(why.starts_with("`sh` failed ("), "{why}");
        assert!(why.ends_with("): two"), "{why}");
    }

    #[test]
    fn a_command_past_its_limit_is_stopped() {
        let stop = AtomicBool::new(false);
        let started = Instant::now();
        let why = run_command(
            &sh("sleep 30"),
            &asked(&[]),
            Duration::from_millis(100),
            &stop,
        )
        .unwrap_err();
        assert!(why.contains("ran past --command-timeout (0.1 s)"), "{why}");
        assert!(started.elapsed() < Duration::from_secs(10));
    }

    #[test]
    fn nothing_runs_once_the_provider_is_stopping() {
        let stop = AtomicBool::new(true);
        let why = run_command(&sh("exit 0"), &asked(&[]), LIMIT, &stop).unwrap_err();
        assert_eq!(why, STOPPING);
    }

    #[test]
    fn an_answer_longer_than_a_packet_is_refused() {
        let stop = AtomicBool::new(false);
        let script = format!("head -c {} /dev/zero | tr '\\0' x", MAX_PACKET + 10);
        let why = run_command(&sh(&script), &asked(&[]), LIMIT, &stop).unwrap_err();
        assert_eq!(
            why,
            format!(
                "`sh` printed {} bytes, more than one packet holds",
                MAX_PACKET + 10
            )
        );
    }
}
