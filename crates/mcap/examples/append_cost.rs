//! What logging one packet costs the hub's thread, `.clog` against MCAP: appends of a sort-live
//! `vision` frame (4 robots, 40 pucks) and of a one-line `radio` command, each format writing to
//! a file in a temporary directory, the MCAP's chunks closed as they fill (1 MiB) and finished
//! at the end. `cargo run --release -p colony-mcap --example append_cost [N]` (N appends of
//! each, default 200,000).

use std::time::{Duration, Instant, UNIX_EPOCH};

use colony_hub::log::LogWriter;
use colony_mcap::McapLogWriter;

fn vision() -> Vec<u8> {
    let mut p = String::from("@ <vision> 20\nstep n 1234 part 0 parts 1\n");
    p += "arena width 187 height 187 corner 15\n";
    p += "sizes robot_length 12.5 robot_width 10.8 gripper_radius 3.6 puck_diameter 6.3\n";
    for id in 0..4 {
        p += &format!(
            "robot id {id} x {:.2} y {:.2} theta {:.2}\n",
            id as f64 * 17.3 - 30.0,
            41.7 - id as f64 * 9.1,
            0.61
        );
    }
    for id in 0..40 {
        p += &format!(
            "puck id {id} kind {} x {:.2} y {:.2}\n",
            id % 2,
            id as f64 * 3.7 - 70.0,
            60.0 - id as f64 * 2.9
        );
    }
    p.into_bytes()
}

fn main() {
    let n: u64 = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(200_000);
    let dir = tempfile::tempdir().unwrap();
    let src = "127.0.0.1:5000".parse().unwrap();
    let radio = b"@ <radio> 0\ncmd id 1 forward 0.56 turn -0.44\n".to_vec();
    let vision = vision();
    println!(
        "{n} appends of each; vision {} bytes, radio {} bytes",
        vision.len(),
        radio.len()
    );
    for (name, packet) in [("vision", &vision), ("radio", &radio)] {
        let path = dir.path().join(format!("{name}.clog"));
        let (mut clog, _) = LogWriter::open(&path).unwrap();
        let t = Instant::now();
        for i in 0..n {
            clog.append(UNIX_EPOCH + Duration::from_micros(i), src, packet)
                .unwrap();
        }
        clog.flush().unwrap();
        let clog_time = t.elapsed();
        let clog_size = std::fs::metadata(&path).unwrap().len();

        let path = dir.path().join(format!("{name}.mcap"));
        let mut mcap = McapLogWriter::create(&path).unwrap();
        let source = src.to_string();
        let t = Instant::now();
        for i in 0..n {
            mcap.append_raw(i, &source, packet).unwrap();
        }
        mcap.finish().unwrap();
        let mcap_time = t.elapsed();
        let mcap_size = std::fs::metadata(&path).unwrap().len();
        let parsed = colony_wire::Packet::parse(packet).unwrap();
        let t = Instant::now();
        let mut json_bytes = 0;
        for _ in 0..n {
            json_bytes += colony_schema::to_json(&parsed, Some(&source)).len();
        }
        let json_time = t.elapsed();
        let per = |d: Duration| d.as_secs_f64() * 1e6 / n as f64;
        println!(
            "{name}: colony-schema's to_json alone {:.2} us/packet, {} bytes of JSON",
            per(json_time),
            json_bytes as u64 / n
        );
        println!(
            "{name}: .clog {:.2} us/packet, {:.0} bytes/packet; MCAP {:.2} us/packet, {:.0} bytes/packet",
            per(clog_time),
            clog_size as f64 / n as f64,
            per(mcap_time),
            mcap_size as f64 / n as f64
        );
    }
}
