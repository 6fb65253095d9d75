//! MURDOCH deployed: announcement-to-award and announcement-to-done times
//! with every robot's agent its own `colony tasks agent` process, on one
//! loopback hub. The auction's bid window (200 ms by default) is most of
//! announcement-to-award by design: bids are taken for that long.
//!
//! `cargo bench -p colony --bench auction` (about a minute). Prints a
//! Markdown section for BENCHMARKS.md.

use std::process::{Child, Command, Stdio};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_hub::{HubSpec, HubThread, Server};
use colony_tasks::protocol::{TaskSpec, Token};
use colony_tasks::{AnnouncerEvent, AuctionConfig, Backoff, Link, UserAgent, UserEvent};

const TASKS: usize = 200;
const ROBOTS: [(&str, &str); 5] = [
    ("r1", "mobile,laser"),
    ("r2", "mobile,camera"),
    ("r3", "mobile,laser,camera"),
    ("r4", "mobile,gripper"),
    ("r5", "mobile,laser,camera,gripper"),
];

struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

fn main() {
    let stop = Arc::new(AtomicBool::new(false));
    let hub =
        HubThread::spawn(Server::start(&HubSpec::new("127.0.0.1:0")).unwrap(), &stop).unwrap();
    let addr = hub.addr();
    let _robots: Vec<Killed> = ROBOTS
        .iter()
        .map(|(name, resources)| {
            Killed(
                Command::new(env!("CARGO_BIN_EXE_colony"))
                    .args(["tasks", "agent", "--hub", &addr.to_string(), "--name", name])
                    .args(["--resources", resources, "--drain", "0"])
                    .env("COLONY_LOG", "warn")
                    .stdout(Stdio::null())
                    .spawn()
                    .expect("start colony tasks agent"),
            )
        })
        .collect();
    std::thread::sleep(Duration::from_secs(2));

    let epoch = Instant::now();
    let mut link = Link::new(UdpClient::connect(addr).unwrap(), epoch);
    let backoff = Backoff {
        give_up_after: Duration::from_secs(30),
        ..Backoff::default()
    };
    let mut user = UserAgent::new(
        Token::new("bench").unwrap(),
        AuctionConfig::default(),
        backoff,
        1,
    );
    link.flush(&mut user).unwrap();
    let needs = ["camera", "laser", "gripper", "laser,camera", "mobile"];
    let (mut to_award, mut to_done) = (Vec::new(), Vec::new());
    for i in 0..TASKS {
        let spec = TaskSpec::new("bench", needs[i % needs.len()].parse().unwrap()).length(0.05);
        let start = Instant::now();
        user.introduce(link.now(), spec).unwrap();
        let mut awarded = None;
        'task: loop {
            link.pump(&mut user).unwrap();
            while let Some(e) = user.poll_event() {
                match e {
                    UserEvent::Auction {
                        event: AnnouncerEvent::Awarded { .. },
                        ..
                    } => {
                        awarded.get_or_insert(start.elapsed());
                    }
                    UserEvent::Completed { .. } | UserEvent::GaveUp { .. } => break 'task,
                    _ => {}
                }
            }
            link.wait(&user, Some(Duration::from_millis(10))).unwrap();
        }
        if let Some(a) = awarded {
            to_award.push(a.as_secs_f64() * 1e3);
            to_done.push(start.elapsed().as_secs_f64() * 1e3);
        }
    }
    to_award.sort_by(f64::total_cmp);
    to_done.sort_by(f64::total_cmp);
    println!("## Task allocation deployed: one agent process per robot\n");
    println!(
        "`cargo bench -p colony --bench auction`; {} cores; one hub on loopback, {} `colony tasks agent` processes, {} tasks of 50 ms introduced one after another (bid window 200 ms, the default).\n",
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        ROBOTS.len(),
        TASKS
    );
    println!("| from the announcement to | p50 ms | p99 ms | tasks |");
    println!("|---|---:|---:|---:|");
    for (what, v) in [("the award", &to_award), ("done", &to_done)] {
        println!(
            "| {what} | {:.1} | {:.1} | {} |",
            quantile(v, 0.5),
            quantile(v, 0.99),
            v.len()
        );
    }
    drop(link);
    let _ = hub.stop();
}
