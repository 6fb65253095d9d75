//! The UDP runtime under a flood, on loopback: it still stops when told,
//! still expires leases, and counts what the kernel dropped at its socket.
//! No speed is asserted: the bounds below are generous deadlines for events
//! that today's machine meets in a fraction of them.

use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use colony_hub::{DropReason, HubConfig, Server};
use colony_sys::udp::send_connected;
use colony_testkit::HubOnThread;

/// Subscribes `sock` to `channel` at the hub; answers a cookie challenge if
/// the hub makes one.
fn subscribe(sock: &UdpSocket, hub: SocketAddr, channel: &str) {
    sock.set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    let mut cookie = colony_wire::Cookie::NONE.to_string();
    let mut buf = [0; 2048];
    for _ in 0..100 {
        let req = format!("@ <hub> 0\ncookie v {cookie}\nsubscribe ch {channel}\n");
        sock.send_to(req.as_bytes(), hub).unwrap();
        // Flood packets may come first; look for the reply among them.
        for _ in 0..1000 {
            let Ok(n) = sock.recv(&mut buf) else { break };
            let reply = String::from_utf8_lossy(&buf[..n]).into_owned();
            if !reply.starts_with("@ <hub>") {
                continue;
            }
            if reply.contains("lease") {
                return;
            }
            if let Some(c) = reply.split("cookie v ").nth(1) {
                c.trim().clone_into(&mut cookie);
                break;
            }
        }
    }
    panic!("no lease for {channel}");
}

/// A thread that publishes to `channel` as fast as it can, until told to
/// stop or for `limit` at most (so a failing test ends too).
struct Flood {
    stop: Arc<AtomicBool>,
    sent: Arc<AtomicU64>,
    handle: JoinHandle<()>,
}

fn flood(hub: SocketAddr, channel: &str, limit: Duration) -> Flood {
    let sock = UdpSocket::bind("127.0.0.1:0").unwrap();
    sock.connect(hub).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let sent = Arc::new(AtomicU64::new(0));
    let packet = format!("@ <{channel}> 0\nx a 1\n").into_bytes();
    let handle = {
        let (stop, sent) = (stop.clone(), sent.clone());
        thread::spawn(move || {
            let msgs: Vec<&[u8]> = vec![&packet[..]; 64];
            let end = Instant::now() + limit;
            while !stop.load(Ordering::Relaxed) && Instant::now() < end {
                let n = send_connected(&sock, &msgs).unwrap_or(0);
                sent.fetch_add(n as u64, Ordering::Relaxed);
            }
        })
    };
    Flood { stop, sent, handle }
}

impl Flood {
    fn end(self) {
        self.stop.store(true, Ordering::Relaxed);
        self.handle.join().unwrap();
    }
}

/// Reads whatever waits on a non-blocking socket; returns how much.
fn drain(sock: &UdpSocket) -> usize {
    let mut buf = [0; 2048];
    let mut n = 0;
    while sock.recv(&mut buf).is_ok() {
        n += 1;
    }
    n
}

#[test]
fn the_hub_stops_when_told_while_a_flood_goes_on() {
    let hub = HubOnThread::start();
    // A subscriber makes every flood packet cost the hub a send too.
    let sub = UdpSocket::bind("127.0.0.1:0").unwrap();
    subscribe(&sub, hub.addr, "flood");
    // Two flooders, so the socket stays full even when one is descheduled.
    let floods = [0, 1].map(|_| flood(hub.addr, "flood", Duration::from_secs(20)));
    thread::sleep(Duration::from_millis(500));
    // Before the bound on a poll's work, the hub read on until its socket
    // was empty, which under this flood is when the flood ends (20 s).
    let stopped = hub.stop_within(Duration::from_secs(5));
    let flooding = floods.iter().any(|f| !f.handle.is_finished());
    floods.into_iter().for_each(Flood::end);
    assert!(flooding, "the flood ended first: the test shows nothing");
    assert!(
        stopped.is_some(),
        "the hub did not stop within 5 s of being told"
    );
}

#[test]
fn leases_run_out_while_a_flood_goes_on() {
    let config = HubConfig {
        lease: Duration::from_secs(1),
        ..HubConfig::default()
    };
    let hub = HubOnThread::start_with(config);
    let sub = UdpSocket::bind("127.0.0.1:0").unwrap();
    subscribe(&sub, hub.addr, "flood");
    sub.set_nonblocking(true).unwrap();
    let subscribed = Instant::now();
    let flood = flood(hub.addr, "flood", Duration::from_secs(30));
    // The subscriber never refreshes: once its lease is out, a window in
    // which the flood goes on and nothing reaches it must come.
    let mut got_some = false;
    let mut quiet = false;
    while !quiet && subscribed.elapsed() < Duration::from_secs(20) {
        got_some |= drain(&sub) > 0;
        let before = flood.sent.load(Ordering::Relaxed);
        thread::sleep(Duration::from_millis(300));
        let flooding = flood.sent.load(Ordering::Relaxed) > before;
        quiet = flooding && subscribed.elapsed() > Duration::from_secs(1) && drain(&sub) == 0;
    }
    flood.end();
    let server = hub.stop_within(Duration::from_secs(30)).unwrap();
    assert!(
        got_some,
        "the subscriber got nothing while it held its lease"
    );
    assert!(
        quiet,
        "the flood still reached a subscriber whose lease ran out"
    );
    assert_eq!(server.hub().client_count(), 0);
}

#[test]
fn datagrams_the_kernel_dropped_at_the_hubs_socket_are_counted() {
    // A hub that is not reading: its socket buffer fills and the kernel
    // drops the rest.
    let mut server = Server::bind("127.0.0.1:0", HubConfig::default()).unwrap();
    let addr = server.local_addr().unwrap();
    let sock = UdpSocket::bind("127.0.0.1:0").unwrap();
    sock.connect(addr).unwrap();
    let packet = b"@ <nobody> 0\nx a 1\n";
    let msgs: Vec<&[u8]> = vec![&packet[..]; 64];
    // 64,000 small datagrams: several times what a 4 MiB buffer holds.
    let mut sent = 0;
    let deadline = Instant::now() + Duration::from_secs(20);
    while sent < 64_000 && Instant::now() < deadline {
        sent += send_connected(&sock, &msgs).unwrap();
    }
    while server.poll(Duration::ZERO).unwrap() > 0 {}
    assert_eq!(server.hub().drops(DropReason::ReceiveOverflow), 0);
    // The kernel tells the count with the next datagram it queues.
    sock.send(packet).unwrap();
    let mut handled = 0;
    let deadline = Instant::now() + Duration::from_secs(5);
    while handled == 0 && Instant::now() < deadline {
        handled += server.poll(Duration::from_millis(50)).unwrap();
    }
    let dropped = server.hub().drops(DropReason::ReceiveOverflow);
    assert!(dropped > 0, "no receive drops counted");
    assert!(dropped < sent as u64);
}

#[test]
fn each_subscriber_gets_a_burst_whole_and_in_order() {
    let hub = HubOnThread::start();
    let subs: Vec<UdpSocket> = (0..3)
        .map(|_| UdpSocket::bind("127.0.0.1:0").unwrap())
        .collect();
    for s in &subs {
        subscribe(s, hub.addr, "burst");
    }
    let publisher = UdpSocket::bind("127.0.0.1:0").unwrap();
    publisher.connect(hub.addr).unwrap();
    // Runs of equal lengths (sent as one GSO message per subscriber) and
    // lengths that differ, in one burst.
    let packets: Vec<Vec<u8>> = (0..200)
        .map(|i| {
            let pad = if i < 100 { 0 } else { i % 7 };
            format!("@ <burst> 0\nx n {i:03}{}\n", "0".repeat(pad)).into_bytes()
        })
        .collect();
    let msgs: Vec<&[u8]> = packets.iter().map(Vec::as_slice).collect();
    let mut sent = 0;
    while sent < msgs.len() {
        sent += send_connected(&publisher, &msgs[sent..]).unwrap();
    }
    for s in &subs {
        s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        let mut buf = [0; 2048];
        for p in &packets {
            let n = s.recv(&mut buf).unwrap();
            assert_eq!(
                String::from_utf8_lossy(&buf[..n]),
                String::from_utf8_lossy(p)
            );
        }
    }
    let server = hub.stop_within(Duration::from_secs(30)).unwrap();
    assert_eq!(server.hub().drops(DropReason::SendFailed), 0);
    assert_eq!(server.hub().drops(DropReason::SendFull), 0);
}
