//! `colony bridge`: this hub's channels shared with other sites over Zenoh.

use std::path::PathBuf;

use colony_bridge::{Bridge, BridgeConfig, Mode, Pattern, Site};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The local hub [default: the config file's, else 127.0.0.1:7400].
    #[arg(long, env = "COLONY_HUB", value_name = "HOST:PORT")]
    pub hub: Option<String>,
    /// This site's name, unique among the bridged sites (A-Z a-z 0-9 _ -).
    #[arg(long)]
    pub site: Option<Site>,
    /// How to join Zenoh: `peer` (directly) or `client` (through a router) [default: peer].
    #[arg(long)]
    pub mode: Option<Mode>,
    /// A Zenoh endpoint to connect to, such as tcp/10.0.0.2:7447 (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: Vec<String>,
    /// A Zenoh endpoint to listen on, such as tcp/0.0.0.0:7447 (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    pub listen: Vec<String>,
    /// Channels other sites may take from this hub; `*` stands for any run
    /// of characters (repeatable) [default: *].
    #[arg(long, value_name = "PATTERN")]
    pub export: Vec<String>,
    /// Channels this hub's clients may take from other sites (repeatable) [default: *].
    #[arg(long, value_name = "PATTERN")]
    pub import: Vec<String>,
    /// A TOML file with any of the settings above; flags given here win.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Sign what the bridge sends its hub with this shared key (a hub run
    /// with `--key` and `--auth-all` asks it).
    #[arg(long, value_name = "FILE")]
    pub key: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let mut config = match (&args.config, &args.site) {
        (Some(path), _) => BridgeConfig::from_file(path)?,
        (None, Some(site)) => BridgeConfig::new("127.0.0.1:7400", site.clone()),
        (None, None) => anyhow::bail!("name this site: --site NAME (or a --config file)"),
    };
    if let Some(site) = args.site {
        config.site = site;
    }
    if let Some(hub) = args.hub {
        config.hub = hub;
    }
    if let Some(mode) = args.mode {
        config.mode = mode;
    }
    if !args.connect.is_empty() {
        config.connect = args.connect;
    }
    if !args.listen.is_empty() {
        config.listen = args.listen;
    }
    if !args.export.is_empty() {
        config.export = args.export.iter().map(|p| Pattern::new(p)).collect();
    }
    if !args.import.is_empty() {
        config.import = args.import.iter().map(|p| Pattern::new(p)).collect();
    }
    let key = args.key.as_deref().map(super::read_key).transpose()?;
    let stop = super::stop_flag()?;
    tracing::info!(
        site = %config.site,
        hub = %config.hub,
        mode = config.mode.as_str(),
        connect = ?config.connect,
        listen = ?config.listen,
        "bridge starting"
    );
    let mut bridge = Bridge::start(config, key)?;
    bridge.run(&stop)?;
    Ok(())
}
