//! `colony call` and `colony serve`: request and reply from a shell script.

use std::io::{Read as _, Write as _};
use std::os::unix::process::CommandExt as _;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use colony_client::rpc::{Asked, CallClient, Caller, Provider, ServeClient, Ticket};
use colony_wire::{Priority, MAX_PACKET};

use super::{Bounds, HubAddr};

/// A provider's lease: long enough not to flood the hub with announcements,
/// no longer than callers believe one (a minute).
const LEASE: Bounds = Bounds::new(0.1, 60.0, "seconds");
/// Calls waiting for the command beyond the one it runs; more are refused
/// at once, so a flood of calls costs a refusal each, not a queue.
const QUEUE: usize = 64;

#[derive(clap::Args, Debug)]
pub struct CallArgs {
    #[command(flatten)]
    pub hub: HubAddr,
    /// Seconds to wait for a provider's answer.
    #[arg(long, default_value_t = 5.0, value_parser = super::TIMEOUT)]
    pub timeout: f64,
    /// The call's priority (its answer keeps it).
    #[arg(long, short, default_value_t = 0, allow_negative_numbers = true)]
    pub priority: i32,
    /// The service to call.
    pub service: String,
    /// The call's lines, such as `'text value "hi"'`; with none, they are
    /// read from standard input, one a line.
    #[arg(value_name = "LINE")]
    pub lines: Vec<String>,
}

#[derive(clap::Args, Debug)]
pub struct ServeArgs {
    #[command(flatten)]
    pub hub: HubAddr,
    /// Seconds callers believe in this provider after they last heard from
    /// it (it announces every third of this): how soon they notice it died.
    #[arg(long, default_value_t = 3.0, value_parser = LEASE)]
    pub lease: f64,
    /// Seconds a command may run for one call before it is killed and the call refused.
    #[arg(long, default_value_t = 10.0, value_parser = super::TIMEOUT)]
    pub command_timeout: f64,
    /// Answer every call with its own lines instead of running a command.
    #[arg(long, conflicts_with = "command")]
    pub echo: bool,
    /// The service to provide.
    pub service: String,
    /// The command run for each call: the call's lines on its standard input,
    /// its standard output's lines the answer; a non-zero exit refuses the
    /// call with the last line of its standard error. Calls are served one
    /// at a time, in the order they arrive; the provider keeps announcing
    /// itself while a command runs. What the command leaves running in the
    /// background is killed when it ends.
    #[arg(last = true, value_name = "COMMAND", required_unless_present = "echo")]
    pub command: Vec<String>,
}

pub fn call(args: CallArgs) -> anyhow::Result<()> {
    let timeout = super::seconds("--timeout", args.timeout)?;
    let lines = if args.lines.is_empty() {
        // A call is one datagram: reading more could only fill memory.
        let mut bytes = Vec::new();
        std::io::stdin()
            .take(MAX_PACKET as u64 + 1)
            .read_to_end(&mut bytes)
            .context("cannot read the call's lines from standard input")?;
        if bytes.len() > MAX_PACKET {
            anyhow::bail!("the call's lines on standard input pass {MAX_PACKET} bytes, more than one packet holds");
        }
        String::from_utf8(bytes)
            .context("the call's lines on standard input are not UTF-8")?
            .lines()
            .filter(|l| !l.trim().is_empty())
            .map(str::to_owned)
            .collect()
    } else {
        args.lines
    };
    let lines: Vec<&str> = lines.iter().map(String::as_str).collect();
    let caller = Caller::new(&args.service)?;
    let mut client = CallClient::with(args.hub.connect()?, caller)?;
    let answer = client.call(Priority(args.priority), &lines, timeout);
    let forged = client.caller().forged();
    if forged > 0 {
        // Someone spoke for a provider: worth an operator's attention even
        // when the real answer came.
        eprintln!(
            "colony: dropped {forged} answers or notices not sealed by the provider they name"
        );
    }
    let answer =
        answer.with_context(|| format!("calling `{}` on {}", args.service, args.hub.addr))?;
    let mut out = std::io::stdout().lock();
    for line in &answer.lines {
        // A provider's words: no control or bidirectional character reaches the terminal.
        writeln!(out, "{}", colony_wire::terminal_line(line))
            .context("cannot write to standard output")?;
    }
    out.flush().context("cannot write to standard output")
}

pub fn serve(args: ServeArgs) -> anyhow::Result<()> {
    let lease = super::seconds("--lease", args.lease)?;
    let limit = super::seconds("--command-timeout", args.command_timeout)?;
    let stop = super::stop_flag()?;
    let provider = Provider::new(&args.service, lease, Instant::now())?;
    let mut server = ServeClient::with(args.hub.connect()?, provider)?;
    // On standard output, for the script that started it: which provider this is.
    println!(
        "provider {} serves `{}` through {}",
        server.provider().id(),
        args.service,
        args.hub.addr
    );
    let _ = std::io::stdout().flush();
    if args.command.is_empty() {
        server.serve(&stop, |asked| Ok(asked.lines.clone()))?;
        return Ok(());
    }

    // Commands run on a worker thread, one at a time, while this loop keeps
    // the hub's lease and the provider's announcements going: a long command
    // must not make callers think the provider died.
    let (jobs, queue) = mpsc::sync_channel::<Asked>(QUEUE);
    let (done_tx, done) = mpsc::channel::<(Ticket, Result<Vec<String>, String>)>();
    let worker = {
        let (command, stop) = (args.command, stop.clone());
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
            finish(&mut server, result)?;
        }
    }
    // The worker refuses what is left at once (the stop flag is set); every
    // taken call gets its refusal before the provider says it is leaving.
    drop(jobs);
    for result in done.iter() {
        finish(&mut server, result)?;
    }
    let _ = worker.join();
    server.leave()?;
    Ok(())
}

/// Runs `command` for one call: what it prints is the answer, a failure the refusal.
fn run_command(
    command: &[String],
    asked: &Asked,
    limit: Duration,
    stop: &AtomicBool,
) -> Result<Vec<String>, String> {
    const STOPPING: &str = "the provider is stopping";
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
    // An answer is one datagram: the first bytes are kept, the rest read and
    // dropped, so the command is never stopped by a full pipe.
    let read = |pipe: Option<Box<dyn std::io::Read + Send>>| {
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
    };
    let stdout = read(child.stdout.take().map(|p| Box::new(p) as _));
    let stderr = read(child.stderr.take().map(|p| Box::new(p) as _));
    let started = Instant::now();
    let ended = loop {
        match child.try_wait() {
            Ok(Some(status)) => break Ok(status),
            // Stopping is not waited out: the caller hears at once.
            Ok(None) if stop.load(Ordering::Relaxed) => break Err(STOPPING.to_string()),
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
