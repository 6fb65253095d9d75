//! `colony call` and `colony serve`: request and reply from a shell script.

use std::io::{Read as _, Write as _};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use colony_client::rpc::{Call, CallClient, ServeClient};
use colony_wire::{Priority, MAX_PACKET};

use super::HubAddr;

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
    /// Seconds callers believe in this provider after each announcement
    /// (it announces every third of this): how soon they notice it died.
    #[arg(long, default_value_t = 3.0, value_parser = super::TIMEOUT)]
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
    /// at a time, in the order they arrive.
    #[arg(last = true, value_name = "COMMAND", required_unless_present = "echo")]
    pub command: Vec<String>,
}

pub fn call(args: CallArgs) -> anyhow::Result<()> {
    let timeout = super::seconds("--timeout", args.timeout)?;
    let lines = if args.lines.is_empty() {
        let mut text = String::new();
        std::io::stdin()
            .read_to_string(&mut text)
            .context("cannot read the call's lines from standard input")?;
        text.lines()
            .filter(|l| !l.trim().is_empty())
            .map(str::to_owned)
            .collect()
    } else {
        args.lines
    };
    let lines: Vec<&str> = lines.iter().map(String::as_str).collect();
    let mut client = CallClient::connect(&args.hub.addr, &args.service)?;
    let answer = client
        .call(Priority(args.priority), &lines, timeout)
        .with_context(|| format!("calling `{}` on {}", args.service, args.hub.addr))?;
    let mut out = std::io::stdout().lock();
    for line in &answer.lines {
        writeln!(out, "{line}").context("cannot write to standard output")?;
    }
    out.flush().context("cannot write to standard output")
}

pub fn serve(args: ServeArgs) -> anyhow::Result<()> {
    let lease = super::seconds("--lease", args.lease)?;
    let limit = super::seconds("--command-timeout", args.command_timeout)?;
    let stop = super::stop_flag()?;
    let mut server = ServeClient::connect(&args.hub.addr, &args.service, lease)?;
    // On standard output, for the script that started it: which provider this is.
    println!(
        "provider {} serves `{}` through {}",
        server.provider().id(),
        args.service,
        args.hub.addr
    );
    let command = args.command;
    let handler = |call: &Call<'_>| -> Result<Vec<String>, String> {
        let lines: Vec<String> = call.lines().map(|l| l.as_str().to_owned()).collect();
        if command.is_empty() {
            return Ok(lines);
        }
        run_command(&command, &lines, call.id().to_string(), limit, &stop)
    };
    server.serve(&stop, handler)?;
    Ok(())
}

/// Runs `command` for one call: what it prints is the answer, a failure the refusal.
fn run_command(
    command: &[String],
    lines: &[String],
    call_id: String,
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
        .env("COLONY_CALL_ID", call_id)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot run `{program}`: {e}"))?;
    let mut input = lines.join("\n");
    input.push('\n');
    let stdin = child.stdin.take();
    // Written from a thread of its own: a command that prints before it
    // reads could otherwise fill both pipes and wait on us forever.
    let writer = thread::spawn(move || {
        if let Some(mut stdin) = stdin {
            let _ = stdin.write_all(input.as_bytes());
        }
    });
    // An answer is one datagram; more is read and dropped, never kept.
    let read = |pipe: Option<Box<dyn std::io::Read + Send>>| {
        thread::spawn(move || {
            let mut bytes = Vec::new();
            if let Some(pipe) = pipe {
                let _ = pipe.take(MAX_PACKET as u64 + 1).read_to_end(&mut bytes);
            }
            String::from_utf8_lossy(&bytes).into_owned()
        })
    };
    let stdout = read(child.stdout.take().map(|p| Box::new(p) as _));
    let stderr = read(child.stderr.take().map(|p| Box::new(p) as _));
    let started = Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(status)) => break status,
            // Stopping is not waited out: the caller hears at once.
            Ok(None) if stop.load(Ordering::Relaxed) => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(STOPPING.into());
            }
            Ok(None) if started.elapsed() > limit => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!(
                    "`{program}` ran past --command-timeout ({:.1} s) and was stopped",
                    limit.as_secs_f64()
                ));
            }
            Ok(None) => thread::sleep(Duration::from_millis(2)),
            Err(e) => return Err(format!("cannot wait for `{program}`: {e}")),
        }
    };
    let _ = writer.join();
    let out = stdout.join().unwrap_or_default();
    let err = stderr.join().unwrap_or_default();
    if !status.success() {
        let last = err.lines().rev().find(|l| !l.trim().is_empty());
        return Err(match last {
            Some(line) => format!("`{program}` failed ({status}): {}", line.trim()),
            None => format!("`{program}` failed ({status})"),
        });
    }
    Ok(out
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(str::to_owned)
        .collect())
}
