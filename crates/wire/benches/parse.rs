//! Parse and build throughput for the packets colony sends most: RoboCup-style
//! vision frames.
//!
//! `cargo bench -p colony-wire --bench parse`

use std::hint::black_box;
use std::time::Duration;

use colony_wire::{Packet, PacketBuilder, Priority};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};

/// One robot as the overhead tracker reports it.
struct Robot {
    id: u32,
    x: f64,
    y: f64,
    xh: f64,
    yh: f64,
}

/// Five robots a team, with positions and headings that look measured.
fn robots() -> Vec<(&'static str, Robot)> {
    (0..10)
        .map(|i| {
            let team = if i < 5 { "blue" } else { "yellow" };
            let a = i as f64 * 0.7;
            let robot = Robot {
                id: i % 5,
                x: ((-90.0 + 17.3 * i as f64) * 10.0).round() / 10.0,
                y: ((-98.3 + 21.7 * i as f64) * 10.0).round() / 10.0,
                xh: (a.cos() * 100.0).round() / 100.0,
                yh: (a.sin() * 100.0).round() / 100.0,
            };
            (team, robot)
        })
        .collect()
}

/// The vision frame, written by the builder; 10 robot lines plus ball and latency.
fn vision_packet(robots: &[(&str, Robot)]) -> Vec<u8> {
    let mut b = PacketBuilder::new(["vision_out"], Priority(0));
    b.line("ball").field("x", 5.3).field("y", -2.5);
    for (team, r) in robots {
        b.line(team)
            .field("id", r.id)
            .field("x", r.x)
            .field("y", r.y)
            .field("xh", r.xh)
            .field("yh", r.yh);
    }
    b.line("latency").field("millis", 152);
    b.finish().expect("the vision frame is valid")
}

/// About 60 KB: the vision frame's body repeated under one header.
fn large_packet(vision: &[u8]) -> Vec<u8> {
    let text = std::str::from_utf8(vision).unwrap();
    let (header, body) = text.split_once('\n').unwrap();
    let mut out = format!("{header}\n");
    while out.len() + body.len() <= 60_000 {
        out.push_str(body);
    }
    out.into_bytes()
}

/// The same frame as JSON, the usual alternative, for the peer measurement.
fn vision_json(vision: &[u8]) -> Vec<u8> {
    let p = Packet::parse(vision).unwrap();
    let lines: Vec<String> = p
        .lines()
        .map(|l| {
            let fields: Vec<String> = l
                .fields()
                .map(|f| format!("\"{}\":{}", f.name, f.value.as_f64().unwrap()))
                .collect();
            format!("{{\"label\":\"{}\",{}}}", l.label(), fields.join(","))
        })
        .collect();
    format!(
        "{{\"subjects\":[\"vision_out\"],\"priority\":0,\"lines\":[{}]}}",
        lines.join(",")
    )
    .into_bytes()
}

/// Parses and reads every field of every line as a number.
fn parse_and_read(bytes: &[u8]) -> f64 {
    let p = Packet::parse(bytes).unwrap();
    let mut sum = 0.0;
    for line in p.lines() {
        for f in line.fields() {
            sum += f.value.as_f64().unwrap();
        }
    }
    sum
}

fn bench(c: &mut Criterion) {
    let robots = robots();
    let vision = vision_packet(&robots);
    let large = large_packet(&vision);
    assert!(
        (400..=500).contains(&vision.len()),
        "{} bytes",
        vision.len()
    );
    assert!(large.len() > 55_000, "{} bytes", large.len());
    // Both read back: every field is a number.
    assert!(parse_and_read(&vision).is_finite());
    assert!(parse_and_read(&large).is_finite());
    eprintln!(
        "vision packet {} bytes, large packet {} bytes",
        vision.len(),
        large.len()
    );

    for (name, bytes) in [("vision", &vision), ("large_60k", &large)] {
        let mut g = c.benchmark_group(format!("parse/{name}"));
        g.throughput(Throughput::Bytes(bytes.len() as u64));
        g.bench_function("parse_only", |b| {
            b.iter(|| Packet::parse(black_box(bytes)).unwrap().priority())
        });
        g.bench_function("parse_and_read_f64", |b| {
            b.iter(|| parse_and_read(black_box(bytes)))
        });
        g.finish();
    }

    // The peer: the same frame as JSON through serde_json into a `Value`,
    // numbers converted as `parse_and_read_f64` converts them.
    let json = vision_json(&vision);
    assert!(serde_json::from_slice::<serde_json::Value>(&json).is_ok());
    eprintln!("vision frame as JSON: {} bytes", json.len());
    let mut g = c.benchmark_group("peer/vision_json");
    g.throughput(Throughput::Bytes(json.len() as u64));
    g.bench_function("serde_json_value", |b| {
        b.iter(|| serde_json::from_slice::<serde_json::Value>(black_box(&json)).unwrap())
    });
    g.finish();

    let mut g = c.benchmark_group("build/vision");
    g.throughput(Throughput::Bytes(vision.len() as u64));
    g.bench_function("builder_and_finish", |b| {
        b.iter(|| vision_packet(black_box(&robots)))
    });
    g.finish();
}

fn config() -> Criterion {
    Criterion::default()
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1))
        .sample_size(20)
}

criterion_group! {
    name = benches;
    config = config();
    targets = bench
}
criterion_main!(benches);
