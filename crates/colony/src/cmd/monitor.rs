//! `colony monitor`: the system monitor in the browser.

use std::sync::atomic::Ordering;
use std::time::Duration;

use colony_monitor::{Monitor, MonitorConfig};

use super::HubAddr;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub hub: HubAddr,
    /// Where the web page is served. Loopback by default: the page can take
    /// control of robots, so think before opening it to a network.
    #[arg(long, default_value = "127.0.0.1:8080", value_name = "HOST:PORT")]
    pub bind: String,
    /// A host name the page may be opened by, besides the bound address,
    /// localhost, 127.0.0.1 and [::1] (as through a tunnel or a proxy); with
    /// no port, the monitor's. Requests naming any other host are refused, so
    /// a web page cannot reach the monitor by DNS rebinding. Repeatable.
    #[arg(long = "allow-host", value_name = "NAME")]
    pub allow_host: Vec<String>,
    /// A web page origin allowed to open the Foxglove endpoint (`/foxglove`)
    /// besides the monitor's own, as a hosted viewer needs: for example
    /// `https://app.foxglove.dev`. The token is still needed. Repeatable.
    #[arg(long = "foxglove-origin", value_name = "ORIGIN")]
    pub foxglove_origin: Vec<String>,
    /// Serve the pages without the random token the printed address carries:
    /// then anyone who can reach the port may drive the robots.
    #[arg(long)]
    pub no_token: bool,
}

/// Refuses what would open the robots to the web: another site's pages let into the Foxglove
/// endpoint with no token to stop them.
fn check(args: &Args) -> anyhow::Result<()> {
    if args.no_token && !args.foxglove_origin.is_empty() {
        anyhow::bail!(
            "--foxglove-origin with --no-token would let any page of {} drive the robots \
             without a token; drop --no-token (the hosted viewer takes the token in the \
             printed address)",
            args.foxglove_origin.join(", ")
        );
    }
    Ok(())
}

pub fn run(args: Args) -> anyhow::Result<()> {
    check(&args)?;
    let stop = super::stop_flag()?;
    let monitor = Monitor::start(&MonitorConfig {
        hub: args.hub.addr.clone(),
        bind: args.bind,
        allow_hosts: args.allow_host,
        token: !args.no_token,
        key: args.hub.read_key()?,
    })?;
    for origin in &args.foxglove_origin {
        monitor.allow_foxglove_origin(origin);
    }
    println!(
        "colony monitor: {} (hub {}); Ctrl-C stops",
        monitor.url(),
        monitor.hub_addr()
    );
    println!(
        "colony monitor: Foxglove or Lichtblick: open a Foxglove WebSocket connection to {}",
        monitor.foxglove_url()
    );
    while !stop.load(Ordering::Relaxed) && monitor.is_running() {
        std::thread::sleep(Duration::from_millis(100));
    }
    monitor.shutdown()?;
    Ok(())
}
