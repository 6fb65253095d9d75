//! One module per subcommand, plus what they share.

pub mod demo;
pub mod game;
pub mod hub;
pub mod monitor;
pub mod path;
pub mod pubsub;
pub mod sort;
pub mod status;
pub mod tasks;
pub mod traffic;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use clap::Args;
use colony_client::UdpClient;

/// Where the hub is, for every command that talks to one.
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
}

impl HubAddr {
    pub fn connect(&self) -> anyhow::Result<UdpClient> {
        Ok(UdpClient::connect_to(&self.addr)?)
    }
}

/// A positive number of seconds given on the command line; one past what a `Duration` holds is
/// the longest `Duration`.
pub fn seconds(flag: &str, s: f64) -> anyhow::Result<Duration> {
    if !(s.is_finite() && s > 0.0) {
        anyhow::bail!("{flag} must be a positive number of seconds, not {s}");
    }
    Ok(Duration::try_from_secs_f64(s).unwrap_or(Duration::MAX))
}

/// When a run given `--seconds` on the command line should end: `None` for no limit, or for a
/// limit beyond what the clock can hold (the run then lasts until Ctrl-C).
pub fn deadline(flag: &str, seconds: Option<f64>) -> anyhow::Result<Option<Instant>> {
    let Some(s) = seconds else { return Ok(None) };
    Ok(Instant::now().checked_add(self::seconds(flag, s)?))
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
    let bytes = std::fs::read(path)
        .map_err(|e| anyhow::anyhow!("cannot read the key file `{}`: {e}", path.display()))?;
    colony_wire::auth::Key::new(&bytes)
        .map_err(|e| anyhow::anyhow!("the key file `{}`: {e}", path.display()))
}
