//! `colony hub`: the broker on a UDP port.

use std::path::PathBuf;
use std::time::Duration;

use colony_hub::{HubConfig, HubSpec, Server, StartError};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Address to listen on; 127.0.0.1 keeps the hub to this machine.
    #[arg(long, default_value = "127.0.0.1:7400", value_name = "HOST:PORT")]
    pub bind: String,
    /// Append every accepted packet to this traffic log.
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// Seconds a subscription lasts without a refresh.
    #[arg(
        long,
        default_value_t = 10.0,
        value_name = "SECONDS",
        allow_negative_numbers = true
    )]
    pub lease: f64,
    /// Most clients held at once.
    #[arg(long, default_value_t = 4096)]
    pub max_clients: usize,
}

pub fn config(args: &Args) -> anyhow::Result<HubConfig> {
    if !(args.lease.is_finite() && args.lease > 0.0 && args.lease <= 86_400.0) {
        anyhow::bail!(
            "--lease must be between 0 and 86400 seconds, not {}",
            args.lease
        );
    }
    if args.max_clients == 0 {
        anyhow::bail!("--max-clients must be at least 1");
    }
    Ok(HubConfig {
        lease: Duration::from_secs_f64(args.lease),
        max_clients: args.max_clients,
        ..HubConfig::default()
    })
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let spec = HubSpec {
        bind: args.bind.clone(),
        config: config(&args)?,
        log: args.log.clone(),
    };
    let mut server = Server::start(&spec).map_err(|e| match e {
        StartError::Bind { addr, source } => anyhow::Error::new(source).context(format!(
            "cannot listen on `{addr}` (is another hub running there?)"
        )),
        e => e.into(),
    })?;
    let stop = super::stop_flag()?;
    tracing::info!(addr = %server.local_addr()?, log = ?args.log, "hub listening");
    server.run(&stop)?;
    tracing::info!("hub stopped");
    Ok(())
}
