//! `colony hub`: the broker on a UDP port.

use std::path::{Path, PathBuf};

use colony_hub::log::Rotation;
use colony_hub::{Cidr, HubConfig, HubSpec, Server, StartError};
use colony_mcap::McapLogWriter;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Address to listen on; 127.0.0.1 keeps the hub to this machine.
    #[arg(long, default_value = "127.0.0.1:7400", value_name = "HOST:PORT")]
    pub bind: String,
    /// Append every accepted packet to this traffic log: a crash-safe `.clog`,
    /// or, for a name ending in `.mcap`, a new MCAP file (chunked, zstd, indexed)
    /// that Foxglove and Lichtblick open; a crash loses at most its last second.
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// Rotate a `.clog` log once it would pass this size (`64K`, `100M`, `2G`; at least 64K):
    /// FILE becomes FILE.1, FILE.1 becomes FILE.2 and so on, and a new FILE begins.
    #[arg(long, value_name = "BYTES", requires = "log", value_parser = super::log_size)]
    pub log_max: Option<u64>,
    /// How many rotated logs to keep (FILE.1 newest to FILE.N oldest; 0: none); older ones are deleted.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 5,
        requires = "log_max",
        value_parser = clap::value_parser!(u32).range(0..=1000)
    )]
    pub log_keep: u32,
    /// Seconds a subscription lasts without a refresh (clients refresh about
    /// three times per lease, so a shorter lease costs traffic).
    #[arg(
        long,
        default_value_t = 10.0,
        value_name = "SECONDS",
        allow_negative_numbers = true,
        value_parser = LEASE
    )]
    pub lease: f64,
    /// Most clients held at once.
    #[arg(long, default_value_t = 4096)]
    pub max_clients: usize,
    /// Sources that may act on other clients (`min_priority`): an address,
    /// an address and port, or a range (10.0.0.0/8). Repeat for more.
    #[arg(long, value_name = "ADDR|CIDR")]
    pub console: Vec<Cidr>,
    /// Only these sources may use the hub at all. Repeat for more.
    #[arg(long, value_name = "CIDR")]
    pub allow: Vec<Cidr>,
    /// A shared key (a file of at least 16 bytes): packets signed with it
    /// may act as a console's from any address.
    #[arg(long, value_name = "FILE")]
    pub key: Option<PathBuf>,
    /// Refuse every packet not signed with --key.
    #[arg(long, requires = "key")]
    pub auth_all: bool,
}

/// A lease from a tenth of a second (shorter, and clients do little but
/// refresh) to a day.
const LEASE: super::Bounds = super::Bounds::new(0.1, 86_400.0, "seconds");

pub fn config(args: &Args) -> anyhow::Result<HubConfig> {
    if args.max_clients == 0 {
        anyhow::bail!("--max-clients must be at least 1");
    }
    Ok(HubConfig {
        lease: super::seconds("--lease", args.lease)?,
        max_clients: args.max_clients,
        consoles: args.console.clone(),
        allow: args.allow.clone(),
        key: args.key.as_deref().map(super::read_key).transpose()?,
        auth_all: args.auth_all,
        ..HubConfig::default()
    })
}

/// A hub open to a network with nothing to say who may use it: worth a warning.
fn open_to_anyone(args: &Args, addr: std::net::SocketAddr) -> bool {
    !addr.ip().is_loopback() && args.allow.is_empty() && args.key.is_none()
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let spec = HubSpec {
        bind: args.bind.clone(),
        config: config(&args)?,
        log: args.log.clone(),
        log_rotation: args.log_max.map(|max_bytes| Rotation {
            max_bytes,
            keep: args.log_keep,
        }),
    };
    let mut server = start(&spec, |addr| {
        format!("cannot listen on `{addr}` (is another hub running there?)")
    })?;
    let stop = super::stop_flag()?;
    let addr = server.local_addr()?;
    tracing::info!(%addr, log = ?args.log, "hub listening");
    if open_to_anyone(&args, addr) {
        tracing::warn!(
            %addr,
            "the hub listens beyond this machine with neither --allow nor --key: anyone who reaches it may publish and subscribe"
        );
    }
    if args.console.is_empty() && args.key.is_none() {
        tracing::info!("no --console and no --key: operator requests (min_priority) are refused");
    }
    server.run(&stop)?;
    tracing::info!("hub stopped");
    Ok(())
}

/// Whether the hub writes its log at `path` as MCAP: a name ending in `.mcap`.
/// (Readers tell the formats apart by their first bytes, not by the name.)
pub fn writes_mcap(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mcap"))
}

/// Binds a hub as `spec` says, with its traffic log: a `.clog` (opened by
/// the hub, torn tails cut), or an MCAP for a name ending in `.mcap` (a new
/// file). `cannot_bind` says, given the address, why a taken one matters.
pub fn start(spec: &HubSpec, cannot_bind: impl FnOnce(&str) -> String) -> anyhow::Result<Server> {
    let mcap = spec.log.as_deref().filter(|p| writes_mcap(p));
    if mcap.is_some() && spec.log_rotation.is_some() {
        anyhow::bail!(
            "--log-max rotates .clog logs only: an MCAP log is one file whose index and summary are \
             written when the hub stops. Log to a .clog to rotate (`colony log export` makes MCAP \
             of it later), or leave out --log-max"
        );
    }
    let plain = HubSpec {
        log: if mcap.is_some() {
            None
        } else {
            spec.log.clone()
        },
        ..spec.clone()
    };
    let server = Server::start(&plain).map_err(|e| match e {
        StartError::Bind { addr, source } => {
            let why = cannot_bind(&addr);
            anyhow::Error::new(source).context(why)
        }
        e => e.into(),
    })?;
    Ok(match mcap {
        Some(path) => server.with_log(McapLogWriter::create(path)?),
        None => server,
    })
}
