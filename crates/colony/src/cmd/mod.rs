//! One module per subcommand, plus what they share.

pub mod bridge;
pub mod demo;
pub mod game;
pub mod hub;
pub mod monitor;
pub mod path;
pub mod progress;
pub mod pubsub;
pub mod rpc;
pub mod sort;
pub mod spy;
pub mod status;
pub mod tasks;
pub mod traffic;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use clap::Args;
use colony_client::UdpClient;

/// Where the hub is, and its key, for every command that talks to one.
#[derive(Args, Debug, Clone)]
pub struct HubAddr {
    /// The hub's address.
    #[arg(
        long = "hub",
        env = "COLONY_HUB",
        default_value = "127.0.0.1:7400",
        value_name = "HOST:PORT"
    )]
    pub addr: String,
    /// The hub's shared key (`colony hub --key FILE`): every packet is signed
    /// with it, as a hub run with `--auth-all` asks, and operator requests
    /// count as a console's.
    #[arg(long = "key", env = "COLONY_KEY", value_name = "FILE")]
    pub key: Option<std::path::PathBuf>,
}

impl HubAddr {
    /// The hub at `addr`, with no key.
    pub fn at(addr: &str) -> HubAddr {
        HubAddr {
            addr: addr.to_owned(),
            key: None,
        }
    }

    /// A client of the hub, signing with the key when there is one.
    pub fn connect(&self) -> anyhow::Result<UdpClient> {
        let mut client = UdpClient::connect_to(&self.addr)?;
        if let Some(key) = self.read_key()? {
            client.set_key(key);
        }
        Ok(client)
    }

    /// The key, read from its file.
    pub fn read_key(&self) -> anyhow::Result<Option<colony_wire::auth::Key>> {
        self.key.as_deref().map(read_key).transpose()
    }

    /// Refuses a key for a command that cannot sign yet, rather than ignore it.
    pub fn no_key(&self, command: &str) -> anyhow::Result<()> {
        match &self.key {
            Some(path) => anyhow::bail!(
                "--key {} (or COLONY_KEY): {command} does not sign its packets yet, so a hub \
                 run with --auth-all would drop them; run it against a hub without --auth-all",
                path.display()
            ),
            None => Ok(()),
        }
    }
}

/// The one rule for every floating-point flag: clap parses it with a [`Bounds`]
/// (`#[arg(value_parser = SPEED)]`), so NaN, infinities and values that would
/// overflow a `Duration` or make a loop spin are refused as usage errors
/// (exit 2) that name the flag and the range, before any command runs.
#[derive(Debug, Clone, Copy)]
pub struct Bounds {
    min: f64,
    max: f64,
    unit: &'static str,
}

impl Bounds {
    /// Values from `min` to `max` inclusive, in `unit` (for messages).
    pub const fn new(min: f64, max: f64, unit: &'static str) -> Bounds {
        Bounds { min, max, unit }
    }

    /// `value` when it lies within the bounds (never NaN), or why not (the
    /// caller shows the value as it was typed: `1e308` is clearer than its 309 digits).
    pub fn check(&self, value: f64) -> Result<f64, String> {
        if (self.min..=self.max).contains(&value) {
            Ok(value)
        } else {
            Err(format!(
                "must be from {} to {} {}",
                self.min, self.max, self.unit
            ))
        }
    }
}

impl clap::builder::TypedValueParser for Bounds {
    type Value = f64;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<f64, clap::Error> {
        let invalid = |why: String| {
            let flag = arg.map_or_else(|| "value".to_string(), ToString::to_string);
            cmd.clone().error(
                clap::error::ErrorKind::ValueValidation,
                format!(
                    "invalid value '{}' for '{flag}': {why}",
                    value.to_string_lossy()
                ),
            )
        };
        let text = value
            .to_str()
            .ok_or_else(|| invalid("not a number".into()))?;
        let number: f64 = text
            .trim()
            .parse()
            .map_err(|_| invalid("not a number".into()))?;
        self.check(number).map_err(invalid)
    }
}

/// How many times faster than real time a world or a replay runs: slower
/// than 1/1000 makes a step last minutes, faster than a million is as fast
/// as the machine goes anyway.
pub const SPEED: Bounds = Bounds::new(0.001, 1e6, "times real time");
/// How long to wait for an answer: a millisecond to a day.
pub const TIMEOUT: Bounds = Bounds::new(0.001, 86_400.0, "seconds");
/// How long a run lasts before it stops by itself: a millisecond to a year
/// (`Instant` arithmetic on longer spans can overflow).
pub const RUN_SECONDS: Bounds = Bounds::new(0.001, 365.0 * 86_400.0, "seconds");
/// A point in a log or a simulation, seconds from its start: up to a century.
pub const OFFSET_SECONDS: Bounds = Bounds::new(0.0, 100.0 * 365.0 * 86_400.0, "seconds");

/// A number of seconds given on the command line (and already bounded by
/// clap) as a `Duration`; a value out of `Duration`'s range is refused here
/// too, for a caller that has not bounded it.
pub fn seconds(flag: &str, s: f64) -> anyhow::Result<Duration> {
    if !(s.is_finite() && s > 0.0) {
        anyhow::bail!("{flag} must be a positive number of seconds, not {s}");
    }
    Duration::try_from_secs_f64(s).map_err(|_| anyhow::anyhow!("{flag} is too many seconds: {s}"))
}

/// When a run given `--seconds` on the command line should end: `None` for
/// no limit (or, should a bound ever allow one, a limit beyond what the clock
/// can hold: the run then lasts until Ctrl-C).
pub fn deadline(flag: &str, seconds: Option<f64>) -> anyhow::Result<Option<Instant>> {
    let Some(s) = seconds else { return Ok(None) };
    Ok(Instant::now().checked_add(self::seconds(flag, s)?))
}

/// The smallest `--log-max`: about one largest record.
const LOG_MAX_MIN: u64 = 64 * 1024;

/// A `--log-max` size in bytes, with an optional binary suffix: `65536`, `64K`, `100M`, `2G`.
pub fn log_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let (digits, unit) = match t.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => (&t[..i], c.to_ascii_uppercase()),
        _ => (t, 'B'),
    };
    let shift = match unit {
        'B' => 0,
        'K' => 10,
        'M' => 20,
        'G' => 30,
        'T' => 40,
        _ => return Err(format!("`{text}`: the suffix may be K, M, G or T")),
    };
    let n: u64 = digits
        .parse()
        .map_err(|_| format!("`{text}` is not a size such as 65536, 64K or 100M"))?;
    let bytes = n
        .checked_mul(1 << shift)
        .ok_or_else(|| format!("`{text}` is too large"))?;
    if bytes < LOG_MAX_MIN {
        return Err(format!("must be at least 64K, not {text}"));
    }
    Ok(bytes)
}

/// A flag set by Ctrl-C or SIGTERM, so loops can stop cleanly.
pub fn stop_flag() -> anyhow::Result<Arc<AtomicBool>> {
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    ctrlc::set_handler(move || s.store(true, Ordering::Relaxed))
        .context("cannot install the Ctrl-C handler")?;
    Ok(stop)
}

/// Reads a shared key from a file, with an error that names the file.
pub fn read_key(path: &std::path::Path) -> anyhow::Result<colony_wire::auth::Key> {
    use std::io::Read as _;
    // A key is a few dozen bytes; a bounded read keeps `--key /dev/zero`
    // from filling memory.
    const MAX_KEY_FILE: u64 = 4096;
    let cannot =
        |e: std::io::Error| anyhow::anyhow!("cannot read the key file `{}`: {e}", path.display());
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .map_err(cannot)?
        .take(MAX_KEY_FILE + 1)
        .read_to_end(&mut bytes)
        .map_err(cannot)?;
    if bytes.len() as u64 > MAX_KEY_FILE {
        anyhow::bail!(
            "the key file `{}` is longer than {MAX_KEY_FILE} bytes: is it a key?",
            path.display()
        );
    }
    colony_wire::auth::Key::new(&bytes)
        .map_err(|e| anyhow::anyhow!("the key file `{}`: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_sizes_take_binary_suffixes_and_refuse_what_is_too_small_or_too_large() {
        assert_eq!(log_size("65536"), Ok(65_536));
        assert_eq!(log_size("64K"), Ok(65_536));
        assert_eq!(log_size("100m"), Ok(100 << 20));
        assert_eq!(log_size("2G"), Ok(2 << 30));
        for bad in ["10", "63K", "1Q", "K", "", "-1M", "99999999999T", "1.5M"] {
            assert!(log_size(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn bounds_refuse_nan_and_infinities() {
        for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 0.0, 1e7] {
            assert!(SPEED.check(v).is_err(), "{v}");
        }
        assert_eq!(SPEED.check(1.0), Ok(1.0));
    }
}
