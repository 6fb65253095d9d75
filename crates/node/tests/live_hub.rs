//! Nodes over a real hub on loopback: the same values the bus runs, on
//! threads of their own ([`run`]) and on one mio loop ([`Mux`]).

use std::collections::BTreeSet;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_hub::HubConfig;
use colony_testkit::HubOnThread;
use std::ops::ControlFlow;

use colony_node::{run, Link, Mux, Node, Time};
use colony_wire::{Packet, Priority, Request, Subject};

/// The key the test's hub takes operator requests with.
fn console_key() -> colony_wire::auth::Key {
    colony_wire::auth::Key::new(b"a console key for the live hub tests").unwrap()
}

/// A hub in this process on a free loopback port, stopped when dropped,
/// taking operator requests sealed with [`console_key`].
fn hub() -> HubOnThread {
    HubOnThread::start_with(HubConfig {
        key: Some(console_key()),
        ..HubConfig::default()
    })
}

fn subjects(s: &str) -> BTreeSet<Subject> {
    s.split_whitespace()
        .map(|s| Subject::new(s).unwrap())
        .collect()
}

/// Publishes `ping` every 20 ms (priority 0) and counts the `pong`s it hears.
struct Pinger {
    subs: BTreeSet<Subject>,
    next: Time,
    due: bool,
    pongs: u32,
}

impl Pinger {
    fn new() -> Pinger {
        Pinger {
            subs: subjects("pong"),
            next: Time::ZERO,
            due: false,
            pongs: 0,
        }
    }
}

impl Node for Pinger {
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        &self.subs
    }
    fn handle_packet(&mut self, _: Time, packet: &Packet<'_>) {
        if packet.has_subject("pong") {
            self.pongs += 1;
        }
    }
    fn handle_timeout(&mut self, now: Time) {
        self.due = true;
        self.next = now + Duration::from_millis(20);
    }
    fn poll_timeout(&self) -> Option<Time> {
        Some(self.next)
    }
    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        std::mem::take(&mut self.due).then(|| b"@ <ping> 0\nping\n".to_vec())
    }
}

/// Answers every `ping` with a `pong` at priority 0.
struct Ponger {
    subs: BTreeSet<Subject>,
    owed: u32,
}

impl Ponger {
    fn new() -> Ponger {
        Ponger {
            subs: subjects("ping"),
            owed: 0,
        }
    }
}

impl Node for Ponger {
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        &self.subs
    }
    fn handle_packet(&mut self, _: Time, _: &Packet<'_>) {
        self.owed += 1;
    }
    fn handle_timeout(&mut self, _: Time) {}
    fn poll_timeout(&self) -> Option<Time> {
        None
    }
    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        (self.owed > 0).then(|| {
            self.owed -= 1;
            b"@ <pong> 0\npong\n".to_vec()
        })
    }
}

const LIMIT: Duration = Duration::from_secs(10);

#[test]
fn two_nodes_on_threads_of_their_own_talk_through_the_hub() {
    let hub = hub();
    let epoch = Instant::now();
    let stop = Arc::new(AtomicBool::new(false));
    let pongs = Arc::new(AtomicU32::new(0));

    let ponger = {
        let (stop, addr) = (stop.clone(), hub.addr);
        thread::spawn(move || {
            let mut link = Link::connect(addr, epoch).unwrap();
            run(&mut Ponger::new(), &mut link, &stop, |_, _| {
                ControlFlow::Continue(())
            })
        })
    };
    let pinger = {
        let (stop, addr, pongs) = (stop.clone(), hub.addr, pongs.clone());
        thread::spawn(move || {
            let mut link = Link::connect(addr, epoch).unwrap();
            run(&mut Pinger::new(), &mut link, &stop, |node, _| {
                pongs.store(node.pongs, Ordering::Relaxed);
                ControlFlow::Continue(())
            })
        })
    };
    let end = Instant::now() + LIMIT;
    while pongs.load(Ordering::Relaxed) < 5 && Instant::now() < end {
        thread::sleep(Duration::from_millis(10));
    }
    stop.store(true, Ordering::Relaxed);
    pinger.join().unwrap().unwrap();
    ponger.join().unwrap().unwrap();
    assert!(
        pongs.load(Ordering::Relaxed) >= 5,
        "the pinger heard its pongs"
    );
}

#[test]
fn two_nodes_on_one_mio_loop_talk_through_the_hub_and_obey_its_minimum_priority() {
    let hub = hub();
    let epoch = Instant::now();
    let pongs = Arc::new(AtomicU32::new(0));

    /// A pinger that reports its count where the test can read it.
    struct Counted(Pinger, Arc<AtomicU32>);
    impl Node for Counted {
        fn subscriptions(&self) -> &BTreeSet<Subject> {
            self.0.subscriptions()
        }
        fn handle_packet(&mut self, now: Time, packet: &Packet<'_>) {
            self.0.handle_packet(now, packet);
            self.1.store(self.0.pongs, Ordering::Relaxed);
        }
        fn handle_timeout(&mut self, now: Time) {
            self.0.handle_timeout(now)
        }
        fn poll_timeout(&self) -> Option<Time> {
            self.0.poll_timeout()
        }
        fn poll_transmit(&mut self) -> Option<Vec<u8>> {
            self.0.poll_transmit()
        }
    }

    let mut mux: Mux<Box<dyn Node>> = Mux::new().unwrap();
    mux.add(
        Link::connect(hub.addr, epoch).unwrap(),
        Box::new(Counted(Pinger::new(), pongs.clone())),
    )
    .unwrap();
    mux.add(
        Link::connect(hub.addr, epoch).unwrap(),
        Box::new(Ponger::new()),
    )
    .unwrap();

    let until = |mux: &mut Mux<Box<dyn Node>>, want: u32, limit: Duration| {
        let stop = AtomicBool::new(false);
        let end = Instant::now() + limit;
        mux.run(&stop, |_| {
            if pongs.load(Ordering::Relaxed) >= want || Instant::now() >= end {
                stop.store(true, Ordering::Relaxed);
            }
        })
        .unwrap();
        pongs.load(Ordering::Relaxed)
    };
    assert!(until(&mut mux, 5, LIMIT) >= 5, "the pinger heard its pongs");

    // A console raises the minimum priority above the nodes' 0: the hub
    // forwards none of their packets any more.
    let mut console = UdpClient::connect(hub.addr).unwrap();
    console.set_key(console_key());
    console
        .request(&[Request::MinPriority(Priority(1))])
        .unwrap();
    // The hub answers a new address with a cookie; the client asks again with it.
    let asked = Instant::now();
    while console.session().cookie().is_none() && asked.elapsed() < LIMIT {
        console
            .wait(Some(Instant::now() + Duration::from_millis(50)))
            .unwrap();
        console.recv_reply().unwrap();
    }
    assert!(
        console.session().cookie().is_some(),
        "the hub sent a cookie"
    );
    // Let what was under way before the request arrive.
    until(&mut mux, u32::MAX, Duration::from_millis(200));
    let before = pongs.load(Ordering::Relaxed);
    until(&mut mux, u32::MAX, Duration::from_millis(300));
    assert_eq!(pongs.load(Ordering::Relaxed), before, "nothing got through");

    // A member taken out (a robot killed) is served no more.
    let (_, ponger) = mux.remove(1).expect("the ponger was in");
    assert!(ponger.subscriptions().contains("ping"));
    assert!(mux.node(1).is_none());
    assert!(mux.node(0).is_some());
}

/// Subscribes to `echo` and, at once, publishes one packet on it.
struct Echo {
    subs: BTreeSet<Subject>,
    sent: bool,
    heard: u32,
}

impl Node for Echo {
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        &self.subs
    }
    fn handle_packet(&mut self, _: Time, packet: &Packet<'_>) {
        if packet.has_subject("echo") {
            self.heard += 1;
        }
    }
    fn handle_timeout(&mut self, _: Time) {}
    fn poll_timeout(&self) -> Option<Time> {
        None
    }
    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        (!std::mem::replace(&mut self.sent, true)).then(|| b"@ <echo> 0\nhello\n".to_vec())
    }
}

#[test]
fn a_new_clients_first_packet_waits_for_its_subscription_so_the_answer_is_not_lost() {
    // A new address's first subscription takes a cookie round trip; a packet
    // published at once would reach the hub first and find nobody subscribed
    // (here the node itself: it is its own answer). The link holds it until
    // the hub knows the address.
    let hub = hub();
    let mut link = Link::new(UdpClient::connect(hub.addr).unwrap(), Instant::now());
    let mut echo = Echo {
        subs: subjects("echo"),
        sent: false,
        heard: 0,
    };
    let stop = AtomicBool::new(false);
    let start = Instant::now();
    run(&mut echo, &mut link, &stop, |e, _| {
        if e.heard > 0 || start.elapsed() > LIMIT {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    })
    .unwrap();
    assert!(echo.sent);
    assert_eq!(echo.heard, 1, "the packet went out before the subscription");
}
