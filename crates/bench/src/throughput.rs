//! Delivered throughput at a fan-out: one publisher, N subscribers spread over
//! a few receiver threads, and a window so the publisher sends only as fast as
//! the slowest subscriber keeps up.
//!
//! Every packet carries a sequence number. Each subscriber remembers how many
//! packets it got and the highest sequence it saw; the publisher keeps at most
//! `window` packets beyond the slowest subscriber's highest sequence in flight.
//! A lost packet therefore does not stall the window (later ones move the
//! highest sequence on); only when the last packets in flight are all lost
//! does the publisher wait, and after [`STALL`] it writes them off and goes on.
//! Loss is counted exactly: packets sent x subscribers - packets received.

use std::io::{self, Write};
use std::net::{SocketAddr, TcpStream, UdpSocket};
use std::os::fd::{AsFd, BorrowedFd};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::{self, Thread};
use std::time::{Duration, Instant};

use colony_sys::udp::{SendPlan, Sender};
use colony_wire::batch;

use crate::mqtt;
use crate::payload::{self, Lengths, Packet};
use crate::sys::{self, RecvBatch, BATCH};

/// How long the publisher waits on a full window with no progress before it
/// writes the packets in flight off as lost.
const STALL: Duration = Duration::from_millis(50);
/// How long to wait after the last send for packets still on their way.
const DRAIN: Duration = Duration::from_millis(300);

/// One subscriber as a receiver thread sees it.
pub trait Subscriber: Send {
    fn fd(&self) -> BorrowedFd<'_>;
    /// Takes in what is waiting, without blocking.
    fn drain(&mut self) -> io::Result<()>;
    /// Packets received so far.
    fn count(&self) -> u64;
    /// One past the highest sequence number received.
    fn next(&self) -> u64;
}

/// The sending side.
pub trait Publisher {
    /// Publishes packets `first..first + n`; returns how many it is done
    /// with (sent, or refused by its own socket and given up).
    fn send(&mut self, first: u64, n: usize) -> io::Result<usize>;
    /// Packets so far that [`send`](Self::send) counted as done but its own
    /// socket refused: they never reached the broker, so they are not the
    /// broker's loss.
    fn refused(&self) -> u64 {
        0
    }
}

/// A UDP socket subscribed to the hub. A datagram of several packets (for
/// a subscriber that asked the hub for them) counts each packet.
pub struct UdpSub {
    sock: UdpSocket,
    batch: RecvBatch,
    count: u64,
    next: u64,
}

impl UdpSub {
    /// A subscriber taking datagrams of up to `largest` bytes.
    pub fn new(sock: UdpSocket, largest: usize) -> io::Result<UdpSub> {
        sock.set_nonblocking(true)?;
        Ok(UdpSub {
            sock,
            batch: RecvBatch::new(largest.max(sys::SLOT - 1) + 1),
            count: 0,
            next: 0,
        })
    }
}

impl Subscriber for UdpSub {
    fn fd(&self) -> BorrowedFd<'_> {
        self.sock.as_fd()
    }

    fn drain(&mut self) -> io::Result<()> {
        // A few batches at most, so other sockets of the thread get their turn.
        for _ in 0..4 {
            let n = self.batch.recv(&self.sock)?;
            for i in 0..n {
                let d = self.batch.get(i);
                let Ok(pieces) = batch::split(d) else {
                    continue;
                };
                for r in pieces {
                    if let Some(seq) = payload::seq_of(&d[r]) {
                        self.count += 1;
                        self.next = self.next.max(seq + 1);
                    }
                }
            }
            if n < BATCH {
                break;
            }
        }
        Ok(())
    }

    fn count(&self) -> u64 {
        self.count
    }

    fn next(&self) -> u64 {
        self.next
    }
}

/// Publishes to the hub (or a relay) with `sendmmsg`, up to 64 datagrams a call; with
/// `gso`, each run of equal-length datagrams (and a shorter one after it)
/// goes as one UDP GSO send, the datagram counterpart of the MQTT publisher's
/// many frames per `write`. The kernel splits a GSO send before the hub's
/// socket takes it (the hub does not ask for `UDP_GRO`), so the hub still
/// receives one datagram per packet: only the measuring side's work shrinks.
pub struct UdpPub {
    sock: UdpSocket,
    hub: [SocketAddr; 1],
    packets: Vec<Packet>,
    gso: Option<(SendPlan, Sender)>,
    refused: u64,
}

impl UdpPub {
    pub fn new(hub: SocketAddr, lengths: Lengths, gso: bool) -> io::Result<UdpPub> {
        let sock = UdpSocket::bind("127.0.0.1:0")?;
        sock.connect(hub)?;
        Ok(UdpPub {
            sock,
            hub: [hub],
            packets: vec![Packet::with(lengths); BATCH],
            gso: gso.then(|| (SendPlan::new(), Sender::new(true))),
            refused: 0,
        })
    }
}

impl Publisher for UdpPub {
    fn send(&mut self, first: u64, n: usize) -> io::Result<usize> {
        let n = n.min(BATCH);
        for (i, p) in self.packets[..n].iter_mut().enumerate() {
            p.stamp(first + i as u64);
        }
        let Some((plan, sender)) = &mut self.gso else {
            let msgs: Vec<&[u8]> = self.packets[..n].iter().map(|p| p.bytes()).collect();
            return sys::send_batch(&self.sock, &msgs);
        };
        plan.clear();
        for i in 0..n {
            plan.push(i, &self.hub);
        }
        let packets = &self.packets;
        let report = sender.send(&self.sock, plan, |i| packets[i].bytes());
        if report.sent == 0 && report.failed > 0 {
            // As the plain publisher's send fails on anything but a full buffer.
            return Err(io::Error::other("the kernel refused a batch to the broker"));
        }
        if report.sent == 0 {
            // Nothing went: a full socket buffer waits for the window's next
            // turn, as the plain publisher's would-block does.
            return Ok(0);
        }
        // A run refused among others is not sent again (later ones went,
        // so sending it now would reorder), and not taken for the broker's loss.
        self.refused += (report.full + report.failed) as u64;
        Ok(n)
    }

    fn refused(&self) -> u64 {
        self.refused
    }
}

/// An MQTT connection subscribed to the benchmark topic.
pub struct MqttSub {
    conn: mqtt::Conn,
    count: u64,
    next: u64,
}

impl MqttSub {
    pub fn new(conn: mqtt::Conn) -> io::Result<MqttSub> {
        conn.stream.set_nonblocking(true)?;
        Ok(MqttSub {
            conn,
            count: 0,
            next: 0,
        })
    }
}

impl Subscriber for MqttSub {
    fn fd(&self) -> BorrowedFd<'_> {
        self.conn.stream.as_fd()
    }

    fn drain(&mut self) -> io::Result<()> {
        for _ in 0..4 {
            match self.conn.fill() {
                Ok(0) => {
                    return Err(io::Error::new(
                        io::ErrorKind::UnexpectedEof,
                        "broker closed a subscriber connection",
                    ))
                }
                Ok(_) => {
                    let (count, next) = (&mut self.count, &mut self.next);
                    self.conn.each_publish(|p| {
                        if let Some(seq) = payload::seq_of(p) {
                            *count += 1;
                            *next = (*next).max(seq + 1);
                        }
                    });
                }
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }

    fn count(&self) -> u64 {
        self.count
    }

    fn next(&self) -> u64 {
        self.next
    }
}

/// Pipelines QoS 0 PUBLISH frames, many per `write`.
pub struct MqttPub {
    stream: TcpStream,
    packet: Packet,
    out: Vec<u8>,
}

impl MqttPub {
    pub fn new(conn: mqtt::Conn, lengths: Lengths) -> MqttPub {
        MqttPub {
            stream: conn.stream,
            packet: Packet::with(lengths),
            out: Vec::with_capacity(BATCH * 128),
        }
    }
}

impl Publisher for MqttPub {
    fn send(&mut self, first: u64, n: usize) -> io::Result<usize> {
        let n = n.min(BATCH);
        self.out.clear();
        for i in 0..n {
            mqtt::put_publish(
                &mut self.out,
                payload::CHANNEL,
                self.packet.stamp(first + i as u64),
            );
        }
        self.stream.write_all(&self.out)?;
        Ok(n)
    }
}

/// What one fan-out run measured.
pub struct Fanout {
    pub subscribers: usize,
    /// Packets delivered per second, summed over subscribers, in the measured interval.
    pub rate: f64,
    pub sent: u64,
    pub delivered: u64,
    pub loss_pct: f64,
    /// The worst loss over the rounds merged into this one.
    pub worst_loss_pct: f64,
    /// The broker's CPU use in the measured interval, in % of one core.
    pub broker_cpu_pct: Option<f64>,
    /// This process's CPU use less the broker's, in % of one core.
    pub bench_cpu_pct: Option<f64>,
    /// Times the publisher wrote off a full window of lost packets.
    pub stalls: u64,
    /// UDP datagrams the kernel dropped at a full receive buffer during the run.
    pub rcvbuf_drops: Option<u64>,
    /// CPU used by other processes in the measured interval, in % of the machine.
    pub foreign_pct: Option<f64>,
}

struct Shared {
    /// Per receiver thread: the lowest `next` over its subscribers.
    acked: Vec<AtomicU64>,
    /// Per receiver thread: packets received over its subscribers.
    received: Vec<AtomicU64>,
    waiting: AtomicBool,
    stop: AtomicBool,
    publisher: Thread,
}

impl Shared {
    fn acked(&self) -> u64 {
        self.acked
            .iter()
            .map(|a| a.load(Ordering::SeqCst))
            .min()
            .unwrap_or(0)
    }

    fn received(&self) -> u64 {
        self.received.iter().map(|a| a.load(Ordering::SeqCst)).sum()
    }
}

fn receive(shared: &Shared, me: usize, mut subs: Vec<Box<dyn Subscriber>>) -> io::Result<()> {
    let mut epoll = sys::Epoll::new()?;
    for (i, s) in subs.iter().enumerate() {
        epoll.add(&s.fd(), i)?;
    }
    let mut acked = 0;
    let mut received = 0;
    while !shared.stop.load(Ordering::Relaxed) {
        let mut any = false;
        for i in epoll.wait(Duration::from_millis(5))? {
            let sub = &mut subs[i];
            let before = sub.count();
            sub.drain()?;
            received += sub.count() - before;
            any = true;
        }
        if !any {
            continue;
        }
        let low = subs.iter().map(|s| s.next()).min().unwrap_or(0);
        shared.received[me].store(received, Ordering::SeqCst);
        if low != acked {
            acked = low;
            shared.acked[me].store(acked, Ordering::SeqCst);
        }
        if shared.waiting.load(Ordering::SeqCst) && shared.waiting.swap(false, Ordering::SeqCst) {
            shared.publisher.unpark();
        }
    }
    Ok(())
}

/// CPU clocks read at the start and end of the measured interval.
pub struct CpuProbe<'a> {
    /// The broker's CPU time so far.
    pub broker: &'a dyn Fn() -> Option<Duration>,
    /// Whether the broker is a thread of this process (its time is in ours).
    pub broker_in_process: bool,
    /// Processes we started (brokers), whose CPU time is not outside load.
    pub pids: &'a [u32],
}

fn own_cpu() -> Option<Duration> {
    sys::process_cpu(std::process::id())
}

/// Runs one fan-out: `warmup` unmeasured, then `duration` measured.
pub fn run(
    publisher: &mut dyn Publisher,
    subs: Vec<Box<dyn Subscriber>>,
    threads: usize,
    window: u64,
    warmup: Duration,
    duration: Duration,
    probe: &CpuProbe<'_>,
) -> io::Result<Fanout> {
    let n_subs = subs.len();
    let rcvbuf_before = sys::udp_rcvbuf_errors();
    let threads = threads.clamp(1, n_subs.max(1));
    let mut groups: Vec<Vec<Box<dyn Subscriber>>> = (0..threads).map(|_| Vec::new()).collect();
    for (i, s) in subs.into_iter().enumerate() {
        groups[i % threads].push(s);
    }
    let shared = Shared {
        acked: (0..threads).map(|_| AtomicU64::new(0)).collect(),
        received: (0..threads).map(|_| AtomicU64::new(0)).collect(),
        waiting: AtomicBool::new(false),
        stop: AtomicBool::new(false),
        publisher: thread::current(),
    };
    thread::scope(|scope| {
        let receivers: Vec<_> = groups
            .into_iter()
            .enumerate()
            .map(|(me, group)| {
                let shared = &shared;
                thread::Builder::new()
                    .name(format!("recv{me}"))
                    .spawn_scoped(scope, move || receive(shared, me, group))
            })
            .collect::<io::Result<_>>()?;

        let result = publish(&mut *publisher, &shared, window, warmup, duration, probe);
        shared.stop.store(true, Ordering::SeqCst);
        for r in receivers {
            r.join()
                .map_err(|_| io::Error::other("a receiver thread panicked"))??;
        }
        let mut fanout = result?;
        fanout.subscribers = n_subs;
        fanout.rcvbuf_drops = sys::udp_rcvbuf_errors()
            .zip(rcvbuf_before)
            .map(|(after, before)| after.saturating_sub(before));
        fanout.delivered = shared.received();
        fanout.sent -= publisher.refused().min(fanout.sent);
        let expected = fanout.sent * n_subs as u64;
        fanout.loss_pct = if expected == 0 {
            0.0
        } else {
            100.0 * expected.saturating_sub(fanout.delivered) as f64 / expected as f64
        };
        fanout.worst_loss_pct = fanout.loss_pct;
        Ok(fanout)
    })
}

fn publish(
    publisher: &mut dyn Publisher,
    shared: &Shared,
    window: u64,
    warmup: Duration,
    duration: Duration,
    probe: &CpuProbe<'_>,
) -> io::Result<Fanout> {
    let t0 = Instant::now();
    let measure_from = t0 + warmup;
    let end = measure_from + duration;
    let mut start: Option<(Instant, u64, Option<Duration>, Option<Duration>)> = None;
    let mut foreign: Option<sys::Foreign> = None;
    let mut sent = 0u64;
    let mut written_off = 0u64;
    let mut stalls = 0u64;
    let mut last_received = 0u64;
    let mut last_progress = t0;
    loop {
        let now = Instant::now();
        if start.is_none() && now >= measure_from {
            start = Some((now, shared.received(), (probe.broker)(), own_cpu()));
            foreign = Some(sys::Foreign::start(probe.pids));
        }
        if now >= end {
            break;
        }
        let acked = shared.acked().max(written_off);
        let in_flight = sent - acked.min(sent);
        if in_flight < window {
            sent += publisher.send(sent, (window - in_flight) as usize)? as u64;
            continue;
        }
        // Window full: sleep until a receiver reports progress.
        shared.waiting.store(true, Ordering::SeqCst);
        if shared.acked() <= acked {
            thread::park_timeout(Duration::from_millis(2));
        }
        shared.waiting.store(false, Ordering::SeqCst);
        // Slow subscribers still receive; only when nothing at all arrives
        // for a while are the packets in flight taken as lost.
        let received = shared.received();
        if received != last_received {
            last_received = received;
            last_progress = now;
        } else if now.duration_since(last_progress) > STALL {
            written_off = sent;
            stalls += 1;
            last_progress = now;
        }
    }
    let stop = Instant::now();
    let foreign_pct = foreign.and_then(|f| f.percent(probe.pids));
    let received_end = shared.received();
    let broker_end = (probe.broker)();
    let own_end = own_cpu();
    let (t_start, received_start, broker_start, own_start) =
        start.unwrap_or((stop, received_end, broker_end, own_end));
    let wall = stop.duration_since(t_start).as_secs_f64();
    // Let the last packets arrive before the receivers stop.
    let drain_end = Instant::now() + DRAIN;
    while Instant::now() < drain_end && shared.acked() < sent {
        thread::sleep(Duration::from_millis(5));
    }
    thread::sleep(Duration::from_millis(20));
    let pct = |a: Option<Duration>, b: Option<Duration>| -> Option<f64> {
        Some(100.0 * b?.saturating_sub(a?).as_secs_f64() / wall)
    };
    let broker_cpu_pct = pct(broker_start, broker_end);
    let own_pct = pct(own_start, own_end);
    let bench_cpu_pct = match (own_pct, broker_cpu_pct, probe.broker_in_process) {
        (Some(o), Some(b), true) => Some((o - b).max(0.0)),
        (o, _, false) => o,
        _ => None,
    };
    Ok(Fanout {
        subscribers: 0,
        rate: (received_end - received_start) as f64 / wall,
        sent,
        delivered: 0,
        loss_pct: 0.0,
        worst_loss_pct: 0.0,
        broker_cpu_pct,
        bench_cpu_pct,
        stalls,
        rcvbuf_drops: None,
        foreign_pct,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hub::{subscribe_udp, HubThread};
    use colony_hub::HubConfig;

    #[test]
    fn hub_fanout_counts_every_delivery() {
        fanout_counts_every_delivery(false);
    }

    #[test]
    fn a_gso_publisher_reaches_the_subscribers_one_datagram_a_packet() {
        fanout_counts_every_delivery(true);
    }

    fn fanout_counts_every_delivery(gso: bool) {
        let hub = HubThread::start(HubConfig::default(), None).unwrap();
        let mut subs: Vec<Box<dyn Subscriber>> = Vec::new();
        for _ in 0..3 {
            let sock = UdpSocket::bind("127.0.0.1:0").unwrap();
            sock.connect(hub.addr).unwrap();
            subscribe_udp(&sock, payload::CHANNEL).unwrap();
            subs.push(Box::new(UdpSub::new(sock, 0).unwrap()));
        }
        let mut publisher = UdpPub::new(hub.addr, Lengths::Fixed, gso).unwrap();
        let none = || None;
        let probe = CpuProbe {
            broker: &none,
            broker_in_process: true,
            pids: &[],
        };
        let run = run(
            &mut publisher,
            subs,
            2,
            16,
            Duration::from_millis(50),
            Duration::from_millis(200),
            &probe,
        )
        .unwrap();
        hub.stop().unwrap();
        assert_eq!(run.subscribers, 3);
        assert!(run.sent > 0 && run.rate > 0.0);
        assert_eq!(run.delivered, run.sent * 3, "loss {} %", run.loss_pct);
    }

    /// Publishes every packet but each fourth, which it reports refused,
    /// as a GSO publisher does with a run its socket would not take.
    struct Refusing {
        inner: UdpPub,
        refused: u64,
    }

    impl Publisher for Refusing {
        fn send(&mut self, first: u64, n: usize) -> io::Result<usize> {
            let n = n.min(BATCH);
            for seq in first..first + n as u64 {
                if seq % 4 == 3 {
                    self.refused += 1;
                } else if self.inner.send(seq, 1)? == 0 {
                    return Ok((seq - first) as usize);
                }
            }
            Ok(n)
        }

        fn refused(&self) -> u64 {
            self.refused
        }
    }

    #[test]
    fn packets_the_publisher_could_not_send_are_not_the_brokers_loss() {
        let hub = HubThread::start(HubConfig::default(), None).unwrap();
        let sock = UdpSocket::bind("127.0.0.1:0").unwrap();
        sock.connect(hub.addr).unwrap();
        subscribe_udp(&sock, payload::CHANNEL).unwrap();
        let subs: Vec<Box<dyn Subscriber>> = vec![Box::new(UdpSub::new(sock, 0).unwrap())];
        let mut publisher = Refusing {
            inner: UdpPub::new(hub.addr, Lengths::Fixed, false).unwrap(),
            refused: 0,
        };
        let none = || None;
        let probe = CpuProbe {
            broker: &none,
            broker_in_process: true,
            pids: &[],
        };
        let window = 16;
        let (warmup, duration) = (Duration::from_millis(50), Duration::from_millis(200));
        let run = run(&mut publisher, subs, 1, window, warmup, duration, &probe).unwrap();
        hub.stop().unwrap();
        assert!(publisher.refused > 0);
        assert!(run.sent > 0);
        assert_eq!(run.delivered, run.sent, "loss {} %", run.loss_pct);
        assert_eq!(run.loss_pct, 0.0);
    }
}
