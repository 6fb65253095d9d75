//! `colony status`: what the hub knows, formatted for people.

use std::time::Duration;

use colony_client::status::{fetch_status, format_report};

use super::HubAddr;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub hub: HubAddr,
    /// Seconds to wait for the hub's answer.
    #[arg(long, default_value_t = 3.0)]
    pub timeout: f64,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if !(args.timeout.is_finite() && args.timeout > 0.0) {
        anyhow::bail!("--timeout must be a positive number of seconds");
    }
    // Past what a Duration holds, wait as long as one can.
    let timeout = Duration::try_from_secs_f64(args.timeout).unwrap_or(Duration::MAX);
    let report = fetch_status(&args.hub.addr, timeout)?;
    print!("{}", format_report(&report));
    Ok(())
}
