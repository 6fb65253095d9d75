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
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let stop = super::stop_flag()?;
    let monitor = Monitor::start(&MonitorConfig {
        hub: args.hub.addr.clone(),
        bind: args.bind,
    })?;
    println!(
        "colony monitor: {} (hub {}); Ctrl-C stops",
        monitor.url(),
        monitor.hub_addr()
    );
    while !stop.load(Ordering::Relaxed) && monitor.is_running() {
        std::thread::sleep(Duration::from_millis(100));
    }
    monitor.shutdown()?;
    Ok(())
}
