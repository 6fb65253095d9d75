//! `colony demo`: the whole system on one machine. A hub (in this
//! process), the simulated swarm sorting pucks with CACHECONS in the
//! standard configuration in live mode (the world and each robot's controller
//! a hub client of its own, on threads of this process), and the monitor in
//! the browser. Ctrl-C, or `--seconds`, stops all three.

use std::str::FromStr as _;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use colony_hub::{HubSite, HubSpec, HubThread};
use colony_lab::sort::launch::{Controllers, Swarm, SwarmSpec};
use colony_monitor::{Monitor, MonitorConfig};
use colony_sim::{Engine, SceneConfig};
use colony_sort::{Method, SortParams};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Where the demo's hub listens.
    #[arg(
        long = "hub-bind",
        alias = "bind",
        default_value = "127.0.0.1:7400",
        value_name = "HOST:PORT"
    )]
    pub hub_bind: String,
    /// Where the monitor serves its page.
    #[arg(
        long = "monitor-bind",
        default_value = "127.0.0.1:8080",
        value_name = "HOST:PORT"
    )]
    pub monitor_bind: String,
    /// How many times faster than real time the world runs.
    #[arg(long, default_value_t = 1.0, value_parser = super::SPEED)]
    pub speed: f64,
    /// Stop after this many seconds (default: run until Ctrl-C).
    #[arg(long, value_parser = super::RUN_SECONDS)]
    pub seconds: Option<f64>,
    /// Log every packet of the run to this file: a `.clog`, or for a name
    /// ending in `.mcap` an MCAP file for Foxglove or Lichtblick.
    #[arg(long, value_name = "FILE")]
    pub log: Option<std::path::PathBuf>,
    /// The contact engine that steps the arena: rapier (the reference) or disc.
    #[arg(long, value_name = "NAME", value_parser = Engine::from_str, default_value_t = Engine::default())]
    pub engine: Engine,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let deadline = super::deadline("--seconds", args.seconds)?;
    let stop = super::stop_flag()?;
    // The demo's hub takes operator requests from the demo's monitor alone:
    // they share a key made for this run.
    let key = one_run_key();
    let mut spec = HubSpec::new(args.hub_bind.as_str());
    spec.config.key = Some(key.clone());
    spec.log = args.log.clone();
    let server = super::hub::start(&spec, |addr| {
        format!("cannot start the demo's hub on `{addr}` (is a hub already running there? choose another port with --hub-bind)")
    })?;
    let hub = HubSite::Here(HubThread::spawn(server, &stop)?);
    let result = run_with_hub(&args, &hub.addr(), key, &stop, deadline);
    let hub_result = hub.stop();
    result?;
    hub_result.context("the demo's hub failed")?;
    println!("colony demo: stopped");
    Ok(())
}

/// A random key, 256 bits written as hex, that lives as long as this process.
fn one_run_key() -> colony_wire::auth::Key {
    let bytes: [u8; 32] = rand::random();
    let hex: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
    colony_wire::auth::Key::new(hex.as_bytes()).expect("64 hex digits make a key")
}

fn run_with_hub(
    args: &Args,
    hub_addr: &str,
    key: colony_wire::auth::Key,
    stop: &Arc<AtomicBool>,
    deadline: Option<Instant>,
) -> anyhow::Result<()> {
    let monitor = Monitor::start(&MonitorConfig {
        hub: hub_addr.to_string(),
        bind: args.monitor_bind.clone(),
        key: Some(key),
        ..MonitorConfig::default()
    })
    .map_err(|e| match e {
        colony_monitor::MonitorError::Bind { addr, source } => anyhow::anyhow!(
            "cannot serve the monitor on `{addr}`: {source} (is another monitor running? choose another port with --monitor-bind)"
        ),
        e => e.into(),
    })?;
    let mut scene = SceneConfig::default();
    scene.physics.engine = args.engine;
    let spec = SwarmSpec {
        hub: hub_addr.to_string(),
        scene,
        params: SortParams::default(),
        method: Method::CacheCons,
        seed: 1,
    };
    let swarm = Swarm::launch(&spec, Controllers::Threads, stop)
        .context("cannot start the live simulator")?;
    let speed = args.speed;
    let simulator = std::thread::spawn(move || swarm.run(speed, None, |_| {}));
    println!(
        "colony demo: open {} (hub on {hub_addr}; CACHECONS, 4 robots and 40 pucks, {} engine, {}x real time); Ctrl-C stops",
        monitor.url(),
        args.engine,
        args.speed
    );
    let mut outcome = Ok(());
    while !stop.load(Ordering::Relaxed) && deadline.is_none_or(|d| Instant::now() < d) {
        if simulator.is_finished() {
            outcome = Err(anyhow::anyhow!("the live simulator stopped"));
            break;
        }
        if !monitor.is_running() {
            outcome = Err(anyhow::anyhow!("the monitor stopped"));
            break;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    // The world and its controllers stop on the flag, at the deadline as on Ctrl-C.
    stop.store(true, Ordering::Relaxed);
    match simulator.join() {
        Ok(Ok(())) => {}
        Ok(Err(e)) => outcome = outcome.and(Err(e).context("the live simulator failed")),
        Err(_) => outcome = outcome.and(Err(anyhow::anyhow!("the live simulator panicked"))),
    }
    monitor.shutdown()?;
    outcome
}
