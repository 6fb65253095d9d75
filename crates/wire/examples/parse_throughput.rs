//! Parse throughput of `Packet::parse` on one packet file, measured the way the C
//! client's `clients/c/bench/bench_parse.c` measures its parser, so the two
//! figures in BENCHMARKS.md compare like with like:
//!
//! `cargo run --release -p colony-wire --example parse_throughput clients/c/bench/vision.txt`
//!
//! Each of 11 rounds runs one operation for about 0.3 s; the best and the
//! median round's time per packet are printed (the best is the one a busy
//! machine disturbs least). "parse" checks the whole packet; "parse+read"
//! also walks every line and field and reads every bare value as a number.

use std::hint::black_box;
use std::time::Instant;

use colony_wire::Packet;

fn measure(name: &str, data: &[u8], op: impl Fn(&[u8]) -> f64) {
    let mut per: Vec<f64> = (0..11)
        .map(|_| {
            let start = Instant::now();
            let mut n = 0u64;
            loop {
                for _ in 0..1000 {
                    black_box(op(black_box(data)));
                }
                n += 1000;
                let elapsed = start.elapsed().as_secs_f64();
                if elapsed >= 0.3 {
                    break elapsed / n as f64;
                }
            }
        })
        .collect();
    per.sort_by(f64::total_cmp);
    let mib = |t: f64| data.len() as f64 / t / 1_048_576.0;
    println!(
        "Rust  {name:<10} {:5} bytes  best {:7.3} us {:7.1} MiB/s  median {:7.3} us {:7.1} MiB/s",
        data.len(),
        per[0] * 1e6,
        mib(per[0]),
        per[5] * 1e6,
        mib(per[5])
    );
}

fn main() {
    let path = std::env::args()
        .nth(1)
        .expect("usage: parse_throughput PACKET_FILE");
    let data = std::fs::read(&path).expect("read the packet file");
    Packet::parse(&data).expect("the file holds one valid packet");
    measure("parse", &data, |d| match Packet::parse(d) {
        Ok(p) => f64::from(p.priority().0),
        Err(_) => f64::NAN,
    });
    measure("parse+read", &data, |d| {
        let p = Packet::parse(d).expect("valid");
        let mut sum = 0.0;
        for line in p.lines() {
            for field in line.fields() {
                if let Some(v) = field.value.as_f64() {
                    sum += v;
                }
            }
        }
        sum
    });
}
