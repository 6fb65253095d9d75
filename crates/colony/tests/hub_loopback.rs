//! The hub, its clients and the CLI on real sockets on 127.0.0.1.

use std::net::UdpSocket;
use std::process::Stdio;
use std::time::{Duration, Instant};

use colony_testkit::cli::{colony, HubProcess};
use colony_testkit::client::{drain_until, subscribed};
use colony_wire::{PacketBuilder, Priority, Request};

fn packet(channel: &str, seq: u64) -> Vec<u8> {
    let mut p = PacketBuilder::new([channel], Priority(0));
    p.line("msg").field("seq", seq);
    p.finish().unwrap()
}

#[test]
fn fan_out_to_50_subscribers_loses_nothing_at_a_moderate_rate() {
    let hub = HubProcess::start(&[]);
    let mut subs: Vec<_> = (0..50).map(|_| subscribed(hub.addr, &["vision"])).collect();
    let mut publisher = hub.client();
    let mut counts = vec![0u64; subs.len()];
    let total = 500;
    for seq in 0..total {
        publisher.publish(&packet("vision", seq)).unwrap();
        // About 1,000 packets a second: drain every subscriber as we go.
        std::thread::sleep(Duration::from_micros(1000));
        for (c, n) in subs.iter_mut().zip(&mut counts) {
            while c.recv().unwrap().is_some() {
                *n += 1;
            }
        }
    }
    let deadline = Instant::now() + Duration::from_secs(30);
    while counts.iter().any(|&n| n < total) && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
        for (c, n) in subs.iter_mut().zip(&mut counts) {
            while c.recv().unwrap().is_some() {
                *n += 1;
            }
        }
    }
    assert!(
        counts.iter().all(|&n| n == total),
        "per-subscriber counts: {counts:?}"
    );
}

/// A key file for a hub's consoles, kept for the test's length.
fn key_file() -> (
    tempfile::TempDir,
    std::path::PathBuf,
    colony_wire::auth::Key,
) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("colony.key");
    let bytes = b"a console key for the loopback tests\n";
    std::fs::write(&path, bytes).unwrap();
    (dir, path, colony_wire::auth::Key::new(bytes).unwrap())
}

/// Sends operator requests and waits until the hub has acted on them: the
/// first goes out before the client holds a cookie and is sent again with it.
fn console_request(console: &mut colony_client::UdpClient, requests: &[Request]) {
    console.request(requests).unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    while console.session().cookie().is_none() && Instant::now() < deadline {
        console
            .wait(Some(Instant::now() + Duration::from_millis(20)))
            .unwrap();
        console.recv_reply().unwrap();
    }
    assert!(
        console.session().cookie().is_some(),
        "no cookie from the hub"
    );
    std::thread::sleep(Duration::from_millis(50));
}

#[test]
fn the_minimum_priority_filters_low_priority_packets_until_restored() {
    let (_dir, path, key) = key_file();
    let hub = HubProcess::start(&["--key", path.to_str().unwrap()]);
    let mut sub = subscribed(hub.addr, &["radio"]);
    let mut console = hub.client();
    console.set_key(key);
    console_request(&mut console, &[Request::MinPriority(Priority(10))]);
    let mut ai = hub.client();
    let mut operator = hub.client();
    ai.publish(b"@ <radio> 0\ncmd from \"ai\"\n").unwrap();
    operator
        .publish(b"@ <radio> 10\ncmd from \"operator\"\n")
        .unwrap();
    let got = drain_until(&mut sub, Instant::now() + Duration::from_secs(30), |g| {
        !g.is_empty()
    });
    std::thread::sleep(Duration::from_millis(100));
    let later = drain_until(
        &mut sub,
        Instant::now() + Duration::from_millis(100),
        |_| false,
    );
    assert_eq!(
        got.into_iter().chain(later).collect::<Vec<_>>(),
        ["@ <radio> 10\ncmd from \"operator\"\n"]
    );
    console
        .request(&[Request::MinPriority(Priority(i32::MIN))])
        .unwrap();
    std::thread::sleep(Duration::from_millis(50));
    ai.publish(b"@ <radio> 0\ncmd from \"ai\"\n").unwrap();
    let got = drain_until(&mut sub, Instant::now() + Duration::from_secs(30), |g| {
        !g.is_empty()
    });
    assert_eq!(got, ["@ <radio> 0\ncmd from \"ai\"\n"]);
}

#[test]
fn a_min_priority_from_a_process_that_is_no_console_silences_nobody() {
    let hub = HubProcess::start(&[]);
    let mut sub = subscribed(hub.addr, &["radio"]);
    // The attack as a person would type it, and as a client that does the
    // cookie round trip: neither is a console.
    let raw = UdpSocket::bind("127.0.0.1:0").unwrap();
    raw.send_to(b"@ <hub> 0\nmin_priority value 2147483647\n", hub.addr)
        .unwrap();
    let mut stranger = hub.client();
    console_request(&mut stranger, &[Request::MinPriority(Priority(i32::MAX))]);
    let mut ai = hub.client();
    ai.publish(b"@ <radio> 0\ncmd from \"ai\"\n").unwrap();
    let got = drain_until(&mut sub, Instant::now() + Duration::from_secs(30), |g| {
        !g.is_empty()
    });
    assert_eq!(got, ["@ <radio> 0\ncmd from \"ai\"\n"]);
    let report =
        colony_client::status::fetch_status(&hub.addr.to_string(), Duration::from_secs(30))
            .unwrap();
    assert!(
        report
            .drops
            .iter()
            .any(|(r, n)| r == "not_console" && *n >= 1),
        "{:?}",
        report.drops
    );
}

#[test]
fn a_subject_set_packet_reaches_only_clients_with_every_subject() {
    let hub = HubProcess::start(&[]);
    let mut both = subscribed(hub.addr, &["mobile", "camera"]);
    let mut one = subscribed(hub.addr, &["mobile"]);
    let mut publisher = hub.client();
    publisher
        .publish(b"@ <mobile> <camera> 0\ntask name \"track\"\n")
        .unwrap();
    publisher
        .publish(b"@ <mobile> 0\ntask name \"drive\"\n")
        .unwrap();
    let got_both = drain_until(&mut both, Instant::now() + Duration::from_secs(30), |g| {
        g.len() >= 2
    });
    let got_one = drain_until(&mut one, Instant::now() + Duration::from_millis(500), |g| {
        g.len() >= 2
    });
    assert_eq!(got_both.len(), 2, "{got_both:?}");
    assert_eq!(got_one, ["@ <mobile> 0\ntask name \"drive\"\n"]);
}

#[test]
fn every_client_receives_again_after_a_hub_restart_without_being_restarted() {
    let mut hub = HubProcess::start(&[]);
    let addr = hub.addr;
    let mut subs: Vec<_> = (0..3).map(|_| subscribed(addr, &["vision"])).collect();
    // A publisher thread that never stops, like an overhead camera.
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let publisher = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            let mut c = colony_client::UdpClient::connect(addr).unwrap();
            let mut seq = 0;
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                c.publish(&packet("vision", seq)).unwrap();
                seq += 1;
                std::thread::sleep(Duration::from_millis(20));
            }
        })
    };
    for s in &mut subs {
        assert!(
            !drain_until(s, Instant::now() + Duration::from_secs(30), |g| !g
                .is_empty())
            .is_empty()
        );
    }
    hub.kill();
    // Clients keep polling while the hub is away.
    for s in &mut subs {
        drain_until(s, Instant::now() + Duration::from_millis(300), |_| false);
    }
    let _hub = HubProcess::start_on(&addr.to_string(), &[]);
    let restarted = Instant::now();
    // A generous wait for the event, not a deadline: a busy machine may be slow to schedule
    // the clients, and how fast they come back is a figure for BENCHMARKS.md, not a test.
    let wait = Duration::from_secs(30);
    // Poll every client together, as independent processes would.
    let mut recovered = vec![None; subs.len()];
    while recovered.iter().any(Option::is_none) && restarted.elapsed() < wait {
        for (s, r) in subs.iter_mut().zip(&mut recovered) {
            s.poll(Instant::now()).unwrap();
            if s.recv().unwrap().is_some() && r.is_none() {
                *r = Some(restarted.elapsed());
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    publisher.join().unwrap();
    for (i, r) in recovered.iter().enumerate() {
        assert!(
            r.is_some(),
            "client {i} received nothing within {wait:?} of the hub's restart"
        );
    }
    eprintln!("clients back after the hub's restart: {recovered:?}");
}

#[test]
fn a_killed_client_does_not_disturb_the_others_and_its_lease_expires() {
    let hub = HubProcess::start(&["--lease", "1"]);
    let mut victim = colony()
        .args(["sub", "--hub", &hub.addr.to_string(), "vision"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut survivor = subscribed(hub.addr, &["vision"]);
    let mut publisher = hub.client();
    let wait_for_clients = |n: u64| {
        let deadline = Instant::now() + Duration::from_secs(5);
        loop {
            let report = colony_status(hub.addr);
            // The status command holds a lease of its own.
            if report.client_count == n + 1 {
                return report;
            }
            assert!(
                Instant::now() < deadline,
                "expected {n} clients besides status: {report:?}"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    };
    wait_for_clients(2);
    victim.kill().unwrap();
    victim.wait().unwrap();
    for seq in 0..20 {
        publisher.publish(&packet("vision", seq)).unwrap();
        std::thread::sleep(Duration::from_millis(5));
    }
    let got = drain_until(
        &mut survivor,
        Instant::now() + Duration::from_secs(30),
        |g| g.len() >= 20,
    );
    assert_eq!(got.len(), 20);
    // The survivor keeps refreshing; the dead client's lease runs out.
    let deadline = Instant::now() + Duration::from_millis(1600);
    while Instant::now() < deadline {
        drain_until(
            &mut survivor,
            Instant::now() + Duration::from_millis(50),
            |_| false,
        );
    }
    let report = wait_for_clients(1);
    let me = survivor.local_addr().unwrap().to_string();
    assert!(report.clients.iter().any(|c| c.addr == me), "{report:?}");
}

/// The hub's status; waits (generously) for the answer, since a busy machine may be slow to give it.
fn colony_status(hub: std::net::SocketAddr) -> colony_wire::StatusReport {
    let mut c = subscribed(hub, &["test-status"]);
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        c.request(&[Request::Status]).unwrap();
        let until = Instant::now() + Duration::from_millis(200);
        while Instant::now() < until {
            let _ = c.wait(Some(until));
            if let Some(colony_wire::Reply::Status(r)) = c.recv_reply().unwrap() {
                c.unsubscribe_all().unwrap();
                return r;
            }
        }
        assert!(Instant::now() < deadline, "no status reply");
    }
}

#[test]
fn a_flood_of_malformed_packets_does_not_stop_valid_traffic() {
    let hub = HubProcess::start(&[]);
    let mut sub = subscribed(hub.addr, &["vision"]);
    let attacker = UdpSocket::bind("127.0.0.1:0").unwrap();
    let mut publisher = hub.client();
    let junk: [&[u8]; 6] = [
        b"garbage",
        b"@ <vision> 0\nball x 1 x 2\n",
        b"@ <vision> 0\nball x (y 1\n",
        b"@ <vision> 0\nball s \"open\n",
        b"\xff\xff\xff",
        &[b'@'; 2000],
    ];
    let mut sent = 0;
    let mut received = 0;
    for seq in 0..200u64 {
        for j in &junk {
            for _ in 0..10 {
                attacker.send_to(j, hub.addr).unwrap();
            }
        }
        publisher.publish(&packet("vision", seq)).unwrap();
        sent += 1;
        std::thread::sleep(Duration::from_micros(500));
        while sub.recv().unwrap().is_some() {
            received += 1;
        }
    }
    let rest = drain_until(&mut sub, Instant::now() + Duration::from_secs(30), |g| {
        received + g.len() >= 200
    });
    assert_eq!(
        received + rest.len(),
        200,
        "every valid packet reaches the subscriber"
    );
    let report = colony_status(hub.addr);
    let malformed = report
        .drops
        .iter()
        .find(|(r, _)| r == "malformed")
        .map(|(_, n)| *n);
    assert_eq!(malformed, Some(200 * 60), "{report:?}");
    let vision = report
        .channels
        .iter()
        .find(|c| c.subjects == "vision")
        .unwrap();
    assert_eq!(vision.packets, sent);
}

#[test]
fn a_burst_of_two_thousand_packets_is_taken_in_whole_by_the_hub() {
    let hub = HubProcess::start(&[]);
    let publisher = UdpSocket::bind("127.0.0.1:0").unwrap();
    let packet = b"@ <burst> 0\nping seq 1 pad \"xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx\"\n";
    // Freeze the hub so the whole burst waits in its socket's buffer, as it
    // does when many publishers send at once.
    let signal = |sig: &str| {
        let ok = std::process::Command::new("kill")
            .args([sig, &hub.child.id().to_string()])
            .status()
            .unwrap()
            .success();
        assert!(ok, "kill {sig}");
    };
    signal("-STOP");
    for _ in 0..2000 {
        publisher.send_to(packet, hub.addr).unwrap();
    }
    signal("-CONT");
    std::thread::sleep(Duration::from_millis(300));
    let report = colony_status(hub.addr);
    let burst = report
        .channels
        .iter()
        .find(|c| c.subjects == "burst")
        .map_or(0, |c| c.packets);
    assert_eq!(burst, 2000, "the hub's socket dropped part of the burst");
}
