//! Request/reply round trip on loopback, beside its floor: the same two hops
//! (caller -> hub -> provider -> hub -> caller) as plain publish/subscribe.
//!
//! `cargo run --release -p colony-client --example rpc_roundtrip [CALLS]`
//!
//! One process: the hub on a thread of its own, the provider (an echo) on
//! another, and the caller here, one call in flight at a time.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_client::rpc::{CallClient, ServeClient};
use colony_client::UdpClient;
use colony_hub::{HubSpec, HubThread, Server};
use colony_wire::{Packet, PacketBuilder, Priority};

/// The call's one line, about as long as a short command.
const LINE: &str = "goto id 3 x 1.25 y -0.75 speed 0.3 note \"from the round-trip benchmark\"";

fn percentiles(name: &str, mut samples: Vec<Duration>) {
    samples.sort();
    let at = |q: f64| {
        let i = ((samples.len() as f64 - 1.0) * q).round() as usize;
        samples[i].as_secs_f64() * 1e6
    };
    println!(
        "| {name} | {} | {:.1} | {:.1} | {:.1} | {:.1} |",
        samples.len(),
        at(0.5),
        at(0.9),
        at(0.99),
        at(0.999)
    );
}

fn wait_and_poll(client: &mut UdpClient) {
    client
        .wait(Some(Instant::now() + Duration::from_millis(50)))
        .expect("wait");
    client.poll(Instant::now()).expect("poll");
}

fn main() {
    let calls: usize = std::env::args()
        .nth(1)
        .map_or(20_000, |a| a.parse().expect("CALLS is a count"))
        .max(10);
    let stop = Arc::new(AtomicBool::new(false));
    let server = Server::start(&HubSpec::new("127.0.0.1:0")).expect("hub");
    let hub = HubThread::spawn(server, &stop).expect("hub thread");
    let addr = hub.addr().to_string();

    // The provider: echoes each call's lines.
    let provider = {
        let (addr, stop) = (addr.clone(), stop.clone());
        std::thread::spawn(move || {
            let mut s = ServeClient::connect(&addr, "echo", Duration::from_secs(3)).expect("serve");
            s.serve(&stop, |asked| Ok(asked.lines.clone()))
                .expect("serving");
        })
    };
    // The floor's echo: what arrives on `ping` goes back on `pong`.
    let echo = {
        let (addr, stop) = (addr.clone(), stop.clone());
        std::thread::spawn(move || {
            let mut c = UdpClient::connect_to(&addr).expect("echo client");
            c.subscribe("ping").expect("subscribe");
            while !stop.load(Ordering::Relaxed) {
                wait_and_poll(&mut c);
                let mut out = Vec::new();
                while let Some(p) = c.recv().expect("recv") {
                    let mut b = PacketBuilder::new(["pong"], Priority(0));
                    for l in p.lines() {
                        b.raw_line(l.as_str());
                    }
                    out.push(b.finish().expect("pong"));
                }
                for p in out {
                    c.publish(&p).expect("publish");
                }
            }
        })
    };

    let mut caller = CallClient::connect(&addr, "echo").expect("caller");
    let mut ping = UdpClient::connect_to(&addr).expect("ping client");
    ping.subscribe("pong").expect("subscribe");
    let packet = {
        let mut b = PacketBuilder::new(["ping"], Priority(0));
        b.raw_line(LINE);
        b.finish().expect("ping")
    };
    let timeout = Duration::from_secs(5);
    // The two paths take turns, call by call, so whatever else the machine
    // does falls on both alike; the first tenth of each warms up.
    let warm = calls / 10;
    let (mut rpc, mut floor) = (Vec::with_capacity(calls), Vec::with_capacity(calls));
    let mut lost = 0u64;
    for i in 0..calls + warm {
        let t = Instant::now();
        let answer = caller
            .call(Priority(0), &[LINE], timeout)
            .expect("an answer");
        assert_eq!(answer.lines, [LINE]);
        if i >= warm {
            rpc.push(t.elapsed());
        }
        loop {
            let t = Instant::now();
            ping.publish(&packet).expect("publish");
            let back = loop {
                wait_and_poll(&mut ping);
                if let Some(p) = ping.recv().expect("recv") {
                    break Packet::parse(p.as_str().as_bytes()).is_ok();
                }
                // Until both subscriptions hold, a ping is lost: send again.
                if t.elapsed() > Duration::from_millis(200) {
                    break false;
                }
            };
            if back {
                if i >= warm {
                    floor.push(t.elapsed());
                }
                break;
            }
            lost += 1;
        }
    }
    println!("pings lost (sent again after 200 ms): {lost}");
    println!("| path | round trips | p50 µs | p90 µs | p99 µs | p99.9 µs |");
    println!("|---|---:|---:|---:|---:|---:|");
    percentiles(
        "colony call: caller -> hub -> provider -> hub -> caller",
        rpc,
    );
    percentiles("floor: publish `ping`, echo on `pong`, same hops", floor);
    stop.store(true, Ordering::Relaxed);
    let _ = provider.join();
    let _ = echo.join();
    let _ = hub.stop();
}
