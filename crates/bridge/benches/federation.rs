//! Federation on loopback, in one run: publish-to-subscriber latency of a
//! 100-byte packet through one hub, through two hubs bridged over Zenoh, and
//! Zenoh's own pub/sub between two local sessions beside them; then packets
//! per second delivered across the bridge, and CPU per forwarded packet.
//!
//! `cargo bench -p colony-bridge --bench federation` (about half a minute).
//! It prints a Markdown section for BENCHMARKS.md.

use std::net::TcpListener;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_bridge::{Bridge, BridgeConfig, Site, Stats};
use colony_client::UdpClient;
use colony_hub::{HubSpec, HubThread, Server};
use zenoh::Wait;

const ROUNDS: usize = 2_000;
const THROUGHPUT_FOR: Duration = Duration::from_secs(3);

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

fn hub(stop: &Arc<AtomicBool>) -> HubThread {
    HubThread::spawn(Server::start(&HubSpec::new("127.0.0.1:0")).unwrap(), stop).unwrap()
}

/// A 100-byte packet on `bench` carrying `n`.
fn packet(n: u64) -> Vec<u8> {
    let mut p = format!("@ <bench> 0\nmsg n {n:>12} pad ").into_bytes();
    p.resize(99, b'x');
    p.push(b'\n');
    p
}

fn quantiles(mut us: Vec<f64>) -> (f64, f64) {
    us.sort_by(f64::total_cmp);
    let at = |q: f64| us[((us.len() - 1) as f64 * q).round() as usize];
    (at(0.5), at(0.99))
}

/// Waits for packet `n` at `sub`; `false` if it did not come within a second.
fn await_packet(sub: &mut UdpClient, n: u64) -> bool {
    let deadline = Instant::now() + Duration::from_secs(1);
    let want = format!("msg n {n:>12} ");
    while Instant::now() < deadline {
        while let Some(p) = sub.recv().unwrap() {
            if p.as_str().contains(&want) {
                return true;
            }
        }
        sub.wait(Some(deadline)).unwrap();
    }
    false
}

/// Sequential round trips publisher -> ... -> subscriber; (p50, p99, lost).
fn hub_latency(publisher: &mut UdpClient, sub: &mut UdpClient) -> (f64, f64, usize) {
    let mut us = Vec::with_capacity(ROUNDS);
    let mut lost = 0;
    for n in 0..ROUNDS as u64 {
        let t = Instant::now();
        publisher.publish(&packet(n)).unwrap();
        if await_packet(sub, n) {
            us.push(t.elapsed().as_secs_f64() * 1e6);
        } else {
            lost += 1;
        }
        sub.poll(Instant::now()).unwrap();
    }
    let (p50, p99) = quantiles(us);
    (p50, p99, lost)
}

fn subscribed(addr: &str) -> UdpClient {
    let mut c = UdpClient::connect(addr).unwrap();
    c.subscribe("bench").unwrap();
    let deadline = Instant::now() + Duration::from_secs(5);
    while c.session().lease().is_none() && Instant::now() < deadline {
        c.wait(Some(Instant::now() + Duration::from_millis(10)))
            .unwrap();
        c.poll(Instant::now()).unwrap();
        while c.recv_reply().unwrap().is_some() {}
    }
    c
}

/// The process's CPU time so far (user + system), from /proc.
fn cpu_time() -> Duration {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or_default();
    let fields: Vec<u64> = after
        .split_whitespace()
        .map(|f| f.parse().unwrap_or(0))
        .collect();
    // Fields 14 and 15 of stat; 12 and 13 counting from after the name.
    let ticks = fields.get(11).copied().unwrap_or(0) + fields.get(12).copied().unwrap_or(0);
    Duration::from_secs_f64(ticks as f64 / 100.0)
}

/// Publishes as fast as the publisher can for [`THROUGHPUT_FOR`]; returns
/// (sent, delivered, CPU time of the whole process).
fn throughput(publisher: &mut UdpClient, sub: &mut UdpClient) -> (u64, u64, Duration) {
    let stop = Arc::new(AtomicBool::new(false));
    let cpu0 = cpu_time();
    let (tx, rx) = mpsc::channel();
    let mut sub_thread_sub = std::mem::replace(sub, UdpClient::connect("127.0.0.1:9").unwrap());
    let s = stop.clone();
    let counter = std::thread::spawn(move || {
        let mut got = 0u64;
        let mut quiet_since = None::<Instant>;
        loop {
            let mut any = false;
            while let Some(_p) = sub_thread_sub.recv().unwrap() {
                got += 1;
                any = true;
            }
            sub_thread_sub.poll(Instant::now()).unwrap();
            if s.load(Ordering::Relaxed) {
                match (any, quiet_since) {
                    (true, _) => quiet_since = None,
                    (false, None) => quiet_since = Some(Instant::now()),
                    (false, Some(t)) if t.elapsed() > Duration::from_millis(500) => break,
                    _ => {}
                }
            }
            let _ = sub_thread_sub.wait(Some(Instant::now() + Duration::from_millis(10)));
        }
        tx.send(sub_thread_sub).unwrap();
        got
    });
    let start = Instant::now();
    let mut sent = 0u64;
    while start.elapsed() < THROUGHPUT_FOR {
        for _ in 0..64 {
            publisher.publish(&packet(sent)).unwrap();
            sent += 1;
        }
        // Paced a little, so the publisher does not take a whole core from
        // the hubs and bridges it measures on a 2-core machine.
        std::thread::yield_now();
    }
    stop.store(true, Ordering::Relaxed);
    let got = counter.join().unwrap();
    *sub = rx.recv().unwrap();
    (sent, got, cpu_time().saturating_sub(cpu0))
}

fn main() {
    // `cargo bench` passes --bench; any other argument is a filter we do not have.
    let stop = Arc::new(AtomicBool::new(false));
    let (ha, hb) = (hub(&stop), hub(&stop));
    let (a_addr, b_addr) = (ha.addr().to_string(), hb.addr().to_string());

    // One hub.
    let mut publisher = UdpClient::connect(a_addr.as_str()).unwrap();
    let mut local = subscribed(&a_addr);
    let one = hub_latency(&mut publisher, &mut local);
    let one_tp = throughput(&mut publisher, &mut local);
    drop(local);

    // Two hubs bridged (Zenoh peers on loopback TCP).
    let port = free_port();
    let mut bridges = Vec::new();
    let mut stats: Vec<Arc<Stats>> = Vec::new();
    for (addr, site, connect, listen) in [
        (&a_addr, "a", vec![], vec![format!("tcp/127.0.0.1:{port}")]),
        (&b_addr, "b", vec![format!("tcp/127.0.0.1:{port}")], vec![]),
    ] {
        let mut c = BridgeConfig::new(addr, Site::new(site).unwrap());
        c.connect = connect;
        c.listen = listen;
        let mut bridge = Bridge::start(c, None).unwrap();
        stats.push(bridge.stats());
        let s = stop.clone();
        bridges.push(std::thread::spawn(move || bridge.run(&s).unwrap()));
    }
    let mut remote = subscribed(&b_addr);
    let warm = Instant::now();
    let mut n = 1_000_000;
    loop {
        publisher.publish(&packet(n)).unwrap();
        if await_packet(&mut remote, n) {
            break;
        }
        assert!(
            warm.elapsed() < Duration::from_secs(20),
            "the bridge never carried a packet"
        );
        n += 1;
    }
    let two = hub_latency(&mut publisher, &mut remote);
    let two_tp = throughput(&mut publisher, &mut remote);
    let lost = Stats::get(&stats[1].lost);
    let overflow = Stats::get(&stats[1].overflow);

    // Zenoh alone: two sessions, one putting, one subscribed.
    let zport = free_port();
    let open = |connect: Vec<String>, listen: Vec<String>| {
        let mut c = zenoh::Config::default();
        c.insert_json5("scouting/multicast/enabled", "false")
            .unwrap();
        c.insert_json5("connect/endpoints", &format!("{connect:?}"))
            .unwrap();
        c.insert_json5("listen/endpoints", &format!("{listen:?}"))
            .unwrap();
        zenoh::open(c).wait().unwrap()
    };
    let z_sub = open(vec![], vec![format!("tcp/127.0.0.1:{zport}")]);
    let z_pub = open(vec![format!("tcp/127.0.0.1:{zport}")], vec![]);
    let (ztx, zrx) = mpsc::channel::<Vec<u8>>();
    let _sub = z_sub
        .declare_subscriber("bench/x")
        .callback(move |s| {
            let _ = ztx.send(s.payload().to_bytes().into_owned());
        })
        .wait()
        .unwrap();
    let zput = |n: u64| z_pub.put("bench/x", packet(n)).wait().unwrap();
    let warm = Instant::now();
    loop {
        zput(0);
        if zrx.recv_timeout(Duration::from_millis(100)).is_ok() {
            break;
        }
        assert!(
            warm.elapsed() < Duration::from_secs(20),
            "zenoh never delivered"
        );
    }
    while zrx.try_recv().is_ok() {}
    let mut us = Vec::with_capacity(ROUNDS);
    for n in 0..ROUNDS as u64 {
        let t = Instant::now();
        zput(n);
        let want = packet(n);
        while let Ok(got) = zrx.recv_timeout(Duration::from_secs(1)) {
            if got == want {
                us.push(t.elapsed().as_secs_f64() * 1e6);
                break;
            }
        }
    }
    let zenoh = quantiles(us);

    stop.store(true, Ordering::Relaxed);
    for b in bridges {
        let _ = b.join();
    }
    let _ = (ha.stop(), hb.stop());

    let rate = |(sent, got, _): (u64, u64, Duration)| {
        (got as f64 / THROUGHPUT_FOR.as_secs_f64(), sent, got)
    };
    let per_packet =
        |(_, got, cpu): (u64, u64, Duration)| cpu.as_secs_f64() * 1e6 / got.max(1) as f64;
    println!("## Federation over Zenoh on loopback\n");
    println!(
        "`cargo bench -p colony-bridge --bench federation`; {} cores; {} sequential round trips of a 100-byte packet, then {} s of publishing as fast as one client can.\n",
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        ROUNDS,
        THROUGHPUT_FOR.as_secs()
    );
    println!("| path | p50 µs | p99 µs | lost |");
    println!("|---|---:|---:|---:|");
    println!(
        "| publisher → hub → subscriber | {:.0} | {:.0} | {} |",
        one.0, one.1, one.2
    );
    println!(
        "| publisher → hub A → bridge → Zenoh → bridge → hub B → subscriber | {:.0} | {:.0} | {} |",
        two.0, two.1, two.2
    );
    println!(
        "| Zenoh alone: put → subscriber, two local sessions | {:.0} | {:.0} | — |",
        zenoh.0, zenoh.1
    );
    let (r1, s1, g1) = rate(one_tp);
    let (r2, s2, g2) = rate(two_tp);
    println!(
        "\n| path | sent | delivered | delivered/s | CPU µs per delivered packet (whole process) |"
    );
    println!("|---|---:|---:|---:|---:|");
    println!(
        "| one hub | {s1} | {g1} | {r1:.0} | {:.1} |",
        per_packet(one_tp)
    );
    println!(
        "| two hubs bridged | {s2} | {g2} | {r2:.0} | {:.1} |",
        per_packet(two_tp)
    );
    println!("\nThe receiving bridge counted {lost} packets lost between the sites and {overflow} dropped on its own queue.");
}
