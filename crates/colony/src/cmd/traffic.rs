//! `colony log` and `colony replay`: reading traffic logs.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use colony_hub::log::TornTail;
use colony_hub::replay::{for_each_timed, on_channels, ReplayOptions};
use colony_wire::Packet;

use super::HubAddr;

#[derive(clap::Args, Debug)]
pub struct LogArgs {
    /// The traffic log, as written by `colony hub --log`.
    pub file: PathBuf,
    /// Only packets on these channels (any subject of the header matches).
    #[arg(long = "channel", short, value_name = "SUBJECT")]
    pub channels: Vec<String>,
    /// Only packets this many seconds or more after the log's first record.
    #[arg(long, value_name = "SECONDS", value_parser = super::OFFSET_SECONDS)]
    pub from: Option<f64>,
    /// Only packets up to this many seconds after the log's first record.
    #[arg(long, value_name = "SECONDS", value_parser = super::OFFSET_SECONDS)]
    pub to: Option<f64>,
}

#[derive(clap::Args, Debug)]
pub struct ReplayArgs {
    #[command(flatten)]
    pub hub: HubAddr,
    /// The traffic log to publish again.
    pub file: PathBuf,
    /// How much faster than real time (2 is twice as fast).
    #[arg(long, default_value_t = 1.0, value_parser = super::SPEED)]
    pub speed: f64,
    /// Only packets on these channels.
    #[arg(long = "channel", short, value_name = "SUBJECT")]
    pub channels: Vec<String>,
}

/// Says on standard error that the log ends in a torn record, as the loss it is not.
fn report_torn(file: &Path, pass_records: u64, torn: Option<&TornTail>) {
    if let Some(t) = torn {
        eprintln!(
            "colony: {} ends in a torn record at byte {} ({} bytes, a write cut short); all {pass_records} records before it were read",
            file.display(),
            t.offset,
            t.bytes
        );
    }
}

pub fn list(args: LogArgs) -> anyhow::Result<()> {
    use std::io::Write as _;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    let pass = for_each_timed(&args.file, |since, record| -> anyhow::Result<bool> {
        let s = since.as_secs_f64();
        if args.from.is_some_and(|f| s < f) {
            return Ok(true);
        }
        if args.to.is_some_and(|t| s > t) {
            return Ok(false);
        }
        match Packet::parse(&record.payload) {
            Ok(p) if on_channels(&p, &args.channels) => {
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
    report_torn(&args.file, pass.records, pass.torn.as_ref());
    out.flush()?;
    Ok(())
}

pub fn replay(args: ReplayArgs) -> anyhow::Result<()> {
    let mut client = args.hub.connect()?;
    let stop = super::stop_flag()?;
    let options = ReplayOptions {
        speed: args.speed,
        channels: args.channels.clone(),
    };
    let replayed = colony_hub::replay::replay(&args.file, &options, &stop, |p| {
        client.publish(p).context("cannot publish a logged packet")
    })?;
    report_torn(&args.file, replayed.records, replayed.torn.as_ref());
    eprintln!(
        "colony: replayed {} packets to {}",
        replayed.sent,
        client.hub_addr()
    );
    Ok(())
}
