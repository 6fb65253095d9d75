//! `colony call` and `colony serve`: request and reply from a shell script.

use std::io::{Read as _, Write as _};
use std::time::Instant;

use anyhow::Context as _;
use colony_client::rpc::{runner, CallClient, Caller, Provider, ServeClient};
use colony_wire::{Priority, MAX_PACKET};

use super::{Bounds, HubAddr};

/// A provider's lease: long enough not to flood the hub with announcements,
/// no longer than callers believe one (a minute).
const LEASE: Bounds = Bounds::new(0.1, 60.0, "seconds");

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
    Ok(runner::serve_command(
        &mut server,
        args.command,
        limit,
        &stop,
    )?)
}
