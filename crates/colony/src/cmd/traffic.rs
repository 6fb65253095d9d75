//! `colony log` and `colony replay`: reading traffic logs.

use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use colony_hub::log::{LogReader, Record};
use colony_wire::{Packet, HUB_SUBJECT};

use super::HubAddr;

#[derive(clap::Args, Debug)]
pub struct LogArgs {
    /// The traffic log, as written by `colony hub --log`.
    pub file: PathBuf,
    /// Only packets on these channels (any subject of the header matches).
    #[arg(long = "channel", short, value_name = "SUBJECT")]
    pub channels: Vec<String>,
    /// Only packets this many seconds or more after the log's first record.
    #[arg(long, value_name = "SECONDS")]
    pub from: Option<f64>,
    /// Only packets up to this many seconds after the log's first record.
    #[arg(long, value_name = "SECONDS")]
    pub to: Option<f64>,
}

#[derive(clap::Args, Debug)]
pub struct ReplayArgs {
    #[command(flatten)]
    pub hub: HubAddr,
    /// The traffic log to publish again.
    pub file: PathBuf,
    /// How much faster than real time (2 is twice as fast).
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// Only packets on these channels.
    #[arg(long = "channel", short, value_name = "SUBJECT")]
    pub channels: Vec<String>,
}

fn wanted(packet: &Packet<'_>, channels: &[String]) -> bool {
    channels.is_empty() || packet.subjects().any(|s| channels.iter().any(|c| c == s))
}

/// Reads every whole record, calling `each` with the time since the first;
/// reports a torn tail on standard error, as the loss it is not.
fn each_record(
    file: &PathBuf,
    mut each: impl FnMut(Duration, &Record) -> anyhow::Result<bool>,
) -> anyhow::Result<u64> {
    let mut reader = LogReader::open(file)?;
    let mut first: Option<u64> = None;
    let mut count = 0;
    for record in reader.by_ref() {
        let record = record?;
        let t0 = *first.get_or_insert(record.time_us);
        count += 1;
        if !each(
            Duration::from_micros(record.time_us.saturating_sub(t0)),
            &record,
        )? {
            return Ok(count);
        }
    }
    if let Some(t) = reader.torn_tail() {
        eprintln!(
            "colony: {} ends in a torn record at byte {} ({} bytes, a write cut short); all {count} records before it were read",
            file.display(),
            t.offset,
            t.bytes
        );
    }
    Ok(count)
}

pub fn list(args: LogArgs) -> anyhow::Result<()> {
    use std::io::Write as _;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    each_record(&args.file, |since, record| {
        let s = since.as_secs_f64();
        if args.from.is_some_and(|f| s < f) {
            return Ok(true);
        }
        if args.to.is_some_and(|t| s > t) {
            return Ok(false);
        }
        match Packet::parse(&record.payload) {
            Ok(p) if wanted(&p, &args.channels) => {
                writeln!(out, "# +{s:.6} s from {}", record.source)?;
                write!(out, "{p}")?;
            }
            Ok(_) => {}
            Err(e) => writeln!(
                out,
                "# +{s:.6} s from {}: unreadable packet: {e}",
                record.source
            )?,
        }
        Ok(true)
    })?;
    out.flush()?;
    Ok(())
}

pub fn replay(args: ReplayArgs) -> anyhow::Result<()> {
    if !(args.speed.is_finite() && args.speed > 0.0) {
        anyhow::bail!("--speed must be a positive number, not {}", args.speed);
    }
    let mut client = args.hub.connect()?;
    let stop = super::stop_flag()?;
    let start = Instant::now();
    let mut first_sent: Option<Duration> = None;
    let mut sent = 0u64;
    each_record(&args.file, |since, record| {
        if stop.load(Ordering::Relaxed) {
            return Ok(false);
        }
        let Ok(packet) = Packet::parse(&record.payload) else {
            return Ok(true);
        };
        // Control requests belonged to their senders; only published traffic is replayed.
        if packet.has_subject(HUB_SUBJECT) || !wanted(&packet, &args.channels) {
            return Ok(true);
        }
        let offset = since - *first_sent.get_or_insert(since);
        let due = start + offset.div_f64(args.speed);
        let now = Instant::now();
        if due > now {
            std::thread::sleep(due - now);
        }
        client
            .publish(&record.payload)
            .context("cannot publish a logged packet")?;
        sent += 1;
        Ok(true)
    })?;
    eprintln!("colony: replayed {sent} packets to {}", client.hub_addr());
    Ok(())
}
