//! `hub-bench`: the colony hub on loopback against a raw UDP relay and
//! Mosquitto, in one run. Latency of a 100-byte packet (one in flight) and
//! delivered throughput at several fan-outs. Prints a markdown report and can
//! write it into BENCHMARKS.md under `## Hub on loopback`.
#![forbid(unsafe_code)]

mod hub;
mod latency;
mod mqtt;
mod names;
mod payload;
mod relay;
mod report;
mod sys;
mod throughput;

use std::net::UdpSocket;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::Context;
use clap::Parser;
use colony_hub::HubConfig;
use colony_wire::Request;

use crate::hub::{subscribe_udp_with, HubThread};
use crate::throughput::{CpuProbe, Fanout, MqttPub, MqttSub, Subscriber, UdpPub, UdpSub};

#[derive(Parser, Debug)]
#[command(
    name = "hub-bench",
    about = "colony hub vs raw UDP and Mosquitto on 127.0.0.1: latency and fan-out throughput"
)]
struct Args {
    /// Recorded latency samples per system.
    #[arg(long, default_value_t = 20_000)]
    samples: usize,
    /// Unrecorded latency samples first.
    #[arg(long, default_value_t = 2_000)]
    warmup: usize,
    /// Measured seconds per throughput run.
    #[arg(long, default_value_t = 3.0, value_parser = seconds_arg)]
    duration: f64,
    /// Unmeasured seconds before each throughput run is measured.
    #[arg(long, default_value_t = 0.3, value_parser = seconds_arg)]
    settle: f64,
    /// Fan-outs (subscriber counts) for the throughput runs.
    #[arg(long, value_delimiter = ',', default_value = "1,10,100")]
    fanouts: Vec<usize>,
    /// Packets the publisher may have in flight beyond the slowest subscriber.
    #[arg(long, default_value_t = 128)]
    window: u64,
    /// Thread placement for the throughput runs: `none` lets the scheduler
    /// place everything; `split` keeps the broker on CPU 1 and the publisher
    /// and receivers on CPU 0.
    #[arg(long, value_enum, default_value = "split")]
    throughput_pin: Pin,
    /// Receiver threads the subscribers are spread over.
    #[arg(long, default_value_t = 2)]
    recv_threads: usize,
    /// Receive buffer asked for on every UDP subscriber socket, in bytes.
    #[arg(long, default_value_t = 4 << 20)]
    rcvbuf: usize,
    /// The Mosquitto broker to start (it is stopped again at the end).
    #[arg(long, default_value = "mosquitto")]
    mosquitto: PathBuf,
    /// Skip Mosquitto (no comparison, so no verdict on the targets).
    #[arg(long)]
    no_mosquitto: bool,
    /// Throughput rounds; each system's best round is reported.
    #[arg(long, default_value_t = 3)]
    rounds: usize,
    /// Before each throughput run, wait up to this many seconds for other
    /// processes to use under 10 % of the machine (0: don't wait).
    #[arg(long, default_value_t = 30.0, value_parser = seconds_arg)]
    quiet_wait: f64,
    /// Also run the relay with UDP GSO (`UDP_SEGMENT`), sending each run of
    /// equal-length packets (and a shorter one after it) to a subscriber as
    /// one datagram train: an
    /// experiment showing what fewer trips through the stack would give.
    #[arg(long)]
    relay_gso: bool,
    /// Publish to the hub and the relays one datagram per `sendmmsg` entry
    /// instead of sending runs of equal-length packets with UDP GSO (the
    /// receiving side sees the same datagrams either way).
    #[arg(long)]
    plain_publisher: bool,
    /// The most bytes the hub's batching subscribers take in one datagram
    /// (`batch bytes N`): 1,472 is what fills one 1,500-byte Ethernet frame
    /// over IPv4, what a robot on a real link would ask for.
    #[arg(long, default_value_t = 1472, value_parser = clap::value_parser!(u16).range(1..))]
    batch_bytes: u16,
    /// Skip the hub with batching subscribers in the throughput runs.
    #[arg(long)]
    no_batching: bool,
    /// Skip the raw UDP relay in the throughput runs.
    #[arg(long)]
    no_relay: bool,
    /// Run the latency part only (for profiling).
    #[arg(long)]
    latency_only: bool,
    /// Skip the latency part (it always uses 100-byte packets).
    #[arg(long)]
    no_latency: bool,
    /// Packet lengths in the throughput runs: `fixed` (100 bytes) or `mixed`
    /// (60 to 400, differing from packet to packet). A mixed run writes its
    /// own section of BENCHMARKS.md.
    #[arg(long, value_enum, default_value = "fixed")]
    lengths: payload::Lengths,
    /// Also write the report into this markdown file, replacing its
    /// `## Hub on loopback` section (or adding one) and keeping the rest.
    #[arg(long)]
    markdown: Option<PathBuf>,
    /// The command recorded in the report as the way to reproduce it.
    #[arg(long, default_value = "scripts/bench-hub.sh")]
    command: String,
}

/// What every throughput run needs to know.
struct Ctx<'a> {
    args: &'a Args,
    settle: Duration,
    duration: Duration,
    /// The CPU the broker under test is kept on, if any.
    broker_cpu: Option<usize>,
    /// The brokers we started, whose CPU time is not outside load.
    pids: &'a [u32],
}

impl Ctx<'_> {
    /// Waits for other processes to quieten (builds running beside us), then
    /// measures one fan-out with `probe` reading the broker's CPU.
    fn run(
        &self,
        publisher: &mut dyn throughput::Publisher,
        subs: Vec<Box<dyn Subscriber>>,
        broker: &dyn Fn() -> Option<Duration>,
        broker_in_process: bool,
    ) -> std::io::Result<Fanout> {
        if self.args.quiet_wait > 0.0 {
            sys::wait_quiet(
                self.pids,
                QUIET_BELOW,
                Duration::from_secs_f64(self.args.quiet_wait),
            );
        }
        let probe = CpuProbe {
            broker,
            broker_in_process,
            pids: self.pids,
        };
        throughput::run(
            publisher,
            subs,
            self.args.recv_threads,
            self.args.window,
            self.settle,
            self.duration,
            &probe,
        )
    }
}

/// Outside CPU use (% of the machine) under which a run may start.
const QUIET_BELOW: f64 = 10.0;

const MQTT_DEFAULT: &str = "Mosquitto, Nagle on (default)";
const MQTT_NODELAY: &str = "Mosquitto, set_tcp_nodelay true";

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum Pin {
    None,
    Split,
}

/// Seconds on the command line, 0 to a day: `Duration::from_secs_f64` panics
/// on NaN, negative and overflowing values, so they are refused as usage errors.
fn seconds_arg(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if (0.0..=86_400.0).contains(&v) => Ok(v),
        _ => Err("must be a number of seconds from 0 to 86400".into()),
    }
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let machine = report::Machine::probe();
    eprintln!(
        "hub-bench: {} cores, {}, load {}",
        machine.cores, machine.cpu, machine.load_before
    );
    // Leases outlive any run, so no refresh traffic mixes in with the measurement.
    let config = HubConfig {
        lease: Duration::from_secs(600),
        ..HubConfig::default()
    };

    let brokers = start_brokers(&args)?;
    let pids: Vec<u32> = brokers.iter().map(|(_, b)| b.pid()).collect();
    let foreign = sys::Foreign::start(&pids);
    let lat = latency_runs(&args, &machine, &config, &brokers)?;
    let foreign_latency = foreign.percent(&pids);
    // Throughput: as configured (by default the scheduler places everything).
    let (bench_cpus, broker_cpus): (Option<Vec<usize>>, Option<Vec<usize>>) =
        match args.throughput_pin {
            Pin::None => (None, None),
            Pin::Split if machine.cores >= 2 => (Some(vec![0]), Some(vec![1])),
            Pin::Split => (None, None),
        };
    sys::pin_self(bench_cpus.as_deref())?;
    for (_, b) in &brokers {
        sys::pin_process(b.pid(), broker_cpus.as_deref())?;
    }
    let broker_cpu = broker_cpus.as_ref().map(|c| c[0]);

    let foreign = sys::Foreign::start(&pids);
    let settle = Duration::from_secs_f64(args.settle);
    let duration = Duration::from_secs_f64(args.duration);
    let fanouts = if args.latency_only {
        &[][..]
    } else {
        &args.fanouts[..]
    };
    let ctx = Ctx {
        args: &args,
        settle,
        duration,
        broker_cpu,
        pids: &pids,
    };
    let rows = throughput_rows(&ctx, &config, &brokers, fanouts)?;

    let foreign_throughput = foreign.percent(&pids);
    let load_after = report::loadavg();
    let text = report::render(&report::Report {
        command: &args.command,
        machine: &machine,
        load_after: &load_after,
        foreign: [foreign_latency, foreign_throughput],
        mosquitto: brokers.first().map(|(_, b)| b.version.as_str()),
        samples: args.samples,
        warmup: args.warmup,
        duration: args.duration,
        rounds: args.rounds,
        quiet_wait: args.quiet_wait,
        window: args.window,
        recv_threads: args.recv_threads,
        rcvbuf: args.rcvbuf,
        lengths: args.lengths,
        publisher_gso: !args.plain_publisher,
        placement: match (args.throughput_pin, machine.cores >= 2) {
            (Pin::Split, true) => {
                "The broker runs on CPU 1 and the publisher and receivers on CPU 0, so each \
                 single-threaded broker has one core to itself"
            }
            _ => "The scheduler places all threads",
        },
        latency: &lat,
        fanout: &rows,
    });
    drop(brokers);
    print!("{text}");
    if let Some(path) = &args.markdown {
        report::write_section(path, report::heading(args.lengths), &text)
            .with_context(|| format!("writing {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

/// Mosquitto twice, unless told not to: as shipped (Nagle on, so its writes to a busy
/// subscriber coalesce) and tuned for latency (`set_tcp_nodelay true`). Each comparison is
/// with whichever does better on it.
fn start_brokers(args: &Args) -> anyhow::Result<Vec<(&'static str, mqtt::Mosquitto)>> {
    Ok(if args.no_mosquitto {
        Vec::new()
    } else {
        let program = find_program(&args.mosquitto).with_context(|| {
            format!(
                "mosquitto not found (`{}`): install it with `apt-get install mosquitto`, \
                 or pass --no-mosquitto",
                args.mosquitto.display()
            )
        })?;
        vec![
            (MQTT_DEFAULT, mqtt::Mosquitto::start(&program, false)?),
            (MQTT_NODELAY, mqtt::Mosquitto::start(&program, true)?),
        ]
    })
}

/// Latency, path by path, with each placement of the threads.
fn latency_runs(
    args: &Args,
    machine: &report::Machine,
    config: &HubConfig,
    brokers: &[(&str, mqtt::Mosquitto)],
) -> anyhow::Result<Vec<latency::Latency>> {
    // Where threads run changes latency more than any broker does on a VM
    // (waking an idle vCPU costs tens of µs), so every path is measured with
    // the same explicit placement: all on one core, then broker on its own core.
    let mut placements = vec![("one core", 0usize)];
    if machine.cores >= 2 {
        placements.push(("two cores", 1));
    }
    let mut lat = Vec::new();
    if args.no_latency {
        placements.clear();
    }
    for &(placement, broker_cpu) in &placements {
        sys::pin_self(Some(&[0]))?;
        for (_, b) in brokers {
            sys::pin_process(b.pid(), Some(&[broker_cpu]))?;
        }
        let cpu = Some(broker_cpu);
        eprintln!("latency ({placement}): raw UDP relay");
        let mut runs = vec![latency::raw_udp(args.warmup, args.samples, cpu)?];
        eprintln!("latency ({placement}): colony hub");
        runs.push(latency::hub_raw(args.warmup, args.samples, config, cpu)?);
        eprintln!("latency ({placement}): colony hub via colony-client");
        runs.push(latency::hub_client(args.warmup, args.samples, config, cpu)?);
        for (name, b) in brokers {
            eprintln!("latency ({placement}): {name}");
            runs.push(latency::mosquitto(name, args.warmup, args.samples, b.addr)?);
        }
        for r in &mut runs {
            r.placement = placement.to_owned();
        }
        lat.extend(runs);
    }
    Ok(lat)
}

/// Delivered throughput at each fan-out, over the rounds.
fn throughput_rows(
    ctx: &Ctx<'_>,
    config: &HubConfig,
    brokers: &[(&str, mqtt::Mosquitto)],
    fanouts: &[usize],
) -> anyhow::Result<Vec<report::Row>> {
    let args = ctx.args;
    let mut rows: Vec<report::Row> = Vec::new();
    // Rounds interleave the systems, so a disturbance from outside hits all of
    // them alike; each system keeps its best round (losses: its worst).
    for round in 1..=args.rounds {
        for (k, &n) in fanouts.iter().enumerate() {
            let row = throughput_row(ctx, config, brokers, round, n)?;
            if round == 1 {
                rows.push(row);
            } else {
                rows[k].merge(row);
            }
        }
    }
    Ok(rows)
}

/// One round at fan-out `n`: each system in turn.
fn throughput_row(
    ctx: &Ctx<'_>,
    config: &HubConfig,
    brokers: &[(&str, mqtt::Mosquitto)],
    round: usize,
    n: usize,
) -> anyhow::Result<report::Row> {
    let args = ctx.args;
    let tag = format!("round {round}/{}, fan-out {n}", args.rounds);
    let mut runs = Vec::new();
    if !args.no_relay {
        eprintln!("throughput ({tag}): raw UDP relay");
        let f = relay_fanout(ctx, n, false)?;
        runs.push(report::Run::new(names::RELAY, report::Kind::Relay, f));
    }
    if args.relay_gso {
        eprintln!("throughput ({tag}): raw UDP relay with GSO");
        let f = relay_fanout(ctx, n, true)?;
        runs.push(report::Run::new(
            names::RELAY_GSO,
            report::Kind::Experiment,
            f,
        ));
    }
    eprintln!("throughput ({tag}): colony hub");
    let (hub, mut hub_drops) = hub_fanout(ctx, config, n, 0)?;
    runs.push(report::Run::new(names::HUB, report::Kind::Hub, hub));
    if !args.no_batching {
        eprintln!("throughput ({tag}): colony hub, batching subscribers");
        let bytes = usize::from(args.batch_bytes);
        let (joined, drops) = hub_fanout(ctx, config, n, bytes)?;
        hub_drops.add(&drops);
        runs.push(report::Run::new(
            &names::hub_batching(bytes),
            report::Kind::HubBatching,
            joined,
        ));
    }
    for (name, b) in brokers {
        eprintln!("throughput ({tag}): {name}");
        let f = mqtt_fanout(ctx, b, n)?;
        runs.push(report::Run::new(name, report::Kind::Mqtt, f));
    }
    Ok(report::Row {
        subscribers: n,
        runs,
        hub_drops,
    })
}

/// `program` if it names a file, else the first match on `PATH`, else /usr/sbin.
fn find_program(program: &std::path::Path) -> Option<PathBuf> {
    if program.components().count() > 1 {
        return program.is_file().then(|| program.to_owned());
    }
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path)
        .chain([PathBuf::from("/usr/sbin"), PathBuf::from("/usr/local/sbin")])
        .map(|d| d.join(program))
        .find(|p| p.is_file())
}

/// The hub at fan-out `n`; its subscribers ask for several packets a
/// datagram, of up to `batch` bytes, unless it is 0.
fn hub_fanout(
    ctx: &Ctx<'_>,
    config: &HubConfig,
    n: usize,
    batch: usize,
) -> anyhow::Result<(Fanout, hub::HubDrops)> {
    let hub = HubThread::start(config.clone(), ctx.broker_cpu)?;
    let mut subs: Vec<Box<dyn Subscriber>> = Vec::with_capacity(n);
    for _ in 0..n {
        let sock = UdpSocket::bind("127.0.0.1:0")?;
        sys::set_rcvbuf(&sock, ctx.args.rcvbuf)?;
        sock.connect(hub.addr)?;
        let extra: &[Request] = if batch > 0 {
            &[Request::Batch(batch)]
        } else {
            &[]
        };
        subscribe_udp_with(&sock, payload::CHANNEL, extra)?;
        subs.push(Box::new(UdpSub::new(sock, batch)?));
    }
    let mut publisher = UdpPub::new(hub.addr, ctx.args.lengths, !ctx.args.plain_publisher)?;
    let run = ctx.run(&mut publisher, subs, &|| hub.cpu(), true)?;
    let drops = hub.stop()?;
    Ok((run, drops))
}

fn mqtt_fanout(ctx: &Ctx<'_>, broker: &mqtt::Mosquitto, n: usize) -> anyhow::Result<Fanout> {
    let mut subs: Vec<Box<dyn Subscriber>> = Vec::with_capacity(n);
    for i in 0..n {
        let mut conn = mqtt::Conn::connect(broker.addr, &format!("bench-sub-{n}-{i}"))?;
        conn.subscribe(payload::CHANNEL)?;
        subs.push(Box::new(MqttSub::new(conn)?));
    }
    let mut publisher = MqttPub::new(
        mqtt::Conn::connect(broker.addr, &format!("bench-pub-{n}"))?,
        ctx.args.lengths,
    );
    let pid = broker.pid();
    Ok(ctx.run(&mut publisher, subs, &|| sys::process_cpu(pid), false)?)
}

fn relay_fanout(ctx: &Ctx<'_>, n: usize, gso: bool) -> anyhow::Result<Fanout> {
    let socks = (0..n)
        .map(|_| {
            let sock = UdpSocket::bind("127.0.0.1:0")?;
            sys::set_rcvbuf(&sock, ctx.args.rcvbuf)?;
            Ok(sock)
        })
        .collect::<std::io::Result<Vec<_>>>()?;
    let dests = socks
        .iter()
        .map(|s| s.local_addr())
        .collect::<std::io::Result<Vec<_>>>()?;
    let relay = relay::RelayThread::start(dests, ctx.broker_cpu, gso)?;
    let mut subs: Vec<Box<dyn Subscriber>> = Vec::with_capacity(n);
    for sock in socks {
        sock.connect(relay.addr)?;
        subs.push(Box::new(UdpSub::new(sock, 0)?));
    }
    let mut publisher = UdpPub::new(relay.addr, ctx.args.lengths, !ctx.args.plain_publisher)?;
    let run = ctx.run(&mut publisher, subs, &|| relay.cpu(), true)?;
    relay.stop()?;
    Ok(run)
}
