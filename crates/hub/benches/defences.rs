//! What the hub's defences cost per packet: a publish with and without a
//! signature, a cookie handed to a new address, a request proven by its
//! cookie, and the status report of a full table.
//!
//! `cargo bench -p colony-hub --bench defences`

use std::hint::black_box;
use std::net::SocketAddr;
use std::time::{Instant, SystemTime};

use colony_hub::{Hub, HubConfig, Outcome};
use colony_wire::auth::{unix_micros, Key};
use colony_wire::{Cookie, Packet, Reply};
use criterion::{criterion_group, criterion_main, Criterion};

fn addr(port: u16) -> SocketAddr {
    SocketAddr::from(([127, 0, 0, 1], port))
}

fn key() -> Key {
    Key::new(b"a key for the benchmark, 32 byte").unwrap()
}

/// Subscribes `who` the way a client does, with the cookie round trip.
fn join(hub: &mut Hub, now: Instant, who: SocketAddr, lines: &str) -> Cookie {
    let first = format!("@ <hub> 0\ncookie v {}\n{lines}", Cookie::NONE);
    hub.handle(now, who, first.as_bytes());
    let cookie = std::iter::from_fn(|| hub.poll_transmit())
        .find_map(|t| match Reply::parse(&Packet::parse(&t.payload).ok()?) {
            Some(Ok(Reply::Cookie(c))) => Some(c),
            _ => None,
        })
        .expect("a cookie");
    let again = format!("@ <hub> 0\ncookie v {cookie}\n{lines}");
    hub.handle(now, who, again.as_bytes());
    while hub.poll_transmit().is_some() {}
    cookie
}

/// A packet of `len` bytes as the throughput benchmark sends (100 bytes,
/// or 60 to 400 in its mixed runs).
fn payload(len: usize) -> Vec<u8> {
    let mut p = b"@ <bench> 0\nping seq 1 pad \"".to_vec();
    p.resize(len - 2, b'x');
    p.extend_from_slice(b"\"\n");
    p
}

fn publish(c: &mut Criterion) {
    let now = Instant::now();
    let packet = payload(100);
    let mut plain = Hub::new(HubConfig::default(), now);
    join(&mut plain, now, addr(1), "subscribe ch bench\n");
    c.bench_function("publish, 1 subscriber", |b| {
        b.iter(|| match plain.handle(now, addr(2), black_box(&packet)) {
            Outcome::Forward { dests, .. } => black_box(dests.len()),
            other => panic!("{other:?}"),
        })
    });
    let long = payload(400);
    c.bench_function("publish a 400-byte packet, 1 subscriber", |b| {
        b.iter(|| match plain.handle(now, addr(2), black_box(&long)) {
            Outcome::Forward { dests, .. } => black_box(dests.len()),
            other => panic!("{other:?}"),
        })
    });

    let config = HubConfig {
        key: Some(key()),
        auth_all: true,
        ..HubConfig::default()
    };
    let mut signed_hub = Hub::new(config, now);
    let n0 = unix_micros(SystemTime::now());
    let mut sub =
        format!("@ <hub> 0\ncookie v {}\nsubscribe ch bench\n", Cookie::NONE).into_bytes();
    key().sign(&mut sub, n0);
    signed_hub.handle(now, addr(1), &sub);
    // Packets signed ahead of time, each with its own counter, so the replay
    // window takes every one.
    let signed: Vec<Vec<u8>> = (1..=200_000u64)
        .map(|i| {
            let mut p = packet.clone();
            key().sign(&mut p, n0 + i);
            p
        })
        .collect();
    let mut i = 0;
    c.bench_function("publish signed (--auth-all), checked and stripped", |b| {
        b.iter(|| {
            let p = &signed[i % signed.len()];
            i += 1;
            black_box(signed_hub.handle(now, addr(3), black_box(p)).accepted())
        })
    });
    let signer = key();
    let mut n = n0;
    c.bench_function("sign a 100-byte packet (client side)", |b| {
        b.iter(|| {
            let mut p = packet.clone();
            n += 1;
            signer.sign(&mut p, n);
            black_box(p.len())
        })
    });
}

fn cookies(c: &mut Criterion) {
    let now = Instant::now();
    let config = HubConfig {
        // The benchmark asks from one source far beyond its rate.
        control_rate: f64::MAX,
        control_burst: f64::MAX,
        ..HubConfig::default()
    };
    let mut hub = Hub::new(config, now);
    let ask = format!("@ <hub> 0\ncookie v {}\nsubscribe ch bench\n", Cookie::NONE);
    let mut port = 1u16;
    c.bench_function("subscribe from a new address: a cookie back", |b| {
        b.iter(|| {
            port = port.wrapping_add(1).max(1);
            hub.handle(now, addr(port), ask.as_bytes());
            black_box(hub.poll_transmit())
        })
    });
    let who = addr(7);
    let cookie = join(&mut hub, now, who, "subscribe ch bench\n");
    let refresh = format!("@ <hub> 0\ncookie v {cookie}\nsubscribe ch bench\n");
    c.bench_function("refresh with its cookie: lease renewed", |b| {
        b.iter(|| {
            hub.handle(now, who, refresh.as_bytes());
            black_box(hub.poll_transmit())
        })
    });
}

fn status(c: &mut Criterion) {
    let now = Instant::now();
    let mut hub = Hub::new(HubConfig::default(), now);
    let subs: String = (0..256)
        .map(|i| format!("subscribe ch channel_{i:03}\n"))
        .collect();
    for port in 0..4096u16 {
        join(&mut hub, now, addr(10_000 + port), &subs);
    }
    c.bench_function("status report of 4,096 clients x 256 subscriptions", |b| {
        b.iter(|| black_box(hub.status(now).to_packet().len()))
    });
}

criterion_group!(benches, publish, cookies, status);
criterion_main!(benches);
