//! One-way latency through a relay, a colony hub or Mosquitto, one packet in
//! flight at a time. Publisher and subscriber are sockets of the measuring
//! thread, so both timestamps come from one clock and no halving of a round
//! trip is needed: each sample is publish -> broker -> subscriber.

use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::thread;
use std::time::{Duration, Instant};

use anyhow::Context;
use colony_hub::HubConfig;

use crate::hub::{subscribe_udp, HubThread};
use crate::mqtt;
use crate::payload::{self, Packet};
use crate::sys;

/// How long a subscriber waits before a sample counts as lost.
const LOST_AFTER: Duration = Duration::from_millis(200);

/// Latency samples in nanoseconds, sorted, and how many packets never came.
pub struct Latency {
    pub name: String,
    /// Where the threads ran, e.g. "one core".
    pub placement: String,
    pub ns: Vec<u64>,
    pub lost: u64,
}

impl Latency {
    /// The `q` quantile (0..=1) in microseconds, nearest rank.
    pub fn quantile_us(&self, q: f64) -> f64 {
        if self.ns.is_empty() {
            return f64::NAN;
        }
        let rank = ((q * self.ns.len() as f64).ceil() as usize).clamp(1, self.ns.len());
        self.ns[rank - 1] as f64 / 1000.0
    }
}

/// Runs `warmup` unrecorded and then `samples` recorded round trips of
/// `one`, which publishes packet `seq` and returns once it has arrived
/// (`Ok(true)`) or was given up on (`Ok(false)`).
fn measure(
    name: &str,
    warmup: usize,
    samples: usize,
    mut one: impl FnMut(u64) -> io::Result<bool>,
) -> io::Result<Latency> {
    let mut ns = Vec::with_capacity(samples);
    let mut lost = 0;
    for seq in 0..(warmup + samples) as u64 {
        let t0 = Instant::now();
        let arrived = one(seq)?;
        let dt = t0.elapsed();
        if seq < warmup as u64 {
            continue;
        }
        if arrived {
            ns.push(dt.as_nanos() as u64);
        } else {
            lost += 1;
        }
    }
    ns.sort_unstable();
    Ok(Latency {
        name: name.to_owned(),
        placement: String::new(),
        ns,
        lost,
    })
}

/// Receives on a blocking UDP socket until packet `seq` arrives or the read times out.
fn await_udp(sock: &UdpSocket, buf: &mut [u8], seq: u64) -> io::Result<bool> {
    loop {
        match sock.recv(buf) {
            Ok(n) => match payload::seq_of(&buf[..n]) {
                Some(s) if s == seq => return Ok(true),
                _ => continue, // a late packet from a sample already counted lost
            },
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) =>
            {
                return Ok(false)
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        }
    }
}

fn loopback_udp() -> io::Result<UdpSocket> {
    UdpSocket::bind("127.0.0.1:0")
}

/// (a) The floor: a relay thread doing blocking `recv_from` + `send_to` to
/// one subscriber, the one extra hop a broker adds and nothing else.
pub fn raw_udp(warmup: usize, samples: usize, cpu: Option<usize>) -> anyhow::Result<Latency> {
    let relay = loopback_udp()?;
    let publisher = loopback_udp()?;
    let subscriber = loopback_udp()?;
    let relay_addr = relay.local_addr()?;
    publisher.connect(relay_addr)?;
    subscriber.connect(relay_addr)?;
    subscriber.set_read_timeout(Some(LOST_AFTER))?;
    let dest = subscriber.local_addr()?;
    let relay_thread =
        thread::Builder::new()
            .name("relay".into())
            .spawn(move || -> io::Result<()> {
                sys::pin_self(cpu.as_ref().map(std::slice::from_ref))?;
                let mut buf = [0u8; 2048];
                loop {
                    let (n, _from) = relay.recv_from(&mut buf)?;
                    if &buf[..n] == b"stop" {
                        return Ok(());
                    }
                    relay.send_to(&buf[..n], dest)?;
                }
            })?;
    let mut packet = Packet::new();
    let mut buf = [0u8; 2048];
    let result = measure(crate::names::RAW, warmup, samples, |seq| {
        publisher.send(packet.stamp(seq))?;
        await_udp(&subscriber, &mut buf, seq)
    });
    publisher.send(b"stop")?;
    relay_thread
        .join()
        .map_err(|_| anyhow::anyhow!("relay thread panicked"))??;
    Ok(result?)
}

/// (b) The colony hub, in-process on its own thread, raw sockets on our side.
pub fn hub_raw(
    warmup: usize,
    samples: usize,
    config: &HubConfig,
    cpu: Option<usize>,
) -> anyhow::Result<Latency> {
    let hub = HubThread::start(config.clone(), cpu)?;
    let publisher = loopback_udp()?;
    let subscriber = loopback_udp()?;
    publisher.connect(hub.addr)?;
    subscriber.connect(hub.addr)?;
    subscribe_udp(&subscriber, payload::CHANNEL)?;
    subscriber.set_read_timeout(Some(LOST_AFTER))?;
    let mut packet = Packet::new();
    let mut buf = [0u8; 2048];
    let result = measure(crate::names::HUB, warmup, samples, |seq| {
        publisher.send(packet.stamp(seq))?;
        await_udp(&subscriber, &mut buf, seq)
    });
    hub.stop()?;
    Ok(result?)
}

/// (b') The colony hub through the colony-client library on both ends:
/// `UdpClient::publish` checks the packet, `recv` parses it.
pub fn hub_client(
    warmup: usize,
    samples: usize,
    config: &HubConfig,
    cpu: Option<usize>,
) -> anyhow::Result<Latency> {
    let hub = HubThread::start(config.clone(), cpu)?;
    let mut publisher = colony_client::UdpClient::connect(hub.addr)?;
    let mut subscriber = colony_client::UdpClient::connect(hub.addr)?;
    subscriber.subscribe(payload::CHANNEL)?;
    let deadline = Instant::now() + Duration::from_secs(2);
    loop {
        subscriber.wait(Some(deadline))?;
        if let Some(colony_wire::Reply::Lease { .. }) = subscriber.recv_reply()? {
            break;
        }
        anyhow::ensure!(Instant::now() < deadline, "the hub sent no lease");
    }
    let mut packet = Packet::new();
    let result = measure("colony hub via colony-client", warmup, samples, |seq| {
        publisher
            .publish(packet.stamp(seq))
            .map_err(|e| io::Error::other(e.to_string()))?;
        let deadline = Instant::now() + LOST_AFTER;
        loop {
            if let Some(p) = subscriber.recv()? {
                if payload::seq_of(p.as_str().as_bytes()) == Some(seq) {
                    return Ok(true);
                }
                continue;
            }
            if !subscriber.wait(Some(deadline))? {
                return Ok(false);
            }
        }
    });
    hub.stop()?;
    Ok(result?)
}

/// (c) Mosquitto at QoS 0: publisher and subscriber TCP connections of this thread.
pub fn mosquitto(
    name: &str,
    warmup: usize,
    samples: usize,
    broker: SocketAddr,
) -> anyhow::Result<Latency> {
    let mut subscriber = mqtt::Conn::connect(broker, "bench-lat-sub")?;
    subscriber.subscribe(payload::CHANNEL)?;
    subscriber.stream.set_read_timeout(Some(LOST_AFTER))?;
    let mut publisher = mqtt::Conn::connect(broker, "bench-lat-pub")?;
    let mut packet = Packet::new();
    let mut frame = Vec::with_capacity(256);
    let result = measure(name, warmup, samples, |seq| {
        frame.clear();
        mqtt::put_publish(&mut frame, payload::CHANNEL, packet.stamp(seq));
        std::io::Write::write_all(&mut publisher.stream, &frame)?;
        loop {
            let mut found = false;
            subscriber.each_publish(|p| found |= payload::seq_of(p) == Some(seq));
            if found {
                return Ok(true);
            }
            match subscriber.fill() {
                Ok(0) => {
                    return Err(io::Error::new(
                        io::ErrorKind::UnexpectedEof,
                        "broker closed",
                    ))
                }
                Ok(_) => {}
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                    ) =>
                {
                    return Ok(false)
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    })
    .context("Mosquitto latency")?;
    Ok(result)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relay_and_hub_deliver_every_sample() {
        let raw = raw_udp(5, 50, None).unwrap();
        assert_eq!((raw.ns.len(), raw.lost), (50, 0));
        let hub = hub_raw(5, 50, &HubConfig::default(), None).unwrap();
        assert_eq!((hub.ns.len(), hub.lost), (50, 0));
        assert!(hub.quantile_us(0.5) > 0.0);
        assert!(hub.quantile_us(0.5) <= hub.quantile_us(0.999));
    }
}
