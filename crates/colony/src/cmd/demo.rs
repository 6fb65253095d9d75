//! `colony demo`: a hub, a simulated overhead-camera publisher and a
//! subscriber in one process, so a newcomer sees the system work.

use std::f64::consts::TAU;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use colony_hub::{HubConfig, Server};
use colony_wire::{PacketBuilder, Priority};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Where the demo's hub listens.
    #[arg(long, default_value = "127.0.0.1:7400", value_name = "HOST:PORT")]
    pub bind: String,
    /// Stop after this many seconds (default: run until Ctrl-C).
    #[arg(long)]
    pub seconds: Option<f64>,
}

/// Vision frames per second, as an overhead camera delivers them.
const FRAME_RATE: f64 = 30.0;

pub fn run(args: Args) -> anyhow::Result<()> {
    let mut server = Server::bind(args.bind.as_str(), HubConfig::default())
        .with_context(|| format!("cannot start the demo's hub on `{}` (is a hub already running? try --bind 127.0.0.1:7401)", args.bind))?;
    let hub_addr = server.local_addr()?;
    let stop = super::stop_flag()?;
    if let Some(s) = args.seconds {
        if !(s.is_finite() && s > 0.0) {
            anyhow::bail!("--seconds must be a positive number");
        }
        let stop = stop.clone();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_secs_f64(s));
            stop.store(true, Ordering::Relaxed);
        });
    }
    let hub_stop = stop.clone();
    let hub = std::thread::spawn(move || server.run(&hub_stop));
    let camera_stop = stop.clone();
    let camera = std::thread::spawn(move || camera(hub_addr, camera_stop));
    println!(
        "colony demo: hub on {hub_addr}; publishing <vision_out> at {FRAME_RATE} Hz; Ctrl-C stops"
    );
    let shown = watch(hub_addr, &stop);
    stop.store(true, Ordering::Relaxed);
    camera
        .join()
        .map_err(|_| anyhow::anyhow!("the camera thread panicked"))??;
    hub.join()
        .map_err(|_| anyhow::anyhow!("the hub thread panicked"))??;
    let shown = shown?;
    println!("colony demo: received {shown} vision packets; bye");
    Ok(())
}

/// A simulated overhead camera: a ball and ten robots moving on circles.
fn camera(hub: std::net::SocketAddr, stop: Arc<AtomicBool>) -> anyhow::Result<()> {
    let mut client = colony_client::UdpClient::connect(hub)?;
    let start = Instant::now();
    let period = Duration::from_secs_f64(1.0 / FRAME_RATE);
    let mut frame = 0u64;
    while !stop.load(Ordering::Relaxed) {
        let t = start.elapsed().as_secs_f64();
        client.publish(&vision_packet(frame, t))?;
        frame += 1;
        let next = start + period.mul_f64(frame as f64);
        std::thread::sleep(next.saturating_duration_since(Instant::now()));
    }
    Ok(())
}

/// One RoboCup-style vision frame at time `t` seconds.
pub fn vision_packet(frame: u64, t: f64) -> Vec<u8> {
    let mut p = PacketBuilder::new(["vision_out"], Priority(0));
    p.line("frame").field("n", frame).field("t", round(t));
    p.line("ball")
        .field("x", round(60.0 * (t * 0.7).cos()))
        .field("y", round(40.0 * (t * 1.1).sin()));
    for (team, sign) in [("blue", -1.0), ("yellow", 1.0)] {
        for id in 0..5 {
            let phase = t * 0.4 + id as f64 * TAU / 5.0;
            let (x, y) = (sign * (70.0 + 20.0 * phase.cos()), 50.0 * phase.sin());
            p.line(team)
                .field("id", id)
                .field("x", round(x))
                .field("y", round(y))
                .field("xh", round(-phase.sin()))
                .field("yh", round(phase.cos()));
        }
    }
    p.line("latency").field("millis", 12);
    p.finish().expect("the demo's packets are well formed")
}

fn round(v: f64) -> f64 {
    (v * 100.0).round() / 100.0
}

/// Subscribes and prints a frame every second, with the rate seen.
fn watch(hub: std::net::SocketAddr, stop: &AtomicBool) -> anyhow::Result<u64> {
    let mut client = colony_client::UdpClient::connect(hub)?;
    client.subscribe("vision_out")?;
    let mut total = 0u64;
    let mut in_second = 0u64;
    let mut next_report = Instant::now() + Duration::from_secs(1);
    while !stop.load(Ordering::Relaxed) {
        client.wait(Some(
            next_report.min(Instant::now() + Duration::from_millis(100)),
        ))?;
        client.poll(Instant::now())?;
        while let Some(packet) = client.recv()? {
            total += 1;
            in_second += 1;
            if Instant::now() >= next_report {
                println!("--- {in_second} packets in the last second; the latest:");
                print!("{packet}");
                in_second = 0;
                next_report += Duration::from_secs(1);
            }
        }
    }
    Ok(total)
}
