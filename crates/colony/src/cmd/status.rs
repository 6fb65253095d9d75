//! `colony status`: what the hub knows, formatted for people.

use colony_client::status::{fetch_status, format_report};

use super::HubAddr;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub hub: HubAddr,
    /// Seconds to wait for the hub's answer.
    #[arg(long, default_value_t = 3.0, value_parser = super::TIMEOUT)]
    pub timeout: f64,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let report = fetch_status(&args.hub.addr, super::seconds("--timeout", args.timeout)?)?;
    print!("{}", format_report(&report));
    Ok(())
}
