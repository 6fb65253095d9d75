//! `colony bridge` as a user runs it: hub and bridge processes on loopback,
//! bridges killed with SIGKILL and started again, and Zenoh's own Python
//! package as a client colony did not write.

use std::collections::BTreeSet;
use std::io::{BufRead, BufReader};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::Stdio;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_testkit::cli::{colony, HubProcess, Proc};
use colony_testkit::client::{drain_until, subscribed};
use colony_testkit::net::{free_tcp_port, tcp_endpoint};

/// A `colony bridge` process, killed (SIGKILL) when dropped.
fn bridge(hub: SocketAddr, site: &str, extra: &[String]) -> Proc {
    let hub = hub.to_string();
    let mut args = vec!["bridge", "--hub", &hub, "--site", site];
    args.extend(extra.iter().map(String::as_str));
    Proc::start(&args)
}

/// Publishes `@ <stream> 0\nmsg n N\n`, N = 1, 2, ..., every 5 ms from a
/// thread until stopped; the last N sent is readable at any time.
struct Stream {
    stop: Arc<AtomicBool>,
    sent: Arc<AtomicU64>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Stream {
    fn start(hub: SocketAddr) -> Stream {
        let stop = Arc::new(AtomicBool::new(false));
        let sent = Arc::new(AtomicU64::new(0));
        let (s, n) = (stop.clone(), sent.clone());
        let thread = std::thread::spawn(move || {
            let mut c = UdpClient::connect(hub).unwrap();
            let mut i = 0;
            while !s.load(Ordering::Relaxed) {
                i += 1;
                c.publish(format!("@ <stream> 0\nmsg n {i}\n").as_bytes())
                    .unwrap();
                n.store(i, Ordering::Relaxed);
                std::thread::sleep(Duration::from_millis(5));
            }
        });
        Stream {
            stop,
            sent,
            thread: Some(thread),
        }
    }

    fn sent(&self) -> u64 {
        self.sent.load(Ordering::Relaxed)
    }
}

impl Drop for Stream {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

type Received = Vec<(Instant, u64)>;

/// The numbers each client receives on `stream` until `deadline`, or until
/// every one has some (`first`), taking from all of them in turn so that
/// each arrival is timed when it comes.
fn receive(clients: &mut [(&mut UdpClient, &mut Received)], deadline: Instant, first: bool) {
    while Instant::now() < deadline {
        if first && clients.iter().all(|(_, got)| !got.is_empty()) {
            return;
        }
        for (c, got) in clients.iter_mut() {
            let _ = c.wait(Some(Instant::now() + Duration::from_millis(2)));
            c.poll(Instant::now()).unwrap();
            while let Some(p) = c.recv().unwrap() {
                if let Some(n) = p.line("msg").and_then(|l| l.i64("n").ok()) {
                    got.push((Instant::now(), n as u64));
                }
            }
        }
    }
}

#[test]
fn killing_the_middle_bridge_of_three_loses_only_the_gap_and_recovers_within_three_seconds() {
    let (pa, pb) = (free_tcp_port(), free_tcp_port());
    let (ha, hb, hc) = (
        HubProcess::start(&[]),
        HubProcess::start(&[]),
        HubProcess::start(&[]),
    );
    let _a = bridge(ha.addr, "a", &["--listen".into(), tcp_endpoint(pa)]);
    let b_args = [
        "--connect".into(),
        tcp_endpoint(pa),
        "--listen".into(),
        tcp_endpoint(pb),
    ];
    let mut b = bridge(hb.addr, "b", &b_args);
    let _c = bridge(hc.addr, "c", &["--connect".into(), tcp_endpoint(pb)]);
    let mut on_b = subscribed(hb.addr, &["stream"]);
    let mut on_c = subscribed(hc.addr, &["stream"]);
    let stream = Stream::start(ha.addr);

    let (mut got_b, mut got_c) = (Vec::new(), Vec::new());
    let flowing = Instant::now() + Duration::from_secs(30);
    receive(
        &mut [(&mut on_b, &mut got_b), (&mut on_c, &mut got_c)],
        flowing,
        true,
    );
    assert!(
        !got_b.is_empty() && !got_c.is_empty(),
        "the stream never crossed"
    );

    // `colony status` on B's hub shows the bridge and what it imports.
    let asked = Instant::now();
    loop {
        let status = colony()
            .args(["status", "--hub", &hb.addr.to_string()])
            .output()
            .unwrap();
        let status = String::from_utf8_lossy(&status.stdout).into_owned();
        if status.contains("bridge b run") && status.contains("imports 1 (stream)") {
            break;
        }
        assert!(asked.elapsed() < Duration::from_secs(10), "{status}");
        std::thread::sleep(Duration::from_millis(200));
    }

    // Kill -9 the middle bridge under the stream; start it again a second later.
    b.kill();
    let killed_at = stream.sent();
    std::thread::sleep(Duration::from_secs(1));
    let restarted = Instant::now();
    let sent_at_restart = stream.sent();
    let _b = bridge(hb.addr, "b", &b_args);
    let settle = Instant::now() + Duration::from_secs(6);
    receive(
        &mut [(&mut on_b, &mut got_b), (&mut on_c, &mut got_c)],
        settle,
        false,
    );
    let last_sent = stream.sent();
    drop(stream);
    let tail = Instant::now() + Duration::from_secs(1);
    receive(
        &mut [(&mut on_b, &mut got_b), (&mut on_c, &mut got_c)],
        tail,
        false,
    );

    for (site, got) in [("b", &got_b), ("c", &got_c)] {
        let numbers: Vec<u64> = got.iter().map(|(_, n)| *n).collect();
        let distinct: BTreeSet<u64> = numbers.iter().copied().collect();
        assert_eq!(
            distinct.len(),
            numbers.len(),
            "site {site} got a packet twice"
        );
        // Within 3 s of the restart, packets sent after it arrive again...
        let back = got
            .iter()
            .find(|(_, n)| *n > sent_at_restart)
            .unwrap_or_else(|| panic!("site {site} never received again"));
        let took = back.0.duration_since(restarted);
        assert!(
            took < Duration::from_secs(3),
            "site {site} received again after {took:?}"
        );
        // ...and from then on, none is lost.
        let first = back.1;
        let after = distinct.range(first..).count() as u64;
        let missing = (last_sent - first + 1) - after;
        assert_eq!(
            missing, 0,
            "site {site} lost {missing} packets after it recovered"
        );
        let heard_first = numbers[0];
        let lost_in_gap = (first - heard_first) - distinct.range(heard_first..first).count() as u64;
        eprintln!(
            "# site {site}: the bridge killed at packet {killed_at}, restarted at {sent_at_restart}; \
             packets flowed again {took:?} after the restart; {lost_in_gap} lost in the gap, none after"
        );
    }
}

#[test]
fn zenohs_own_python_package_receives_a_colony_channel_and_publishes_one_back() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let deps = std::env::var_os("COLONY_PYDEPS")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("target/pydeps"));
    assert!(
        deps.join("zenoh").exists(),
        "Zenoh's Python package is not in {}: run the README's test command, `scripts/test`, \
         which installs it (python3 -m pip install --target target/pydeps eclipse-zenoh==1.10.2)",
        deps.display()
    );
    let port = free_tcp_port();
    let hub = HubProcess::start(&[]);
    let _bridge = bridge(hub.addr, "lab", &["--listen".into(), tcp_endpoint(port)]);
    let mut python = std::process::Command::new("python3")
        .arg(root.join("python/tests/zenoh_peer.py"))
        .arg(tcp_endpoint(port))
        .env("PYTHONPATH", &deps)
        .env("PYTHONUNBUFFERED", "1")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("run python3");
    let (tx, rx) = std::sync::mpsc::channel();
    let out = python.stdout.take().unwrap();
    std::thread::spawn(move || {
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let mut back = subscribed(hub.addr, &["to_colony"]);
    let mut publisher = hub.client();
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut python_got = None;
    let mut colony_got = None;
    while (python_got.is_none() || colony_got.is_none()) && Instant::now() < deadline {
        publisher
            .publish(b"@ <from_colony> 0\nhello from colony\n")
            .unwrap();
        publisher.poll(Instant::now()).unwrap();
        while let Ok(line) = rx.try_recv() {
            if let Some(rest) = line.strip_prefix("got ") {
                python_got = Some(rest.to_owned());
            }
        }
        let got = drain_until(
            &mut back,
            Instant::now() + Duration::from_millis(100),
            |g| !g.is_empty(),
        );
        if let Some(p) = got.into_iter().next() {
            colony_got = Some(p);
        }
    }
    let _ = python.kill();
    let _ = python.wait();
    let python_got = python_got.expect("Python's Zenoh subscriber never received from_colony");
    assert!(
        python_got.contains("colony/lab/ch/from_colony")
            && python_got.contains("hello from colony"),
        "{python_got}"
    );
    let colony_got = colony_got.expect("the hub's subscriber never received Python's to_colony");
    assert!(colony_got.contains("reply from python"), "{colony_got}");
}

#[test]
fn a_bridge_with_no_hub_says_so_within_seconds_and_keeps_trying() {
    // A port nothing listens on.
    let quiet = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    let hub = quiet.local_addr().unwrap().to_string();
    drop(quiet);
    let listen = tcp_endpoint(free_tcp_port());
    let mut child = colony()
        .args([
            "bridge", "--hub", &hub, "--site", "lonely", "--listen", &listen,
        ])
        .env("COLONY_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let err = child.stderr.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(err).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                return;
            }
        }
    });
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut said = None;
    while said.is_none() && Instant::now() < deadline {
        if let Ok(line) = rx.recv_timeout(Duration::from_millis(200)) {
            if line.contains("no answer from the hub") {
                said = Some(line);
            }
        }
    }
    let still_running = child.try_wait().unwrap().is_none();
    let _ = child.kill();
    let _ = child.wait();
    let said = said.expect("the bridge never said its hub does not answer");
    assert!(said.contains(&hub), "{said}");
    assert!(still_running, "it keeps trying");
}
