//! The markdown report, the machine it ran on, and its place in BENCHMARKS.md.

use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

use crate::hub::HubDrops;
use crate::latency::Latency;
use crate::names::{HUB, RAW, RELAY_GSO};
use crate::payload::Lengths;
use crate::throughput::Fanout;

pub const HEADING: &str = "## Hub on loopback";
/// The heading of the section a mixed-length run writes.
pub const HEADING_MIXED: &str = "## Hub on loopback, mixed lengths";
/// Targets from the issue.
const ADDED_P99_TARGET_US: f64 = 5.0;
/// Over the better Mosquitto, with fixed-length packets...
const THROUGHPUT_RATIO_TARGET: f64 = 3.0;
/// ...and with a realistic mix of lengths.
const THROUGHPUT_RATIO_TARGET_MIXED: f64 = 2.0;

/// The section heading for a run with these packet lengths.
pub fn heading(lengths: Lengths) -> &'static str {
    match lengths {
        Lengths::Fixed => HEADING,
        Lengths::Mixed => HEADING_MIXED,
    }
}

pub struct Machine {
    pub cores: usize,
    pub cpu: String,
    pub kernel: String,
    pub date: String,
    pub load_before: String,
}

impl Machine {
    pub fn probe() -> Machine {
        let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
        let cpu = command_line("lscpu", &[])
            .and_then(|out| {
                out.lines()
                    .find(|l| l.starts_with("Model name:"))
                    .map(|l| l["Model name:".len()..].trim().to_owned())
            })
            .or_else(|| {
                std::fs::read_to_string("/proc/cpuinfo").ok().and_then(|t| {
                    t.lines()
                        .find(|l| l.starts_with("model name"))
                        .and_then(|l| l.split(':').nth(1))
                        .map(|s| s.trim().to_owned())
                })
            })
            .unwrap_or_else(|| "unknown CPU".into());
        let kernel = std::fs::read_to_string("/proc/sys/kernel/osrelease")
            .map(|s| format!("Linux {}", s.trim()))
            .unwrap_or_else(|_| std::env::consts::OS.to_owned());
        let date = command_line("date", &["-u", "+%Y-%m-%d %H:%M UTC"])
            .map(|s| s.trim().to_owned())
            .unwrap_or_else(|| "unknown date".into());
        Machine {
            cores,
            cpu,
            kernel,
            date,
            load_before: loadavg(),
        }
    }
}

fn command_line(program: &str, args: &[&str]) -> Option<String> {
    let out = Command::new(program).args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).into_owned())
}

/// The 1, 5 and 15 minute load averages.
pub fn loadavg() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

/// What a throughput run measured.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Relay,
    /// A variant shown for information only (the GSO relay).
    Experiment,
    Hub,
    /// The hub, its subscribers asking for several packets a datagram.
    HubBatching,
    Mqtt,
}

/// One system's throughput run at one fan-out.
pub struct Run {
    pub name: String,
    pub kind: Kind,
    pub f: Fanout,
}

impl Run {
    pub fn new(name: &str, kind: Kind, f: Fanout) -> Run {
        Run {
            name: name.to_owned(),
            kind,
            f,
        }
    }

    /// Broker CPU time per delivered packet, in seconds.
    fn cost(&self) -> Option<f64> {
        let p = self.f.broker_cpu_pct?;
        (self.f.rate > 0.0).then(|| p / 100.0 / self.f.rate)
    }
}

/// The throughput runs at one fan-out.
pub struct Row {
    pub subscribers: usize,
    pub runs: Vec<Run>,
    pub hub_drops: HubDrops,
}

impl Row {
    /// Takes in another round: the faster run of each system stays, losses
    /// and write-offs add up, and the worst loss is kept.
    pub fn merge(&mut self, other: Row) {
        for new in other.runs {
            let Some(best) = self.runs.iter_mut().find(|r| r.name == new.name) else {
                self.runs.push(new);
                continue;
            };
            let worst = best.f.worst_loss_pct.max(new.f.worst_loss_pct);
            let stalls = best.f.stalls + new.f.stalls;
            let drops = best
                .f
                .rcvbuf_drops
                .zip(new.f.rcvbuf_drops)
                .map(|(a, b)| a + b);
            if new.f.rate > best.f.rate {
                best.f = new.f;
            }
            best.f.worst_loss_pct = worst;
            best.f.stalls = stalls;
            best.f.rcvbuf_drops = drops;
        }
        self.hub_drops.add(&other.hub_drops);
    }

    fn hub(&self) -> Option<&Run> {
        self.runs.iter().find(|r| r.kind == Kind::Hub)
    }

    fn hub_batching(&self) -> Option<&Run> {
        self.runs.iter().find(|r| r.kind == Kind::HubBatching)
    }

    fn relay(&self) -> Option<&Run> {
        self.runs.iter().find(|r| r.kind == Kind::Relay)
    }

    /// The Mosquitto run that delivered the most.
    fn best_mqtt(&self) -> Option<&Run> {
        self.runs
            .iter()
            .filter(|r| r.kind == Kind::Mqtt)
            .max_by(|a, b| a.f.rate.total_cmp(&b.f.rate))
    }

    /// The lowest Mosquitto CPU time per delivery.
    fn best_mqtt_cost(&self) -> Option<f64> {
        self.runs
            .iter()
            .filter(|r| r.kind == Kind::Mqtt)
            .filter_map(Run::cost)
            .min_by(f64::total_cmp)
    }
}

pub struct Report<'a> {
    pub command: &'a str,
    pub machine: &'a Machine,
    pub load_after: &'a str,
    /// Other processes' CPU use during the latency and the throughput runs,
    /// in % of the whole machine.
    pub foreign: [Option<f64>; 2],
    pub mosquitto: Option<&'a str>,
    pub samples: usize,
    pub warmup: usize,
    pub duration: f64,
    pub rounds: usize,
    pub quiet_wait: f64,
    pub window: u64,
    pub recv_threads: usize,
    pub rcvbuf: usize,
    /// How the throughput runs placed their threads, as a sentence.
    pub placement: &'a str,
    pub lengths: Lengths,
    /// Whether the UDP publisher sends runs of equal-length packets with GSO.
    pub publisher_gso: bool,
    pub latency: &'a [Latency],
    pub fanout: &'a [Row],
}

fn us(x: f64) -> String {
    if x.is_nan() {
        "–".into()
    } else {
        format!("{x:.1}")
    }
}

/// 1234567.0 -> "1,234,567"
fn thousands(x: f64) -> String {
    let digits = format!("{:.0}", x.max(0.0));
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}

fn loss(f: &Fanout) -> String {
    let pct = |p: f64| {
        if p == 0.0 {
            "0 %".to_owned()
        } else {
            format!("{p:.3} %")
        }
    };
    if f.worst_loss_pct > f.loss_pct {
        format!(
            "{} (worst round {})",
            pct(f.loss_pct),
            pct(f.worst_loss_pct)
        )
    } else {
        pct(f.loss_pct)
    }
}

fn share(p: Option<f64>) -> String {
    p.map_or("an unknown share".into(), |p| format!("{p:.1} %"))
}

fn cpu(p: Option<f64>) -> String {
    p.map_or("–".into(), |p| format!("{p:.0} %"))
}

/// Broker CPU time per delivered packet, in µs.
fn per_delivery(run: &Run) -> String {
    run.cost()
        .map_or("–".into(), |c| format!("{:.2} µs", c * 1e6))
}

fn verdict(met: bool) -> &'static str {
    if met {
        "**met**"
    } else {
        "**not met**"
    }
}

pub fn render(r: &Report<'_>) -> String {
    let mut s = String::new();
    let w = &mut s;
    preamble(w, r);
    if !r.latency.is_empty() {
        latency_table(w, r);
    }
    throughput_table(w, r);
    let _ = writeln!(w, "### Targets\n");
    latency_target(w, r);
    throughput_targets(w, r);
    let _ = writeln!(w);
    limits(w, r);
    s
}

/// How the run was made and on what machine.
fn preamble(w: &mut String, r: &Report<'_>) {
    let m = r.machine;
    let _ = writeln!(w, "{}\n", heading(r.lengths));
    let _ = writeln!(
        w,
        "Measured with `{}`, which builds `cargo build --release -p colony-bench`, starts and \
         stops its own Mosquitto, runs `target/release/hub-bench` and rewrites this section, \
         except subsections written by hand (such as `### Analysis`), which it keeps at its \
         end (the rest of the file is kept too).\n",
        r.command
    );
    let _ = writeln!(
        w,
        "- Machine: {} cores (`nproc`), {} (`lscpu`), {}",
        m.cores, m.cpu, m.kernel
    );
    let _ = writeln!(w, "- Date: {}", m.date);
    let _ = writeln!(
        w,
        "- Load average (1, 5, 15 min): {} before the run, {} after; other processes used \
         {} of the machine's CPU during the latency runs and {} during the throughput runs \
         (from /proc/stat, less this process and its brokers)",
        m.load_before,
        r.load_after,
        share(r.foreign[0]),
        share(r.foreign[1])
    );
    let _ = writeln!(
        w,
        "- Peer: {}, started by the benchmark twice, each on a loopback listener with \
         `persistence false`: as shipped (Nagle on: its writes to a busy subscriber coalesce) \
         and with `set_tcp_nodelay true` (tuned for latency); the hub is compared with the \
         better of the two on each figure. Clients are a minimal MQTT 3.1.1 implementation \
         over `TcpStream` with `TCP_NODELAY`, QoS 0",
        r.mosquitto.unwrap_or("Mosquitto not run")
    );
    let _ = writeln!(
        w,
        "- colony hub: `colony_hub::Server::run` on its own thread of the benchmark process \
         (the code the `colony hub` binary runs), release build\n"
    );
}

/// The delivered throughput table, what its rows are, and what was lost.
fn throughput_table(w: &mut String, r: &Report<'_>) {
    let _ = writeln!(w, "### Delivered throughput, {}\n", r.lengths.describe());
    let _ = writeln!(
        w,
        "One publisher, N subscribers (UDP sockets with a {} MiB receive buffer for the hub, \
         TCP connections for Mosquitto) spread over {} receiver threads that wait with epoll \
         and read in batches (`recvmmsg` / 256 KiB `read`). The publisher sends in batches, \
         {}, to Mosquitto as pipelined PUBLISH frames in one `write`, and keeps at most {} packets \
         in flight beyond the slowest subscriber, so it runs as fast as the subscribers keep \
         up. {}. {:.0} s measured per run after 0.3 s unmeasured; {} rounds, the systems \
         taking turns, and each system's best round is shown (loss: that round's, and the \
         worst round's if higher). Delivered/s sums over subscribers; loss is packets sent × \
         N − packets received, counted after the run. \
         CPU is in % of one core: the broker's (the hub's thread, or the mosquitto process) \
         and the measuring side's (publisher + receivers); CPU per delivery is the broker's \
         CPU time over packets delivered. Each run waits (up to {:.0} s) for other processes to \
         use under 10 % of the machine before it starts; *outside load* is what they used \
         during the run, in % of both cores, since on a shared machine that takes cycles \
         from the pinned threads.\n",
        r.rcvbuf >> 20,
        r.recv_threads,
        if r.publisher_gso {
            "to the UDP brokers with `sendmmsg`, each run of equal-length packets and a shorter \
             one after it as one UDP GSO send that the kernel splits before the broker's socket \
             takes it (the broker receives one datagram per packet)"
        } else {
            "to the UDP brokers with `sendmmsg`"
        },
        r.window,
        r.placement,
        r.duration,
        r.rounds,
        r.quiet_wait
    );
    let _ = writeln!(
        w,
        "| fan-out | broker | delivered/s | loss | broker CPU | broker CPU per delivery | measuring side CPU | outside load | ÷ best Mosquitto |"
    );
    let _ = writeln!(w, "|---:|---|---:|---:|---:|---:|---:|---:|---:|");
    for row in r.fanout {
        let best = row.best_mqtt();
        for run in &row.runs {
            let f = &run.f;
            let ratio = match best {
                Some(b) if run.kind != Kind::Mqtt => format!("{:.2}×", f.rate / b.f.rate),
                Some(b) if std::ptr::eq(b, run) => "(best)".into(),
                _ => "–".into(),
            };
            let (name, ratio) = if matches!(run.kind, Kind::Hub | Kind::HubBatching) {
                (format!("**{}**", run.name), format!("**{ratio}**"))
            } else {
                (run.name.clone(), ratio)
            };
            let _ = writeln!(
                w,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                row.subscribers,
                name,
                thousands(f.rate),
                loss(f),
                cpu(f.broker_cpu_pct),
                per_delivery(run),
                cpu(f.bench_cpu_pct),
                f.foreign_pct.map_or("–".into(), |p| format!("{p:.0} %")),
                ratio
            );
        }
    }
    let _ = writeln!(
        w,
        "\nRows: *raw UDP relay (floor)* repeats each datagram to a fixed subscriber list with \
         one `recvmmsg` per batch and one `sendmmsg` for batch × subscribers, no parsing and \
         no routing: the floor for one datagram per delivery."
    );
    if r.fanout.iter().any(|x| x.hub_batching().is_some()) {
        let _ = writeln!(
            w,
            "*colony hub, batching subscribers* is the same hub, its subscribers asking for \
             several packets in one datagram of at most that many bytes (`batch bytes N`): the \
             hub joins packets it already has in hand for a subscriber, behind a head that gives \
             their lengths, and holds none back to fill a datagram, as Mosquitto's TCP \
             connections carry several messages in one segment when a subscriber is busy."
        );
    }
    if r.fanout
        .iter()
        .any(|x| x.runs.iter().any(|run| run.kind == Kind::Experiment))
    {
        let _ = writeln!(
            w,
            "*{RELAY_GSO}* is not a peer but a what-if: the same relay sending each run of \
             equal-length datagrams to a subscriber (and a shorter one after it) as one UDP GSO \
             send (`UDP_SEGMENT`), which the kernel splits only when it delivers them (the hub \
             sends runs the same way). Long runs gain most: fixed-length packets fully; lengths \
             that differ from packet to packet only pair up, which gains little."
        );
    }
    let send_failed: u64 = r.fanout.iter().map(|x| x.hub_drops.send_failed).sum();
    let send_full: u64 = r.fanout.iter().map(|x| x.hub_drops.send_full).sum();
    let overflow: u64 = r.fanout.iter().map(|x| x.hub_drops.receive_overflow).sum();
    let hub_drops: u64 = r.fanout.iter().map(|x| x.hub_drops.total).sum();
    let stalls: u64 = r
        .fanout
        .iter()
        .flat_map(|x| &x.runs)
        .map(|run| run.f.stalls)
        .sum();
    let kernel: u64 = r
        .fanout
        .iter()
        .filter_map(|x| x.hub()?.f.rcvbuf_drops)
        .sum();
    let _ = writeln!(
        w,
        "\nDuring the hub's runs the kernel dropped {kernel} UDP datagrams at a full socket \
         receive buffer (`RcvbufErrors`, machine-wide); the hub itself counted {hub_drops} drops \
         ({overflow} at its own receive buffer, {send_full} sends refused by a full buffer, \
         {send_failed} other failed sends); the publisher wrote off a window of lost packets \
         {stalls} times (all rounds).\n"
    );
}

/// The added latency at p99, judged against its target.
fn latency_target(w: &mut String, r: &Report<'_>) {
    let mut placements: Vec<&str> = Vec::new();
    for l in r.latency {
        if !placements.contains(&l.placement.as_str()) {
            placements.push(&l.placement);
        }
    }
    let mut parts = Vec::new();
    let mut all_met = true;
    for p in &placements {
        let p99 = |name: &str| {
            r.latency
                .iter()
                .find(|l| l.placement == *p && l.name == name)
                .map_or(f64::NAN, |l| l.quantile_us(0.99))
        };
        let (hub, raw) = (p99(HUB), p99(RAW));
        let added = hub - raw;
        all_met &= added < ADDED_P99_TARGET_US;
        parts.push(format!(
            "{p}: {} µs − {} µs = {added:.1} µs",
            us(hub),
            us(raw)
        ));
    }
    if !placements.is_empty() {
        let _ = writeln!(
            w,
            "- Added latency over raw UDP under {ADDED_P99_TARGET_US:.0} µs at p99: {}; {}.",
            parts.join("; "),
            verdict(all_met)
        );
    }
}

/// Delivered throughput and work per packet, judged against Mosquitto's.
fn throughput_targets(w: &mut String, r: &Report<'_>) {
    let target = match r.lengths {
        Lengths::Fixed => THROUGHPUT_RATIO_TARGET,
        Lengths::Mixed => THROUGHPUT_RATIO_TARGET_MIXED,
    };
    type Pick<'r> = &'r dyn Fn(&Row) -> Option<&Run>;
    let modes: [(&str, Pick<'_>); 2] = [
        ("colony hub", &|x: &Row| x.hub()),
        ("the hub with batching subscribers", &|x: &Row| {
            x.hub_batching()
        }),
    ];
    let measured = r.fanout.iter().any(|x| x.best_mqtt().is_some());
    if !measured {
        let _ = writeln!(
            w,
            "- Delivered throughput at least {target:.0}× Mosquitto's: not \
             measured (Mosquitto was not run)."
        );
    } else {
        for (mode, pick) in modes {
            let ratios: Vec<(usize, f64)> = r
                .fanout
                .iter()
                .filter_map(|x| Some((x.subscribers, pick(x)?.f.rate / x.best_mqtt()?.f.rate)))
                .collect();
            if ratios.is_empty() {
                continue;
            }
            let all = ratios.iter().all(|&(_, x)| x >= target);
            let list = ratios
                .iter()
                .map(|(n, x)| format!("{x:.2}× at fan-out {n}"))
                .collect::<Vec<_>>()
                .join(", ");
            let lossy = r
                .fanout
                .iter()
                .any(|x| pick(x).is_some_and(|h| h.f.loss_pct > 0.1));
            let _ = writeln!(
                w,
                "- Delivered throughput at least {target:.0}× Mosquitto's (the \
                 better of its two configurations) at every fan-out, {mode}: {list}; {}{}.",
                verdict(all),
                if lossy {
                    " (but it lost more than 0.1 % somewhere: see the table)"
                } else {
                    ""
                }
            );
        }
        // Work per packet, which outside load disturbs far less than rates.
        let work = |pick: Pick<'_>| -> Option<String> {
            let v = r
                .fanout
                .iter()
                .map(|x| Some(format!("{:.2}×", x.best_mqtt_cost()? / pick(x)?.cost()?)))
                .collect::<Option<Vec<_>>>()?;
            Some(v.join(", "))
        };
        let fanouts = r
            .fanout
            .iter()
            .map(|x| x.subscribers.to_string())
            .collect::<Vec<_>>()
            .join(", ");
        if let Some(hub) = work(&|x: &Row| x.hub()) {
            let _ = write!(
                w,
                "- Work per packet, which outside load disturbs less than rates: Mosquitto's \
                 cheaper configuration uses {hub} the broker CPU time per delivery that the \
                 hub does (fan-out {fanouts})"
            );
            if let Some(batching) = work(&|x: &Row| x.hub_batching()) {
                let _ = write!(w, ", {batching} that of the hub with batching subscribers");
            }
            match work(&|x: &Row| x.relay()) {
                Some(relay) => {
                    let _ = writeln!(
                        w,
                        ", and {relay} that of the raw UDP relay, the floor for one datagram per \
                         delivery."
                    );
                }
                None => {
                    let _ = writeln!(w, ".");
                }
            }
        }
    }
}

fn latency_table(w: &mut String, r: &Report<'_>) {
    let _ = writeln!(w, "### Latency, 100-byte packet, one in flight\n");
    let _ = writeln!(
        w,
        "Each sample is one-way publish -> broker -> subscriber: the publisher and the \
         subscriber are sockets of the same thread, so both timestamps come from one clock. \
         {} samples after {} warm-up, one packet in flight, blocking reads on the subscriber. \
         The packet is a valid colony packet of exactly 100 bytes (`@ <bench> 0` / \
         `ping seq N pad \"xx…\"`); MQTT carries the same 100 bytes as payload on topic `bench`.\n",
        thousands(r.samples as f64),
        thousands(r.warmup as f64)
    );
    let _ = writeln!(
        w,
        "| placement | path | p50 µs | p99 µs | p99.9 µs | p99 added over raw UDP, µs | lost |"
    );
    let _ = writeln!(w, "|---|---|---:|---:|---:|---:|---:|");
    let raw_of = |placement: &str| {
        r.latency
            .iter()
            .find(|l| l.placement == placement && l.name == RAW)
    };
    for l in r.latency {
        let added = match raw_of(&l.placement) {
            Some(raw) if !std::ptr::eq(raw, l) => {
                format!("{:+.1}", l.quantile_us(0.99) - raw.quantile_us(0.99))
            }
            _ => "–".into(),
        };
        let _ = writeln!(
            w,
            "| {} | {} | {} | {} | {} | {} | {} |",
            l.placement,
            l.name,
            us(l.quantile_us(0.50)),
            us(l.quantile_us(0.99)),
            us(l.quantile_us(0.999)),
            added,
            l.lost
        );
    }
    let _ = writeln!(w);
    let _ = writeln!(
        w,
        "Rows: *raw UDP relay* is the floor, a thread doing blocking `recv_from` + `send_to` to \
         one fixed subscriber (the one extra hop any broker adds, with no routing); *colony hub* \
         uses plain sockets on the client side, as the relay row does; *via colony-client* uses \
         `UdpClient::publish` (which checks the packet) and `UdpClient::recv` (which parses it), \
         the path an application takes.\n"
    );
}

/// What bounds the figures, from the figures themselves.
fn limits(w: &mut String, r: &Report<'_>) {
    let _ = writeln!(w, "### What limits these figures\n");
    let _ = writeln!(
        w,
        "- {} cores carry everything at once: the broker, the publisher, the subscribers and \
         whatever else the machine runs (see the load average above; other builds running at \
         the same time disturb the figures).",
        r.machine.cores
    );
    let p50 = |placement: &str| {
        r.latency
            .iter()
            .find(|l| l.placement == placement && l.name == RAW)
            .map(|l| l.quantile_us(0.5))
    };
    if let (Some(one), Some(two)) = (p50("one core"), p50("two cores")) {
        let _ = writeln!(
            w,
            "- Latency: waking a thread on the other core costs this machine about {:.0} µs \
             (the raw relay's p50 is {one:.1} µs with everything on one core, {two:.1} µs with \
             the relay on the other core), a cost every broker pays in the same placement, so \
             each path is compared with the raw relay in that placement. Unpinned, the scheduler \
             picks either placement from run to run, which is why the benchmark pins.",
            two - one
        );
    }
    let range = |f: &dyn Fn(&Fanout) -> Option<f64>| {
        let v: Vec<f64> = r
            .fanout
            .iter()
            .flat_map(|x| &x.runs)
            .filter(|run| matches!(run.kind, Kind::Hub | Kind::HubBatching | Kind::Mqtt))
            .filter_map(|run| f(&run.f))
            .collect();
        let lo = v.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        (!v.is_empty()).then_some((lo, hi))
    };
    if let (Some((blo, bhi)), Some((mlo, mhi))) = (
        range(&|f: &Fanout| f.broker_cpu_pct),
        range(&|f: &Fanout| f.bench_cpu_pct),
    ) {
        let _ = writeln!(
            w,
            "- Throughput: the brokers used {blo:.0}–{bhi:.0} % of a core and the measuring \
             side {mlo:.0}–{mhi:.0} %. A broker near 100 % is the bottleneck and its figure is \
             its capacity on one core; a measuring side near 100 % too means the two are \
             balanced, and the broker figure is a lower bound. The broker CPU per delivery \
             column is the fairer comparison of work per packet; it includes the kernel's \
             loopback delivery into the subscribers' sockets, which runs in the sender's \
             context for both UDP and TCP."
        );
    }
    let _ = writeln!(w);
}

/// Replaces the section under `heading` of a markdown file (up to the next
/// `## ` heading) with `section`, or appends it; creates the file if need
/// be. Subsections written by hand (any `### ` heading `section` lacks, such
/// as `### Analysis`) are kept after it.
pub fn write_section(path: &Path, heading: &str, section: &str) -> std::io::Result<()> {
    let old = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => "# Benchmarks\n".into(),
        Err(e) => return Err(e),
    };
    std::fs::write(path, splice(&old, heading, section))
}

fn splice(old: &str, heading: &str, section: &str) -> String {
    let lines: Vec<&str> = old.split_inclusive('\n').collect();
    let start = lines.iter().position(|l| l.trim_end() == heading);
    let Some(start) = start else {
        let mut out = old.trim_end().to_owned();
        out.push_str("\n\n");
        out.push_str(section);
        return out;
    };
    let end = lines[start + 1..]
        .iter()
        .position(|l| l.starts_with("## "))
        .map_or(lines.len(), |i| start + 1 + i);
    // Hand-written subsections (`### Analysis`, and any other whose heading
    // the new section does not have) are kept, in their order.
    let mut kept = String::new();
    let mut keeping = false;
    for l in &lines[start + 1..end] {
        if l.starts_with("### ") {
            keeping = !section.lines().any(|s| s == l.trim_end());
        }
        if keeping {
            kept.push_str(l);
        }
    }
    let mut out: String = lines[..start].concat();
    out.push_str(section);
    if !kept.is_empty() {
        if !out.ends_with("\n\n") {
            out.push('\n');
        }
        out.push_str(kept.trim_end());
        out.push('\n');
    }
    if end < lines.len() {
        if !out.ends_with("\n\n") {
            out.push('\n');
        }
        out.push_str(&lines[end..].concat());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splice_replaces_only_its_section() {
        let old = "# Benchmarks\n\n## Wire parsing\n\nfast\n\n## Hub on loopback\n\nold\n\n## Later\n\nkeep\n";
        let new = splice(old, HEADING, "## Hub on loopback\n\nnew\n\n");
        assert_eq!(
            new,
            "# Benchmarks\n\n## Wire parsing\n\nfast\n\n## Hub on loopback\n\nnew\n\n## Later\n\nkeep\n"
        );
        let kept = splice(
            "## Hub on loopback\n\nold\n\n### Targets\n\nold\n\n### Restarts\n\nby hand\n\n\
             ### Analysis\n\nwhy\n\n## Next\n",
            HEADING,
            "## Hub on loopback\n\nnew\n\n### Targets\n\nnew\n\n",
        );
        assert_eq!(
            kept,
            "## Hub on loopback\n\nnew\n\n### Targets\n\nnew\n\n### Restarts\n\nby hand\n\n\
             ### Analysis\n\nwhy\n\n## Next\n"
        );
        let appended = splice(
            "# Benchmarks\n\n## Wire parsing\n\nfast\n",
            HEADING,
            "## Hub on loopback\n\nx\n",
        );
        assert_eq!(
            appended,
            "# Benchmarks\n\n## Wire parsing\n\nfast\n\n## Hub on loopback\n\nx\n"
        );
        // A mixed-length run has a section of its own beside the fixed one.
        let mixed = splice(
            &appended,
            HEADING_MIXED,
            "## Hub on loopback, mixed lengths\n\ny\n",
        );
        assert_eq!(
            mixed,
            "# Benchmarks\n\n## Wire parsing\n\nfast\n\n## Hub on loopback\n\nx\n\n\
             ## Hub on loopback, mixed lengths\n\ny\n"
        );
    }

    #[test]
    fn thousands_groups_digits() {
        assert_eq!(thousands(0.0), "0");
        assert_eq!(thousands(999.4), "999");
        assert_eq!(thousands(1_234_567.0), "1,234,567");
    }
}
