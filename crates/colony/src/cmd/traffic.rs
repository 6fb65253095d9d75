//! `colony log` and `colony replay`: reading traffic logs (`.clog` or MCAP,
//! told apart by their first bytes), exporting them as MCAP and recovering a
//! torn MCAP.

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::Context as _;
use colony_hub::log::Record;
use colony_hub::replay::{for_each_timed_in, on_channels, replay_records, ReplayOptions};
use colony_mcap::{McapEnd, McapLogWriter, TrafficReader};
use colony_wire::{BlockWriter, Packet};

use super::HubAddr;

/// `colony log FILE`, or one of its subcommands.
#[derive(clap::Args, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct LogCommand {
    #[command(subcommand)]
    pub action: Option<LogAction>,
    #[command(flatten)]
    pub list: LogArgs,
}

#[derive(clap::Subcommand, Debug)]
pub enum LogAction {
    /// Write a traffic log (what the filters keep of it) as MCAP, for Foxglove,
    /// Lichtblick and other MCAP tools.
    Export(ExportArgs),
    /// Rewrite an MCAP log that a crash cut short (or that has a damaged chunk)
    /// as a valid MCAP holding every whole chunk.
    Recover(RecoverArgs),
    /// Summarise a log: its records, time span, and packets and bytes per
    /// channel (as `mcap info` does), instead of listing every packet.
    Info(InfoArgs),
}

#[derive(clap::Args, Debug)]
pub struct InfoArgs {
    /// The traffic log (a `.clog` or an MCAP).
    pub file: PathBuf,
}

/// Which records of a log to take.
#[derive(clap::Args, Debug)]
pub struct Filter {
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

/// What the filter says of a record.
enum Take<'a> {
    /// Take it.
    Yes(Packet<'a>),
    /// Take it, though it is not a packet (why not).
    Unreadable(String),
    /// Leave it.
    No,
    /// Leave it and everything after it.
    Stop,
}

impl Filter {
    fn take<'a>(&self, since: Duration, record: &'a Record) -> Take<'a> {
        let s = since.as_secs_f64();
        if self.from.is_some_and(|f| s < f) {
            return Take::No;
        }
        if self.to.is_some_and(|t| s > t) {
            return Take::Stop;
        }
        match Packet::parse(&record.payload) {
            Ok(p) if on_channels(&p, &self.channels) => Take::Yes(p),
            Ok(_) => Take::No,
            Err(e) => Take::Unreadable(e.to_string()),
        }
    }
}

#[derive(clap::Args, Debug)]
pub struct LogArgs {
    /// The traffic log, as written by `colony hub --log` (a `.clog` or an MCAP).
    /// Each packet is listed after a `#` line of when and whom it came from, a
    /// blank line between packets (`colony pub` reads them back).
    #[arg(required = true)]
    pub file: Option<PathBuf>,
    /// List each packet as it came, not with the characters that could act on a
    /// terminal (C1 controls, marks that reorder text) shown as `\u{9b}`.
    #[arg(long)]
    pub raw: bool,
    #[command(flatten)]
    pub filter: Filter,
}

#[derive(clap::Args, Debug)]
pub struct ExportArgs {
    /// The traffic log to export (a `.clog` or an MCAP).
    pub file: PathBuf,
    /// The MCAP file to write (it must not exist yet).
    #[arg(long, value_name = "OUT.mcap")]
    pub mcap: PathBuf,
    #[command(flatten)]
    pub filter: Filter,
}

#[derive(clap::Args, Debug)]
pub struct RecoverArgs {
    /// The damaged MCAP log.
    pub file: PathBuf,
    /// The MCAP file to write (it must not exist yet).
    pub out: PathBuf,
}

#[derive(clap::Args, Debug)]
pub struct ReplayArgs {
    #[command(flatten)]
    pub hub: HubAddr,
    /// The traffic log to publish again (a `.clog` or an MCAP).
    pub file: PathBuf,
    /// How much faster than real time (2 is twice as fast).
    #[arg(long, default_value_t = 1.0, value_parser = super::SPEED)]
    pub speed: f64,
    /// Only packets on these channels.
    #[arg(long = "channel", short, value_name = "SUBJECT")]
    pub channels: Vec<String>,
    /// The longest wait for the next packet: a longer silence in the log (at
    /// --speed) is skipped, with a note on standard error.
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 10.0,
        value_parser = MAX_GAP,
        allow_negative_numbers = true
    )]
    pub max_gap: f64,
}

/// A wait for a replayed packet: a millisecond to a day.
const MAX_GAP: super::Bounds = super::Bounds::new(0.001, 86_400.0, "seconds");

/// Opens a log of either format.
fn open(file: &Path) -> anyhow::Result<TrafficReader> {
    Ok(TrafficReader::open(file)?)
}

/// Says on standard error what a crash cut short, as the loss it is (or is not).
fn report_damage(log: &TrafficReader) {
    if let Some(note) = log.damage() {
        eprintln!("colony: {note}");
    }
}

pub fn run(args: LogCommand) -> anyhow::Result<()> {
    match args.action {
        Some(LogAction::Export(a)) => export(a),
        Some(LogAction::Recover(a)) => recover(a),
        Some(LogAction::Info(a)) => info(a),
        None => list(args.list),
    }
}

fn list(args: LogArgs) -> anyhow::Result<()> {
    use std::io::Write as _;
    let file = args.file.context("no log given")?;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    let mut log = open(&file)?;
    let mut blocks = BlockWriter::new();
    for_each_timed_in(
        log.by_ref().map(|r| r.map_err(anyhow::Error::from)),
        |since, record| -> anyhow::Result<bool> {
            let s = since.as_secs_f64();
            let block = match args.filter.take(since, record) {
                Take::Stop => return Ok(false),
                Take::No => return Ok(true),
                Take::Yes(p) => blocks.block(
                    &[&format!("+{s:.6} s from {}", record.source)],
                    Some(&p),
                    !args.raw,
                ),
                Take::Unreadable(e) => blocks.block(
                    &[&format!(
                        "+{s:.6} s from {}: unreadable packet: {e}",
                        record.source
                    )],
                    None,
                    !args.raw,
                ),
            };
            out.write_all(block.as_bytes())?;
            Ok(true)
        },
    )?;
    report_damage(&log);
    out.flush()?;
    Ok(())
}

/// What `colony log info` counts: a log's channels and its time span, in
/// memory bounded by the channels, at most [`MAX_INFO_CHANNELS`] (a forged
/// flood of new subjects is counted under one line).
#[derive(Debug, Default)]
struct Summary {
    records: u64,
    bytes: u64,
    unreadable: u64,
    first_us: Option<u64>,
    last_us: Option<u64>,
    channels: std::collections::BTreeMap<String, (u64, u64)>,
    other: (u64, u64),
}

/// Channels `colony log info` lists one by one; the rest share one line.
const MAX_INFO_CHANNELS: usize = 1024;

impl Summary {
    fn add(&mut self, record: &Record) {
        self.records += 1;
        let len = record.payload.len() as u64;
        self.bytes += len;
        self.first_us = Some(
            self.first_us
                .map_or(record.time_us, |t| t.min(record.time_us)),
        );
        self.last_us = Some(
            self.last_us
                .map_or(record.time_us, |t| t.max(record.time_us)),
        );
        let Ok(p) = Packet::parse(&record.payload) else {
            self.unreadable += 1;
            return;
        };
        let topic =
            colony_wire::terminal_line(&p.subjects().collect::<Vec<_>>().join(" ")).into_owned();
        let full = self.channels.len() >= MAX_INFO_CHANNELS && !self.channels.contains_key(&topic);
        let slot = if full {
            &mut self.other
        } else {
            self.channels.entry(topic).or_default()
        };
        slot.0 += 1;
        slot.1 += len;
    }

    fn text(&self, file: &Path) -> String {
        use std::fmt::Write as _;
        let mut out = String::new();
        let span = match (self.first_us, self.last_us) {
            (Some(a), Some(b)) => (b - a) as f64 / 1e6,
            _ => 0.0,
        };
        let when = |us: Option<u64>| {
            us.map_or_else(
                || "-".to_owned(),
                |us| format!("{:.6} s after the Unix epoch", us as f64 / 1e6),
            )
        };
        let _ = writeln!(out, "file:     {}", file.display());
        let _ = writeln!(
            out,
            "records:  {} ({} bytes, {} not packets)",
            self.records, self.bytes, self.unreadable
        );
        let _ = writeln!(out, "start:    {}", when(self.first_us));
        let _ = writeln!(out, "end:      {}", when(self.last_us));
        let _ = writeln!(out, "duration: {span:.3} s");
        let _ = writeln!(
            out,
            "channels: {}",
            self.channels.len() + usize::from(self.other.0 > 0)
        );
        let mut rows: Vec<(&str, &(u64, u64))> =
            self.channels.iter().map(|(k, v)| (k.as_str(), v)).collect();
        rows.sort_by(|a, b| b.1 .0.cmp(&a.1 .0).then_with(|| a.0.cmp(b.0)));
        if self.other.0 > 0 {
            rows.push(("(other channels)", &self.other));
        }
        for (topic, (packets, bytes)) in rows {
            let rate = if span > 0.0 {
                *packets as f64 / span
            } else {
                0.0
            };
            let _ = writeln!(
                out,
                "  {topic:<32} {packets:>10} packets {bytes:>12} bytes {rate:>10.1}/s"
            );
        }
        out
    }
}

fn info(args: InfoArgs) -> anyhow::Result<()> {
    let mut log = open(&args.file)?;
    let mut summary = Summary::default();
    for record in log.by_ref() {
        summary.add(&record?);
    }
    report_damage(&log);
    print!("{}", summary.text(&args.file));
    Ok(())
}

/// Writes `out` by way of `OUT.partial` beside it (created new, so two runs
/// never share one), renamed onto `out` only once `write` has succeeded: a
/// failed run leaves no finished-looking `out`, and its partial file is
/// removed, so that running it again is not refused.
fn write_via_partial<T>(
    out: &Path,
    write: impl FnOnce(&Path) -> anyhow::Result<T>,
) -> anyhow::Result<T> {
    if std::fs::metadata(out).is_ok_and(|m| m.len() > 0) {
        return Err(colony_mcap::McapLogError::Exists {
            path: out.to_owned(),
        }
        .into());
    }
    let mut name = out.as_os_str().to_owned();
    name.push(".partial");
    let partial = PathBuf::from(name);
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&partial)
        .with_context(|| {
            format!(
                "cannot create {} (if another run left it, remove it)",
                partial.display()
            )
        })?;
    match write(&partial) {
        Ok(v) => {
            std::fs::rename(&partial, out).with_context(|| {
                format!("cannot rename {} to {}", partial.display(), out.display())
            })?;
            Ok(v)
        }
        Err(e) => {
            match std::fs::remove_file(&partial) {
                Ok(()) => eprintln!(
                    "colony: removed the unfinished {}; {} was not written",
                    partial.display(),
                    out.display()
                ),
                Err(r) => eprintln!(
                    "colony: {} is unfinished and could not be removed ({r})",
                    partial.display()
                ),
            }
            Err(e)
        }
    }
}

fn export(args: ExportArgs) -> anyhow::Result<()> {
    let mut log = open(&args.file)?;
    let (out, unreadable) =
        write_via_partial(&args.mcap, |partial| export_to(&args, &mut log, partial))?;
    report_damage(&log);
    if unreadable > 0 {
        eprintln!("colony: left out {unreadable} records that are not packets");
    }
    eprintln!(
        "colony: wrote {} messages to {}",
        out.messages(),
        args.mcap.display()
    );
    Ok(())
}

fn export_to(
    args: &ExportArgs,
    log: &mut TrafficReader,
    partial: &Path,
) -> anyhow::Result<(McapLogWriter, u64)> {
    let mut out = McapLogWriter::create(partial)?;
    let mut unreadable = 0u64;
    for_each_timed_in(
        log.by_ref().map(|r| r.map_err(anyhow::Error::from)),
        |since, record| -> anyhow::Result<bool> {
            match args.filter.take(since, record) {
                Take::Stop => return Ok(false),
                Take::No => {}
                Take::Yes(_) | Take::Unreadable(_) => {
                    if !out.append_record(record)? {
                        unreadable += 1;
                    }
                }
            }
            Ok(true)
        },
    )?;
    out.finish()?;
    Ok((out, unreadable))
}

fn recover(args: RecoverArgs) -> anyhow::Result<()> {
    let r = write_via_partial(&args.out, |partial| {
        Ok(colony_mcap::recover(&args.file, partial)?)
    })?;
    match r.end {
        McapEnd::Finished => eprintln!(
            "colony: {} was finished (its writer wrote its summary)",
            args.file.display()
        ),
        McapEnd::Torn { offset, bytes } => eprintln!(
            "colony: {} ends before its writer finished: the {bytes} bytes from byte {offset} on were not whole and are lost",
            args.file.display()
        ),
    }
    for (offset, why) in &r.skipped {
        eprintln!("colony: skipped the corrupt record at byte {offset} ({why})");
    }
    if r.foreign > 0 {
        eprintln!(
            "colony: skipped {} messages that colony did not write",
            r.foreign
        );
    }
    if r.unwritable > 0 {
        eprintln!(
            "colony: left out {} messages whose text is not a packet",
            r.unwritable
        );
    }
    eprintln!(
        "colony: recovered {} messages from {} whole chunks into {}",
        r.messages,
        r.chunks,
        args.out.display()
    );
    Ok(())
}

pub fn replay(args: ReplayArgs) -> anyhow::Result<()> {
    let mut client = args.hub.connect()?;
    let stop = super::stop_flag()?;
    let options = ReplayOptions {
        speed: args.speed,
        channels: args.channels.clone(),
        max_gap: super::seconds("--max-gap", args.max_gap)?,
    };
    let mut log = open(&args.file)?;
    let (sent, _records) = replay_records(
        log.by_ref().map(|r| r.map_err(anyhow::Error::from)),
        &options,
        &stop,
        |p| client.publish(p).context("cannot publish a logged packet"),
        |g| {
            eprintln!(
                "colony: skipped {:.3} s of silence in the log before its packet at +{:.3} s (longer than --max-gap {} s at --speed {})",
                g.gap.as_secs_f64(),
                g.at.as_secs_f64(),
                args.max_gap,
                args.speed
            )
        },
    )?;
    report_damage(&log);
    eprintln!("colony: replayed {sent} packets to {}", client.hub_addr());
    Ok(())
}
